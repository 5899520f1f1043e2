# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Property: a mutated real recording never crashes or hangs a reading command.

Hypothesis mutates a real ``cfem-sim run`` recording byte by byte (flips,
insertions, truncations) and record by record (a record deleted,
duplicated, swapped with the next, its length field or its body
overwritten), then runs ``info``, ``compare``, ``run --inputs`` and
``recover`` on it. Each ends with exit 2 and one ``ERROR:`` line, or exit 0
with a correct result: ``info`` then prints the original's message count
and topics (the summary's CRC held), ``compare`` finds no difference at
all (every CRC held), ``recover`` writes only messages of the original,
bit for bit, in a file the indexed reader reads and decodes. A watchdog
ends the test if a command hangs. Bounded for ``make test``;
``CFEM_LONG_TESTS=1`` runs 40 times more examples.
"""

import faulthandler
import os
import pathlib
import re
import struct
import sys
import tempfile

from cfem_ros import cli
from hypothesis import given, HealthCheck, settings, strategies as st
from mcap.reader import make_reader
import pytest
from recordings import read_mcap, top_records

CONFIG = pathlib.Path(__file__).resolve().parents[2] / 'config'
SCENARIO = CONFIG / 'store_separation.yaml'
LONG = os.environ.get('CFEM_LONG_TESTS') == '1'
EXAMPLES = 400 if LONG else 10


@pytest.fixture(scope='module')
def original(tmp_path_factory):
    """Record a small real recording (about 450 messages); return its bytes and messages."""
    path = tmp_path_factory.mktemp('fuzz') / 'run.mcap'
    assert cli.main(['run', str(SCENARIO), '-o', str(path), '--rate', '250',
                     '--duration', '0.3']) == 0
    data = path.read_bytes()
    with open(path, 'rb') as stream:
        reader = make_reader(stream)
        summary = reader.get_summary()
        messages = {(c.topic, m.log_time, bytes(m.data)) for _, c, m in reader.iter_messages()}
    return path, data, messages, summary.statistics.message_count


@st.composite
def mutations(draw, data: bytes):
    """Draw one mutation of data, byte-level or record-level."""
    kind = draw(st.sampled_from(['flip', 'flips', 'truncate', 'insert', 'delete record',
                                 'duplicate record', 'swap records', 'record length',
                                 'record body']))
    size = len(data)
    if kind in ('flip', 'flips'):
        out = bytearray(data)
        for _ in range(1 if kind == 'flip' else draw(st.integers(2, 6))):
            out[draw(st.integers(0, size - 1))] ^= draw(st.integers(1, 255))
        return kind, bytes(out)
    if kind == 'truncate':
        return kind, data[:draw(st.integers(0, size - 1))]
    if kind == 'insert':
        at = draw(st.integers(0, size))
        return kind, data[:at] + draw(st.binary(min_size=1, max_size=16)) + data[at:]
    spans = top_records(data)
    k = draw(st.integers(0, len(spans) - 2))
    (start, end), (_, after) = spans[k], spans[k + 1]
    if kind == 'delete record':
        return kind, data[:start] + data[end:]
    if kind == 'duplicate record':
        return kind, data[:end] + data[start:end] + data[end:]
    if kind == 'swap records':
        return kind, data[:start] + data[end:after] + data[start:end] + data[after:]
    if kind == 'record length':
        value = draw(st.one_of(st.integers(0, (1 << 64) - 1), st.integers(0, 2 * (end - start))))
        return kind, data[:start + 1] + struct.pack('<Q', value) + data[start + 9:]
    body = draw(st.binary(min_size=end - start - 9, max_size=end - start - 9))
    return kind, data[:start + 9] + body + data[end:]


def outcome(capsys, argv):
    """Run a command; return (status, stdout), after checking the one-error-line rule."""
    status = cli.main(argv)
    captured = capsys.readouterr()
    assert 'Traceback' not in captured.err
    assert status in (0, 2), (argv, status, captured.err)
    if status == 2:
        assert captured.err.startswith('ERROR: ') and captured.err.count('\n') == 1, (
            argv, captured.err)
    else:
        assert 'ERROR' not in captured.err, (argv, captured.err)
    return status, captured.out


@settings(max_examples=EXAMPLES, deadline=None, derandomize=not LONG,
          suppress_health_check=[HealthCheck.function_scoped_fixture,
                                 HealthCheck.data_too_large, HealthCheck.too_slow])
@given(data=st.data())
def test_mutated_recordings_give_one_error_line_or_a_correct_result(original, capsys, data):
    path, pristine, messages, count = original
    kind, mutated = data.draw(mutations(pristine), label='mutation')
    faulthandler.dump_traceback_later(120, exit=True, file=sys.__stderr__)   # a hang
    try:
        with tempfile.TemporaryDirectory() as folder:
            damaged = os.path.join(folder, 'damaged.mcap')
            with open(damaged, 'wb') as stream:
                stream.write(mutated)
            status, out = outcome(capsys, ['info', damaged])
            if status == 0:
                assert f'{damaged}: {count} messages in' in out, (kind, out)
            status, out = outcome(capsys, ['compare', str(path), damaged])
            if status == 0:
                numbers = [float(x) for x in re.findall(r'^\S+ \S+\s+(\S+)\s', out, re.M)
                           if re.fullmatch(r'[-+.\deE]+|nan', x)]
                assert numbers and all(x == 0.0 for x in numbers), (kind, out)
            outcome(capsys, ['run', str(SCENARIO), '-o', os.path.join(folder, 'r.mcap'),
                             '--inputs', damaged, '--duration', '0.01'])
            fixed = os.path.join(folder, 'fixed.mcap')
            status, out = outcome(capsys, ['recover', damaged, '-o', fixed])
            if status == 0:
                _, summary, decoded = read_mcap(fixed)   # indexed, every message decoded
                with open(fixed, 'rb') as stream:
                    kept = {(c.topic, m.log_time, bytes(m.data))
                            for _, c, m in make_reader(stream).iter_messages()}
                assert kept <= messages, kind
                assert summary.statistics.message_count == len(decoded)
                assert f'{len(decoded)} messages recovered' in out
            else:
                assert not os.path.exists(fixed)
    finally:
        faulthandler.cancel_dump_traceback_later()
