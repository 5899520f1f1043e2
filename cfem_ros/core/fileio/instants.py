# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Dates and times of day (ISO 8601) as the ROS stamps of a recording, integer nanoseconds.

A recording of ``cfem-sim run`` may carry the date of the flight it stands
for (``--start-time``, scenario ``start_time``): simulated time 0 is then
that instant. A ROS ``builtin_interfaces/Time`` holds whole seconds in a
signed 32-bit integer and MCAP log times are unsigned, so an instant must
lie from 1970-01-01T00:00:00Z to 2038-01-19T03:14:07Z, the run's end
included. The text is read to the nanosecond (Python's ``datetime`` stops at
the microsecond, so the fraction is read here); a time of day needs its UTC
offset (``Z`` or ``+02:00``): a local time without one would shift every
stamp by the zone, silently.
"""

from __future__ import annotations

import datetime
import re

from cfem_ros.core.errors import ArgumentError

#: The last second a ROS Time holds (2^31 - 1 s after 1970-01-01T00:00:00Z).
MAX_SECONDS = 2 ** 31 - 1

#: An ISO 8601 date and time: date, time, optional fraction, the offset.
_PATTERN = re.compile(r'(\d{4}-\d{2}-\d{2})[T ](\d{2}:\d{2}(?::\d{2})?)(?:[.,](\d{1,9}))?'
                      r'\s*(Z|z|[+-]\d{2}(?::?\d{2})?)?')

#: What a caller is told to give.
EXPECTED = ('an ISO 8601 date and time with its UTC offset, e.g. 2026-03-14T09:30:00Z or '
            '2026-03-14T10:30:00.25+01:00, from 1970-01-01T00:00:00Z to 2038-01-19T03:14:07Z')

_EPOCH = datetime.datetime(1970, 1, 1, tzinfo=datetime.timezone.utc)


def instant_ns(value) -> int:
    """
    Return an instant as ns since 1970-01-01T00:00:00Z (UTC, leap seconds not counted).

    Parameters
    ----------
    value : str or datetime.datetime
        ISO 8601 text (``2026-03-14T09:30:00.123456789Z``), or a datetime
        with its zone (YAML reads an unquoted timestamp as one, to the
        microsecond).

    Raises
    ------
    ArgumentError
        Saying what the value is and what would do (``EXPECTED``); callers
        prefix the key path or option.

    """
    if isinstance(value, datetime.datetime):
        if value.tzinfo is None:
            raise ArgumentError(f'is {value.isoformat()}, a time with no UTC offset; expected '
                                f'{EXPECTED}')
        ns = _whole_ns(value)
    elif isinstance(value, str):
        ns = _text_ns(value)
    else:
        raise ArgumentError(f'is {value!r}; expected {EXPECTED}')
    if not 0 <= ns <= MAX_SECONDS * 1_000_000_000:
        raise ArgumentError(f'is {value if isinstance(value, str) else value.isoformat()}, '
                            f'outside what a ROS stamp holds; expected {EXPECTED}')
    return ns


def _whole_ns(moment: datetime.datetime) -> int:
    """Return a zoned datetime as integer ns since the epoch (exact: no float on the way)."""
    delta = moment - _EPOCH
    return ((delta.days * 86_400 + delta.seconds) * 1_000_000 + delta.microseconds) * 1000


def _text_ns(text: str) -> int:
    """Return ISO 8601 text as integer ns since the epoch, the fraction to the nanosecond."""
    found = _PATTERN.fullmatch(text.strip())
    if found is None:
        raise ArgumentError(f'is {text!r}; expected {EXPECTED}')
    date, clock, fraction, zone = found.groups()
    if zone is None:
        raise ArgumentError(f'is {text!r}, a time with no UTC offset (a local time would shift '
                            f'every stamp by its zone); expected {EXPECTED}')
    zone = '+00:00' if zone in 'Zz' else zone
    try:
        whole = datetime.datetime.fromisoformat(f'{date}T{clock}{zone}')
    except ValueError as err:
        raise ArgumentError(f'is {text!r} ({err}); expected {EXPECTED}') from None
    return _whole_ns(whole) + int((fraction or '').ljust(9, '0') or 0)
