# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""The compiled core is ready after a warm-up, and a run then compiles nothing."""

import os
import pathlib
import subprocess
import sys

from cfem_ros.core import kernel, warmup

CONFIG = pathlib.Path(__file__).resolve().parents[2] / 'config'


def test_compiled_code_ready_follows_the_cache(tmp_path, monkeypatch):
    warmup.warm_up()
    assert warmup.compiled_code_ready()
    # an empty cache folder is not ready
    monkeypatch.setenv('NUMBA_CACHE_DIR', str(tmp_path))
    assert not warmup.compiled_code_ready()
    # nor a cache older than the source
    index = tmp_path / 'kernel.advance-1.py311.nbi'
    index.write_bytes(b'')
    old = os.path.getmtime(kernel.__file__) - 10
    os.utime(index, (old, old))
    assert not warmup.compiled_code_ready()


def test_a_run_after_the_warm_up_compiles_nothing(tmp_path):
    warmup.warm_up()
    exe = pathlib.Path(sys.executable).parent / 'cfem-sim'
    out = subprocess.run(
        [str(exe), 'run', str(CONFIG / 'store_separation.yaml'), '-o', str(tmp_path / 'r.mcap'),
         '--duration', '0.1'], capture_output=True, text=True, timeout=300,
        env={**os.environ, 'NUMBA_DEBUG_CACHE': '1'})
    assert out.returncode == 0, out.stderr
    assert 'compiling' not in out.stderr
    # numba reports every function it compiles instead of loading: none may be compiled
    lines = out.stdout.splitlines()
    assert any('[cache] data loaded' in line for line in lines)   # the log is on
    saved = [line for line in lines if '[cache] data saved' in line]
    assert not saved, saved[:3]
