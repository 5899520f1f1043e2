# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Every store example separates offline, run as its header says (issue 51).

An example released on a command (by the node's ``release`` topic) ships the
log of that command in ``config/inputs/``, the bytes
``examples/write_release_log.py`` writes; run with it, or on its own for the
others, each example releases its store (or, with no joint, has the
ejectors push it off) and the store is away from where it hung within 1 s.
"""

import importlib.util
import pathlib

from cfem_ros import cli, load_scenario
from cfem_ros.recording.analysis import open_run
import numpy as np
import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
CONFIG = ROOT / 'config'
EXAMPLES = sorted(p.stem for p in CONFIG.glob('store_*.yaml'))
#: The release commands each shipped log holds: (joint or group, s).
LOGS = {'store_release_two_hooks': [('station_1', 0.05)],
        'store_release_on_command': [('pivot', 0.2)]}


def _script():
    spec = importlib.util.spec_from_file_location(
        'write_release_log', ROOT / 'examples' / 'write_release_log.py')
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_shipped_logs_are_what_the_script_writes(tmp_path):
    assert sorted(p.stem for p in (CONFIG / 'inputs').glob('*.mcap')) == sorted(LOGS)
    script = _script()
    for name, releases in LOGS.items():
        out = tmp_path / f'{name}.mcap'
        assert script.main(['-o', str(out)] + [f'--release={n}@{t}' for n, t in releases]) == 0
        assert out.read_bytes() == (CONFIG / 'inputs' / f'{name}.mcap').read_bytes()
        header = (CONFIG / f'{name}.yaml').read_text()
        assert f'--inputs config/inputs/{name}.mcap' in header   # the header says how


@pytest.mark.parametrize('name', EXAMPLES)
def test_every_store_example_separates_offline(name, tmp_path, capsys):
    model = load_scenario(str(CONFIG / f'{name}.yaml'))
    log = CONFIG / 'inputs' / f'{name}.mcap'
    inputs = ['--inputs', str(log)] if log.exists() else []
    out = tmp_path / f'{name}.mcap'
    assert cli.main(['run', str(CONFIG / f'{name}.yaml'), '-o', str(out), '--duration', '1',
                     *inputs]) == 0
    printed = capsys.readouterr().out
    store = model.body_index('store')
    hooks = {j.name for j in model.joints if store in (j.parent, j.child)}
    run = open_run(str(out))
    released = {joint for _, joint, _ in run.releases()}
    assert released == hooks, (name, released, hooks)
    assert all(f'release {joint} at t = ' in printed for joint in hooks)
    if log.exists():   # at the logged command's time, for its cause
        (_, when), = LOGS[name]
        assert {round(t, 9) for t, _, _ in run.releases()} == {when}
        assert '(command' in printed
    # away from where it hung: in its carrier's axes, or the world's with a fixed one
    track = run.relative['store'] if 'store' in run.relative else run.bodies['store']
    assert np.linalg.norm(track.position[-1] - track.position[0]) > 0.3
