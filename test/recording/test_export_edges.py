# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""``cfem-sim export`` at its edges (issue 52 item 11): the extension's case, absurd rates."""

import warnings

from cfem_ros import cli
from cfem_ros.recording.units import read_csv
import pandas as pd
import pytest
import yaml

#: A store falling for 0.2 s, recorded at 100 Hz.
SCENARIO = {'gravity': [0, 0, 9.80665], 'duration': 0.2, 'dt': 0.001,
            'bodies': {'store': {'mass': 230.0, 'inertia': [4.1, 95.0, 95.0]}}}


@pytest.fixture(scope='module')
def recording(tmp_path_factory):
    folder = tmp_path_factory.mktemp('export')
    (folder / 'fall.yaml').write_text(yaml.safe_dump(SCENARIO))
    path = folder / 'fall.mcap'
    assert cli.main(['run', str(folder / 'fall.yaml'), '-o', str(path), '--rate', '100']) == 0
    return path


@pytest.mark.parametrize('name, magic', [('T.CSV', b'time [s],'), ('T.Csv', b'time [s],'),
                                         ('T.PARQUET', b'PAR1'), ('t.parquet', b'PAR1')])
def test_the_format_is_the_extension_s_in_any_case(recording, tmp_path, capsys, name, magic):
    # the case: export -o T.CSV wrote Parquet
    out = tmp_path / name
    assert cli.main(['export', str(recording), '-o', str(out)]) == 0
    assert out.read_bytes()[:len(magic)] == magic
    table = read_csv(str(out)) if magic.startswith(b'time') else pd.read_parquet(out)
    assert len(table) == 21 and table['time'].iloc[-1] == pytest.approx(0.2)


def test_a_rate_of_1e_300_is_the_one_row_at_t_0_without_a_warning(recording, tmp_path):
    # the case: a RuntimeWarning (inf times 0) before an ERROR line; every multiple of
    # 1e300 s in a 0.2 s recording is t = 0, which it has
    out = tmp_path / 'slow.csv'
    with warnings.catch_warnings():
        warnings.simplefilter('error')
        assert cli.main(['export', str(recording), '-o', str(out), '--rate', '1e-300']) == 0
    assert read_csv(str(out))['time'].tolist() == [0.0]


@pytest.mark.parametrize('rate', ['1e300', '200', '1e9'])
def test_a_rate_faster_than_the_recording_is_one_short_error_line(
        recording, tmp_path, capsys, rate):
    # the case: a 520-character ERROR line counting 1e300 missing times
    out = tmp_path / 'fast.csv'
    assert cli.main(['export', str(recording), '-o', str(out), '--rate', rate]) == 2
    line, = capsys.readouterr().err.splitlines()
    assert line.startswith('ERROR: ') and len(line) < 250, line
    assert f"--rate {float(rate):.6g}: faster than the recording's 100 Hz" in line
    assert not out.exists()
