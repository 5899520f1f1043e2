# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""The kernel compiled ahead of time: chosen only when current, and bit-identical to the JIT."""

import os
import pathlib
import subprocess
import sys

from cfem_ros.core import aot

ROOT = pathlib.Path(__file__).resolve().parents[2]

#: States, joint loads and outputs of every shipped scenario at 8 times, hashed;
#: then whether numba was imported and whether the kernel was compiled ahead.
FINGERPRINT = """
import glob, hashlib, sys
import numpy as np
from cfem_ros.core import kernel
from cfem_ros.core.engine import Simulator
from cfem_ros.core.scenario import load_scenario
digest = hashlib.sha256()
end = float(sys.argv[2])
for path in sorted(glob.glob(sys.argv[1] + '/config/*.yaml')
                   + glob.glob(sys.argv[1] + '/config/joints/*.yaml')):
    if path.endswith('params.yaml'):
        continue
    sim = Simulator(load_scenario(path, duration=end))
    for k in range(1, 9):
        if not sim.advance_to(end * k / 8):
            digest.update(b'failed')
            break
        digest.update(np.ascontiguousarray(sim.y).tobytes())
        digest.update(np.ascontiguousarray(sim.outputs()).tobytes())
        for value in sim.joint_wrenches():
            digest.update(np.ascontiguousarray(value).tobytes())
print(digest.hexdigest(), 'numba' in sys.modules, getattr(kernel, 'COMPILED_AHEAD', False))
"""


def fingerprint(end, **env):
    """Run FINGERPRINT in a fresh process; return (hex digest, numba imported, ahead)."""
    done = subprocess.run([sys.executable, '-c', FINGERPRINT, str(ROOT), str(end)],
                          capture_output=True, text=True, timeout=900,
                          env={**os.environ, **env})
    assert done.returncode == 0, done.stderr
    digest, numba, ahead = done.stdout.split()
    return digest, numba == 'True', ahead == 'True'


def ensure_built():
    """Build the extension as ``make`` does if it is missing or stale."""
    if aot.load_extension() is None:
        subprocess.run([sys.executable, '-m', 'cfem_ros.core.aot'], check=True, timeout=1800)
    assert aot.load_extension() is not None


def test_compiled_kernel_gives_the_jit_numbers_without_numba():
    ensure_built()
    ahead = fingerprint(0.25)
    jit = fingerprint(0.25, CFEM_ROS_JIT='1')
    assert ahead[1:] == (False, True)      # numba never imported, the extension used
    assert jit[1:] == (True, False)
    assert ahead[0] == jit[0]


def test_extension_chosen_only_when_current(monkeypatch):
    ensure_built()
    assert aot.kernel_spec() is not None
    monkeypatch.setenv(aot.FORCE_JIT, '1')
    assert aot.load_extension() is None and aot.kernel_spec() is None
    monkeypatch.delenv(aot.FORCE_JIT)
    # built from other sources (here: a hash that is not theirs): the JIT
    other = aot.source_hash() + 1
    monkeypatch.setattr(aot, 'source_hash', lambda path=None: other)
    assert aot.load_extension() is None


def test_stale_extension_falls_back_to_the_jit():
    ensure_built()
    # a process that sees another kernel source hash imports kernel.py with numba
    code = ('from cfem_ros.core import aot\n'
            'aot.source_hash = lambda path=None: 1\n'
            'from cfem_ros.core import kernel\n'
            'import sys\n'
            "print(getattr(kernel, 'COMPILED_AHEAD', False), 'numba' in sys.modules,\n"
            '      type(kernel.advance).__name__)\n')
    done = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True,
                          timeout=300, check=True)
    assert done.stdout.split() == ['False', 'True', 'CPUDispatcher']


def test_arguments_the_compiled_code_does_not_fit_go_to_the_jit():
    ensure_built()
    # float32, byte-swapped, non-contiguous or read-only arrays would crash the
    # compiled code or read wrong numbers (it trusts its arguments' types): the JIT
    # takes them, as it always did
    code = """
import sys
import numpy as np
from cfem_ros.core import kernel
size = kernel.workspace_size(2, 3, 1)
work = np.arange(size, dtype=float)
ahead = kernel.constraint_values(work, 2, 3, 1).copy()
print('numba' in sys.modules)
for bad in (work.astype(np.float32), work.astype('>f8'), np.repeat(work, 2)[::2]):
    try:
        print(np.array_equal(kernel.constraint_values(bad, 2, 3, 1), ahead))
    except Exception as err:   # the JIT's own refusal, not a crash
        print(type(err).__name__)
print(kernel.workspace_size(np.int32(2), np.int32(3), np.int32(1)) == size)
work.flags.writeable = False
print(np.array_equal(kernel.constraint_values(work, 2, 3, 1), ahead))
print('numba' in sys.modules)
"""
    done = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True,
                          timeout=900)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ['False', 'True', 'TypingError', 'TypingError', 'True',
                                   'True', 'True']


def test_the_argument_check_admits_what_numba_types_as_the_kind():
    # the compiled code trusts its arguments: the check before each call must
    # admit exactly the values numba's own typing gives the compiled kinds (and
    # aligned arrays only)
    import numpy as np
    from numba import typeof
    from numba.core.errors import NumbaError
    base = np.arange(24.0)
    frozen = np.zeros((2, 3))
    frozen.flags.writeable = False
    misaligned = np.frombuffer(bytearray(8 * 7), dtype=np.float64, count=6, offset=1)
    values = [base, base.reshape(4, 6), base.reshape(4, 6).T, base[::2],
              base.reshape(4, 6)[:, ::2],
              base.reshape(2, 3, 4), base.astype(np.float32), base.astype('>f8'),
              base.astype(np.int64), base.astype(np.int64).reshape(4, 6), frozen, misaligned,
              np.zeros((1, 1)), np.zeros((0, 0)), np.zeros((3, 1))[:, 0],
              1.5, np.float64(1.5), np.float32(1.5), 3, np.int64(3), np.int32(3), True,
              2 ** 63, -2 ** 63, 'text', None, [1.0]]
    kinds = [['float64'], ['int64'], ['array', 'float64', 1, 'C', True],
             ['array', 'float64', 2, 'C', True], ['array', 'float64', 2, 'F', True],
             ['array', 'float64', 2, 'A', True], ['array', 'float64', 1, 'A', True],
             ['array', 'float64', 2, 'C', False], ['array', 'float64', 3, 'C', True],
             ['array', 'int64', 1, 'C', True], ['array', 'int64', 2, 'C', True]]
    for value in values:
        try:
            numba_kind = aot._describe(typeof(value))
        except (NumbaError, ValueError):   # a type numba does not take at all
            numba_kind = None
        if value is misaligned:   # numba types it as aligned; the compiled code assumes it
            numba_kind = None
        for kind in kinds:
            assert aot._Signature([kind]).admits((value,)) == (numba_kind == kind), \
                (value, kind, numba_kind)
    signature = aot._Signature([['float64'], ['array', 'int64', 1, 'C', True], ['int64']])
    good = (0.5, np.arange(3), 7)
    assert signature.admits(good)
    assert not signature.admits(good[:2]) and not signature.admits(good + (1,))
    assert not signature.admits((good[0], good[1].astype(np.float64), good[2]))
    assert not aot._Signature([['complex128']]).admits((1j,))
