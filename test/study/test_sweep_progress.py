# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""The sweep's progress line: rewritten in place on a terminal, a line per task elsewhere."""

import io

from cfem_ros.study.sweep import Progress


class Terminal(io.StringIO):
    """A stream that says it is a terminal."""

    def isatty(self):
        return True


def test_progress_rewrites_one_line_on_a_terminal_and_adds_lines_to_a_file():
    terminal, log = Terminal(), io.StringIO()
    for stream in (terminal, log):
        meter = Progress(10, 2, stream)   # 2 runs already in the folder
        meter.update(4, 1)
        meter.update(4, 0)
    shown = terminal.getvalue()
    # one line, rewritten: a carriage return per task, one newline when all are done
    assert shown.count('\r') == 2 and shown.count('\n') == 1 and shown.endswith('\n')
    assert shown.split('\r')[1].startswith('sweep: 6/10 runs, 1 failed,')
    last = shown.rsplit('\r', 1)[1]
    assert last.startswith('sweep: 10/10 runs, 1 failed,') and 'ETA 0 s' in last
    # to a file: a line per task, no control characters
    written = log.getvalue()
    assert '\r' not in written and '\x1b' not in written
    assert written.splitlines()[0].startswith('sweep: 6/10 runs, 1 failed,')
    assert written.splitlines()[1].startswith('sweep: 10/10 runs, 1 failed,')
    assert len(written.splitlines()) == 2
