# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The kernel compiled ahead of time into an extension module, so that a run need not import numba.

``python -m cfem_ros.core.aot`` (run by ``make`` after installing) compiles
the public functions of ``kernel`` with numba's ahead-of-time compiler into
``cfem_ros/core/_kernel_aot*.so``, with the signatures the JIT compiled
while it ran the warm-up (``warmup.warm_up``), the same compiler options
(``fastmath`` contract, ``error_model``) and the host CPU's name and
features, so that its results are bit-identical to the JIT's. The module
holds a hash of ``kernel.py``'s source.

On ``import cfem_ros.core.kernel``, a finder that ``cfem_ros.core`` puts
first on ``sys.meta_path`` asks ``kernel_spec``:
when the extension exists and was built from the current ``kernel.py``
(and ``CFEM_ROS_JIT`` is not set), the kernel module is ``kernel.py`` run
with a stand-in for numba (its constants, and its functions as plain
Python), whose public functions are then replaced by the compiled ones. A
call the compiled code cannot take (other argument types) goes to the JIT,
which is loaded then. Otherwise ``kernel.py`` is imported as it is: the JIT.
"""

from __future__ import annotations

import hashlib
import importlib.machinery
import importlib.util
import json
import os
import sys
import types

import numpy as np

KERNEL = 'cfem_ros.core.kernel'
EXTENSION = 'cfem_ros.core._kernel_aot'
#: Set to any non-empty value to use the JIT even where the extension exists.
FORCE_JIT = 'CFEM_ROS_JIT'

_HERE = os.path.dirname(os.path.abspath(__file__))
_SOURCE = os.path.join(_HERE, 'kernel.py')
#: The exported functions' argument kinds and the source hash, written with the extension.
TABLE = os.path.join(_HERE, '_kernel_aot.json')


#: The modules whose numba functions the kernel compiles together (kernel.py
#: calls those of loads.py and motion.py): an extension, or numba's cache, is only as current
#: as the oldest of them.
COMPILED_SOURCES = ('kernel.py', 'loads.py', 'motion.py')


def source_hash(path: str = _SOURCE) -> int:
    """Return the hash of the kernel's sources (kernel.py at path, the others beside it)."""
    digest = hashlib.sha256()
    for name in COMPILED_SOURCES:
        with open(os.path.join(os.path.dirname(path), name), 'rb') as handle:
            digest.update(handle.read())
    return int(digest.hexdigest()[:15], 16)


def load_extension():
    """Return the compiled extension if it and its table match the sources, else None."""
    if os.environ.get(FORCE_JIT):
        return None
    try:
        with open(TABLE, encoding='utf-8') as handle:
            table = json.load(handle)
        current = source_hash()
        if table.get('hash') != current or importlib.util.find_spec(EXTENSION) is None:
            return None
        extension = importlib.import_module(EXTENSION)
        if extension._source_hash() != current:
            return None
    except (ImportError, AttributeError, OSError, ValueError):
        return None
    extension.TABLE = table['functions']
    return extension


class _Signature:
    """
    The argument kinds of one compiled variant, checked as numba's dispatcher would type them.

    Checked on every call of the compiled kernel, so the kinds are sorted
    once into scalars and arrays (with their dtypes made) and each argument
    costs a few attribute reads; nothing is cached per argument (an array's
    flags can change between calls).
    """

    def __init__(self, kinds):
        self.count = len(kinds)
        self.floats = tuple(i for i, kind in enumerate(kinds) if kind[0] == 'float64')
        self.ints = tuple(i for i, kind in enumerate(kinds) if kind[0] == 'int64')
        # (index, dtype, ndim, layout, writeable)
        self.arrays = tuple((i, np.dtype(kind[1]), kind[2], kind[3], kind[4])
                            for i, kind in enumerate(kinds) if kind[0] == 'array')
        if len(self.floats) + len(self.ints) + len(self.arrays) != self.count:
            self.count = -1   # a kind not checked here: nothing fits

    def admits(self, args) -> bool:
        """Tell whether numba's JIT would type args as these kinds."""
        if len(args) != self.count:
            return False
        for i in self.floats:
            if type(args[i]) is not float and type(args[i]) is not np.float64:
                return False
        for i in self.ints:
            value = args[i]
            if not ((type(value) is int and -2 ** 63 <= value < 2 ** 63)
                    or type(value) is np.int64):
                return False
        for i, dtype, ndim, layout, writeable in self.arrays:
            value = args[i]
            if type(value) is not np.ndarray or value.ndim != ndim or value.dtype != dtype:
                return False
            flags = value.flags
            if flags.writeable != writeable or not flags.aligned:
                return False
            if flags.c_contiguous:   # numba's layout: 'C' first (a 1-d array is both)
                if layout != 'C':
                    return False
            elif layout != ('F' if flags.f_contiguous else 'A'):
                return False
        return True


