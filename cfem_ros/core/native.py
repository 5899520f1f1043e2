# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The compiled aerodynamic-table and shape-distance functions (``cpp/*.hpp``).

``load()`` returns the extension module ``cfem_ros.core._aeroshapes``,
building it first (g++ and pybind11, about 20 s) when it is missing or
older than its sources; ``make venv`` builds it once (``python -m
cfem_ros.core.native``).
"""

from __future__ import annotations

import hashlib
import importlib
import importlib.machinery
import os
import subprocess
import sys
import sysconfig

NAME = '_aeroshapes'
HERE = os.path.dirname(os.path.abspath(__file__))
SOURCES = os.path.join(HERE, 'cpp')
_MODULE = None


class BuildError(RuntimeError):
    """The extension could not be compiled (no compiler or pybind11): the message says which."""


def _digest() -> str:
    """Return the SHA-256 of the C++ sources (what the built module was made from)."""
    digest = hashlib.sha256()
    for name in sorted(os.listdir(SOURCES)):
        if name.endswith(('.hpp', '.cpp')):
            with open(os.path.join(SOURCES, name), 'rb') as handle:
                digest.update(name.encode() + b'\0' + handle.read())
    return digest.hexdigest()


def _target() -> str:
    return os.path.join(HERE, NAME + importlib.machinery.EXTENSION_SUFFIXES[0])


def build(force: bool = False) -> str:
    """Compile the extension next to this module if it is missing or stale; return its path."""
    target, stamp = _target(), os.path.join(HERE, NAME + '.sha256')
    digest = _digest()
    if not force and os.path.exists(target) and os.path.exists(stamp):
        with open(stamp, encoding='ascii') as handle:
            if handle.read().strip() == digest:
                return target
    try:
        import pybind11
    except ImportError as err:
        raise BuildError('building cfem_ros.core._aeroshapes needs pybind11 '
                         "(pip install 'pybind11>=2.10')") from err
    compiler = os.environ.get('CXX', 'g++')
    partial = f'{target}.{os.getpid()}.tmp'
    command = [compiler, '-O2', '-std=c++17', '-shared', '-fPIC', '-fvisibility=hidden',
               '-I', pybind11.get_include(), '-I', sysconfig.get_paths()['include'],
               '-I', SOURCES, os.path.join(SOURCES, 'aeroshapes.cpp'), '-o', partial]
    try:
        result = subprocess.run(command, capture_output=True, text=True, check=False)
    except OSError as err:
        raise BuildError(f'building cfem_ros.core._aeroshapes needs a C++17 compiler '
                         f'({compiler}: {err})') from err
    if result.returncode != 0:
        raise BuildError(f'{compiler} failed on cpp/aeroshapes.cpp:\n{result.stderr[-4000:]}')
    os.replace(partial, target)
    with open(stamp, 'w', encoding='ascii') as handle:
        handle.write(digest + '\n')
    return target


def load():
    """Return the extension module, built first if needed."""
    global _MODULE
    if _MODULE is None:
        build()
        _MODULE = importlib.import_module(f'cfem_ros.core.{NAME}')
    return _MODULE


if __name__ == '__main__':
    print(build(force='--force' in sys.argv))
