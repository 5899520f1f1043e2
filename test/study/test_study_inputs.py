# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""Sweep inputs at their edges and damaged study folders (issue 41.8, 41.11)."""

import os
import shutil
import warnings

from cfem_ros import cli
from cfem_ros.core.errors import CfemError
from cfem_ros.study import load_sweep, Sweep
from cfem_ros.study.criteria import parse_rule
from cfem_ros.study.folder import FolderError
from cfem_ros.study.report import write_report
from cfem_ros.study.sweep import prepare
import numpy as np
import pytest
from sweeps import STORE, write_sweep

SMALL = dict(STORE, duration=0.2)
AT = {'at': [{'time': 0.1, 'body': 'store'}]}


@pytest.fixture(scope='module')
def finished(tmp_path_factory):
    base = tmp_path_factory.mktemp('inputs')
    path = write_sweep(base, runs=2, seed=3, scenario=SMALL,
                       vary={'bodies.store.mass': {'uniform': [900, 910]}}, metrics=AT,
                       criteria={'tiny': 'store_at_0.1_z >= 5e-324'})
    out = base / 'sweep'
    Sweep.from_file(path).run(None, str(out), threads=1)
    return base, out


def test_a_clearance_point_beyond_1e9_m_is_refused(tmp_path):
    metrics = {'clearance': [{'bodies': ['store', 'pylon'],
                              'points_a': [[1.5, 0, 0], [1e300, 0, 0]]}]}
    path = write_sweep(tmp_path, runs=1, scenario=SMALL, metrics=metrics)
    with pytest.raises(CfemError, match=r'metrics\.clearance\[0\]\.points_a\[1\]: is '
                       r'\[1e\+300, 0\.0, 0\.0\]; expected a point within 1e\+09 m'):
        load_sweep(path)


def test_a_subnormal_threshold_gives_finite_margins_without_warnings():
    rule = parse_rule('tiny', 'x >= 5e-324')
    with warnings.catch_warnings():
        warnings.simplefilter('error')
        margin = rule.margin(np.array([1.0, -1.0, 0.0, np.nan, 1e308]))
    assert np.all(np.isfinite(margin))
    assert margin[0] > 0 > margin[1] and margin[3] < 0 and margin[4] > 0


def test_the_report_of_a_subnormal_threshold_prints_no_warning(finished):
    base, out = finished
    with warnings.catch_warnings():
        warnings.simplefilter('error')
        write_report(str(out), str(base / 'tiny.html'))   # its page without the figures
    assert 'store_at_0.1_z &gt;= 4.94066e-324' in (base / 'tiny.html').read_text()


def damaged_copy(finished, tmp_path, name, data):
    """Copy the finished folder, put data in its file name (None: remove it); return it."""
    _, out = finished
    copy = tmp_path / 'copy'
    shutil.copytree(out, copy)
    if data is None:
        (copy / name).unlink()
    else:
        (copy / name).write_bytes(data(copy / name) if callable(data) else data)
    return copy


def cut(path):
    return path.read_bytes()[:len(path.read_bytes()) // 2]


@pytest.mark.parametrize('name, data, said', [
    ('results.parquet', cut, 'results.parquet: damaged'),
    ('sweep.json', b'{', 'sweep.json: damaged'),
    ('sweep.json', b'[1, 2]', 'sweep.json: damaged'),
    ('sweep.json', None, 'has no sweep.json'),
])
def test_report_and_rerun_of_a_damaged_folder_say_which_file(finished, tmp_path, capsys,
                                                             name, data, said):
    copy = damaged_copy(finished, tmp_path, name, data)
    for argv in (['report', str(copy), '-o', str(tmp_path / 'r.html')],
                 ['rerun', str(copy), '0', '-o', str(tmp_path / 'r.mcap')]):
        assert cli.main(argv) == 2
        err = capsys.readouterr().err
        assert err.startswith('ERROR: ') and err.count('\n') == 1 and said in err, err
    assert not (tmp_path / 'r.html').exists() and not (tmp_path / 'r.mcap').exists()


@pytest.mark.parametrize('damage, said', [
    ('sweep.json', 'sweep.json: damaged'),
    ('part', '.parquet: damaged (.*); expected the part a sweep wrote: remove it'),
])
def test_a_resumed_sweep_of_a_damaged_folder_says_which_file(finished, tmp_path, damage, said):
    base, out = finished
    part = sorted(os.listdir(out / 'parts'))[0]
    name = 'sweep.json' if damage == 'sweep.json' else f'parts/{part}'
    copy = damaged_copy(finished, tmp_path, name, b'{' if damage == 'sweep.json' else cut)
    spec = load_sweep(str(base / 'sweep.yaml'))
    with pytest.raises(FolderError, match=said):
        prepare(spec, str(copy))