class _Numba(types.ModuleType):
    """A stand-in for numba while kernel.py runs: ``njit`` leaves a function as it is."""

    def njit(self, *args, **options):
        """Return the function itself (or a decorator that does)."""
        if args and callable(args[0]):
            return args[0]
        return lambda function: function


_jit = None


def jit_kernel():
    """Return kernel.py compiled by numba's JIT (loaded on first use)."""
    global _jit
    if _jit is None:
        # under the kernel's own name, as numba's cache knows its functions; not put in
        # sys.modules, where the name stays with the compiled kernel
        # the modules it calls (loads.py, motion.py) were run with the stand-in, their
        # functions plain Python that numba cannot call: it imports its own, compiled,
        # and the package keeps the ones it had
        package = sys.modules[KERNEL.rsplit('.', 1)[0]]
        helpers = [name[:-3] for name in COMPILED_SOURCES if name != 'kernel.py']
        saved = {name: (sys.modules.pop(f'{package.__name__}.{name}', None),
                        vars(package).pop(name, None)) for name in helpers}
        try:
            spec = importlib.util.spec_from_file_location(KERNEL, _SOURCE)
            module = importlib.util.module_from_spec(spec)
            spec.loader.exec_module(module)
        finally:
            for name, (entry, attribute) in saved.items():
                if entry is not None:
                    sys.modules[f'{package.__name__}.{name}'] = entry
                if attribute is not None:
                    setattr(package, name, attribute)
        _jit = module
    return _jit


def _compiled(name, variants):
    """
    Call the compiled variant of name that fits the arguments; the JIT takes the others.

    variants: (function, argument kinds) pairs. The compiled code trusts its
    arguments' types, so they are checked here as numba's dispatcher would.
    """
    checked = [(function, _Signature(kinds)) for function, kinds in variants]

    def call(*args):
        for function, signature in checked:
            if signature.admits(args):
                return function(*args)
        return getattr(jit_kernel(), name)(*args)
    call.__name__ = call.__qualname__ = name
    call.__doc__ = variants[0][0].__doc__
    return call


def _lazy_jit(name):
    """Call the JIT's name, loading the JIT on first call."""
    def call(*args):
        return getattr(jit_kernel(), name)(*args)
    call.__name__ = call.__qualname__ = name
    return call


class _Loader(importlib.machinery.SourceFileLoader):
    """Run kernel.py with the numba stand-in, then put the compiled functions in."""

    def __init__(self, fullname, path, extension):
        super().__init__(fullname, path)
        self.extension = extension

    def exec_module(self, module):
        """Run the source with the stand-in, then swap in the compiled functions."""
        saved = sys.modules.get('numba')
        sys.modules['numba'] = _Numba('numba')
        try:
            super().exec_module(module)
        except Exception:   # kernel.py needs more of numba than njit: the JIT, as it is
            sys.modules.pop('numba')
            if saved is not None:
                sys.modules['numba'] = saved
            super().exec_module(module)
            return
        finally:
            if saved is not None:
                sys.modules['numba'] = saved
            elif isinstance(sys.modules.get('numba'), _Numba):
                del sys.modules['numba']
        variants = {name: [(getattr(self.extension, f'{name}__{k}'), kinds)
                           for k, kinds in enumerate(table)]
                    for name, table in self.extension.TABLE.items()}
        for name, value in list(vars(module).items()):
            if name in variants:
                setattr(module, name, _compiled(name, variants[name]))
            elif (not name.startswith('_') and isinstance(value, types.FunctionType)
                    and value.__module__ == KERNEL):
                setattr(module, name, _lazy_jit(name))
        module.COMPILED_AHEAD = True


def kernel_spec():
    """Return the import spec of the kernel backed by the extension, or None for the JIT."""
    extension = load_extension()
    if extension is None:
        return None
    return importlib.util.spec_from_file_location(
        KERNEL, _SOURCE, loader=_Loader(KERNEL, _SOURCE, extension))


