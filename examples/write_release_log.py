# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
r"""
Write an inputs log that holds release commands: a run released on command, offline.

A release command is a ``std_msgs/String`` on ``/cfem/release`` naming joints
or release groups, as ``cfem_pub release NAME`` publishes it to the node.
This log holds one per ``--release NAME@SECONDS``, logged at that time after
the log's time zero (its ``cfem_ros`` metadata ``start_stamp_ns``, 0), as a
node's recording logs the commands it took. ``cfem-sim run SCENARIO --inputs
LOG`` then releases at those times, with the node's numbers.

The shipped logs in ``config/inputs/`` were written by it::

    python examples/write_release_log.py -o config/inputs/store_release_two_hooks.mcap \
        --release station_1@0.05
    python examples/write_release_log.py -o config/inputs/store_release_on_command.mcap \
        --release pivot@0.2
"""

import argparse
import math
import sys

from cfem_ros.recording.container import Recorder
from cfem_ros.recording.schema import STRING_TYPE


def write(path: str, releases: list, overwrite: bool = False, namespace: str = '/cfem') -> int:
    """
    Write the log of release commands; return how many.

    releases: (name, seconds) pairs, the joint or group and when it is
    released after time zero (s, at most 1e6).
    """
    with Recorder(path, overwrite=overwrite, metadata={'start_stamp_ns': 0}) as rec:
        for name, seconds in sorted(releases, key=lambda item: item[1]):
            stamp_ns = round(seconds * 1e9)
            rec.write(f'{namespace.rstrip("/")}/release', STRING_TYPE, {'data': name}, stamp_ns)
    return len(releases)


def _release(text: str) -> tuple:
    """Return (name, seconds) of ``NAME@SECONDS`` (argparse's type: ValueError if not)."""
    name, _, seconds = text.rpartition('@')
    value = float(seconds)
    if not name or not (math.isfinite(value) and 0.0 <= value <= 1e6):
        raise ValueError(text)
    return name, value


def main(argv=None) -> int:
    """Write the log named on the command line."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[1])
    parser.add_argument('-o', '--output', required=True, help='log to write (MCAP)')
    parser.add_argument('--release', type=_release, action='append', required=True,
                        metavar='NAME@SECONDS',
                        help='release joint or group NAME at SECONDS (0 to 1e6) after time '
                        'zero (repeatable)')
    parser.add_argument('--overwrite', action='store_true', help='replace the log')
    args = parser.parse_args(argv)
    count = write(args.output, args.release, overwrite=args.overwrite)
    print(f'{args.output}: {count} release command(s)')
    return 0


if __name__ == '__main__':
    sys.exit(main())
