# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
What the node says about the messages it refuses: bounded strings, throttled warnings.

Also the bridge from the engine's Python warnings to the node's ROS logger.
"""

import logging
import re
import time

#: Seconds between two warnings of the same kind (topic and reason) about
#: refused messages; the ones in between are counted, and the count given.
REFUSAL_WARNING_PERIOD = 1.0
#: Bytes of a refused message's string kept in the log and the recording.
REFUSED_STRING_BYTES = 256


class RosLogHandler(logging.Handler):
    """Forward the engine's Python warnings to the node's ROS logger."""

    def __init__(self, ros_logger):
        super().__init__(logging.INFO)
        self.ros_logger = ros_logger

    def emit(self, record):
        level = record.levelno
        message = self.format(record)
        if level >= logging.ERROR:
            self.ros_logger.error(message)
        elif level >= logging.WARNING:
            self.ros_logger.warning(message)
        else:
            self.ros_logger.info(message)


def bounded(text: str, limit: int = REFUSED_STRING_BYTES) -> str:
    """
    Return text if it holds at most limit bytes (UTF-8), else its first limit bytes and a mark.

    The mark (``... [N bytes, truncated]``) makes the result differ from any
    name of limit bytes or fewer, so a cut string never names a body, frame
    or joint.
    """
    data = text.encode('utf-8', 'surrogatepass')
    if len(data) <= limit:
        return text
    head = data[:limit].decode('utf-8', 'ignore')
    return f'{head}... [{len(data)} bytes, truncated]'


_QUOTED = re.compile(r"'(?:[^'\\]|\\.)*'|\"(?:[^\"\\]|\\.)*\"")
_NUMBER = re.compile(r'(?<![\w.])[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?(?!\w)'
                     r'|\bnan\b|\binf\b')


class Throttle:
    """
    Warnings of one kind at most once per period, with the count of those held back.

    The kind of a warning is its text with quoted names and numbers taken
    out (``unknown joint 'x'`` and ``unknown joint 'y'`` are one kind), so
    the number of kinds is bounded whatever the messages hold.
    """

    def __init__(self, logger, period: float = REFUSAL_WARNING_PERIOD):
        self.logger = logger
        self.period = period
        self._kinds = {}   # kind -> [time of the last line, lines held back since]
        #: Warnings asked for, by kind.
        self.counts = {}

    def warning(self, message: str):
        """Log ``topic: reason`` unless a line of its kind was logged less than period ago."""
        topic, _, reason = message.partition(': ')
        kind = f"{topic}: {_NUMBER.sub('#', _QUOTED.sub(chr(39) * 2, reason))}"
        self.counts[kind] = self.counts.get(kind, 0) + 1
        now = time.monotonic()
        entry = self._kinds.get(kind)
        if entry is not None and now - entry[0] < self.period:
            entry[1] += 1
            return
        if entry is not None and entry[1]:
            message += (f' ({entry[1]} more like it in the last {now - entry[0]:.1f} s '
                        'not shown)')
        self._kinds[kind] = [now, 0]
        self.logger.warning(message)

    def flush(self):
        """Log the count of warnings held back since their kind's last line, for each kind."""
        for kind, entry in self._kinds.items():
            if entry[1]:
                self.logger.warning(f'{entry[1]} more warnings of the kind "{kind}" not shown')
                entry[1] = 0