# -------------------------------------------------------------------- build

def _hash_source(digest):
    """Python source of a function returning digest."""
    return f'def _source_hash():\n    return {digest}\n'


def _describe(kind):
    """Return a numba argument type as ``_matches`` checks it, or None if it does not."""
    from numba.core import types as nb
    if isinstance(kind, nb.Array) and str(kind.dtype) in ('float64', 'int64') and kind.aligned:
        return ['array', str(kind.dtype), kind.ndim, kind.layout, kind.mutable]
    if kind in (nb.int64, nb.float64):
        return [str(kind)]
    return None


def build(output_dir: str = _HERE, verbose: bool = False) -> str:
    """
    Compile the kernel's public functions into the extension module; return its path.

    To be called in a process where numba is not yet imported (``main``):
    it compiles into a fresh numba cache so that every function's code is
    at hand for linking.
    """
    import tempfile
    os.environ[FORCE_JIT] = '1'
    os.environ['NUMBA_CACHE_DIR'] = tempfile.mkdtemp(prefix='cfem-aot-')
    from numba.core import codegen, cpu
    from numba.core.compiler import Flags
    from numba.core.registry import CPUDispatcher
    from numba.pycc import CC, compiler as pycc_compiler

    from cfem_ros.core import kernel, warmup
    warmup.warm_up()
    digest = source_hash(kernel.__file__)

    cc = CC(EXTENSION.rsplit('.', 1)[1])
    cc.output_dir = output_dir
    cc.target_cpu = 'host'
    cc.verbose = verbose
    options = {}
    table = {}
    for name, value in sorted(vars(kernel).items()):
        if name.startswith('_') or not isinstance(value, CPUDispatcher):
            continue
        kinds = [[_describe(arg) for arg in signature] for signature in value.signatures]
        if not kinds or not all(all(kinds_) for kinds_ in kinds):
            continue   # not run by the warm-up, or an argument type not checked: the JIT
        table[name] = kinds
        for k, signature in enumerate(value.signatures):
            result = value.overloads[signature].signature.return_type
            cc.export(f'{name}__{k}', result(*signature))(value.py_func)
        options[value.py_func] = dict(value.targetoptions)
    namespace = {}
    exec(_hash_source(digest), namespace)  # noqa: S102 - our own source
    cc.export('_source_hash', 'int64()')(namespace['_source_hash'])

    compile_extra = pycc_compiler.compile_extra

    def with_options(typing, target, function, args, result, flags, **named):
        # the JIT's options for this function: same fast-math, error model
        own = Flags()
        for field in ('no_compile', 'no_cpython_wrapper', 'no_cfunc_wrapper', 'nrt'):
            setattr(own, field, getattr(flags, field))
        if function in options:
            cpu.CPUTargetOptions.parse_as_flags(own, options[function])
        return compile_extra(typing, target, function, args, result, own, **named)

    features = codegen.AOTCPUCodegen._customize_tm_features
    pycc_compiler.compile_extra = with_options
    # the JIT's CPU features, not only those its name implies
    codegen.AOTCPUCodegen._customize_tm_features = codegen.CPUCodegen._get_host_cpu_features
    try:
        cc.compile()
    finally:
        pycc_compiler.compile_extra = compile_extra
        codegen.AOTCPUCodegen._customize_tm_features = features
    with open(os.path.join(output_dir, os.path.basename(TABLE)), 'w', encoding='utf-8') as out:
        json.dump({'hash': digest, 'functions': table}, out, indent=1)
    return os.path.join(output_dir, cc.output_file)


def main() -> int:
    """Build the extension next to kernel.py and say where and how long it took."""
    import shutil
    import tempfile
    import time
    started = time.monotonic()
    print('cfem_ros: compiling the numerical core ahead of time (a few minutes)...',
          file=sys.stderr, flush=True)
    try:
        path = build(verbose='-v' in sys.argv)
    finally:   # the build's own numba cache (see build)
        if os.environ.get('NUMBA_CACHE_DIR', '').startswith(tempfile.gettempdir()):
            shutil.rmtree(os.environ['NUMBA_CACHE_DIR'], ignore_errors=True)
    print(f'cfem_ros: {path} built in {time.monotonic() - started:.0f} s', file=sys.stderr)
    return 0


if __name__ == '__main__':
    sys.exit(main())
