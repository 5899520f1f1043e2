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
    # the JIT's cache decides when the kernel is not compiled ahead of time (core.aot)
    monkeypatch.setattr(kernel, 'COMPILED_AHEAD', False, raising=False)
    monkeypatch.setenv('CFEM_ROS_JIT', '1')   # for the warm-up process
    subprocess.run([sys.executable, '-c', 'from cfem_ros.core import warmup; warmup.warm_up()'],
                   check=True, timeout=900)
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
        env={**os.environ, 'NUMBA_DEBUG_CACHE': '1', 'CFEM_ROS_JIT': '1'})
    assert out.returncode == 0, out.stderr
    assert 'compiling' not in out.stderr
    # numba reports every function it compiles instead of loading: none may be compiled
    lines = out.stdout.splitlines()
    assert any('[cache] data loaded' in line for line in lines)   # the log is on
    saved = [line for line in lines if '[cache] data saved' in line]
    assert not saved, saved[:3]


def test_the_cache_is_dropped_when_a_compiled_source_changes(tmp_path, monkeypatch):
    # numba would keep the kernel's cache after an edit of loads.py alone: the guard
    # keeps a digest of every compiled source and drops the cache when it differs
    monkeypatch.setenv('NUMBA_CACHE_DIR', str(tmp_path))
    stale = tmp_path / 'kernel.advance-1.py311.nbi'
    stale.write_bytes(b'old')
    (tmp_path / 'cfem_ros_core_sources.sha256').write_text('a digest of other sources')
    kernel._guard_cache()
    assert not stale.exists()
    kept = tmp_path / 'loads.scheduled_wrench-1.py311.nbc'
    kept.write_bytes(b'current')
    kernel._guard_cache()   # same sources: the cache stays
    assert kept.exists()
