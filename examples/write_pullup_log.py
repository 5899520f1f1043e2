# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Write a small flight-test-like log: an aircraft in a 2 g pull-up, and a release.

The aircraft's odometry (``/cfem/bodies/aircraft/odom``, nav_msgs/Odometry,
REP-105: pose in the world frame, twist in the aircraft's axes) at 100 Hz,
flying at 250 m/s and pitching up at g / V (its lift is twice its weight),
in the world frame of ``config/store_release_from_pullup.yaml`` (x forward,
z down); and the release command of the joint ``hook`` (``/cfem/release``)
at 0.5 s. Replay it with ``cfem-sim run ... --inputs`` or ``cfem-sim play``
(see docs/guide/carriers-and-replays.md, "Replaying a flight test").
"""

import argparse
import math
import sys

from cfem_ros.recording.container import Recorder
from cfem_ros.recording.schema import ODOMETRY_TYPE, STRING_TYPE

G = 9.80665
SPEED = 250.0
START_NS = 1_700_000_000_000_000_000   # the log's clock at its first message


def pullup(t: float, speed: float = SPEED, load_factor: float = 2.0):
    """Return position (world, z down), quaternion x y z w and the pitch rate at t."""
    rate = (load_factor - 1.0) * G / speed
    phi = rate * t
    position = (speed / rate * math.sin(phi), 0.0, speed / rate * (math.cos(phi) - 1.0))
    return position, (0.0, math.sin(phi / 2), 0.0, math.cos(phi / 2)), rate


def _stamp(t_ns: int) -> dict:
    return {'sec': t_ns // 1_000_000_000, 'nanosec': t_ns % 1_000_000_000}


def write(path: str, duration: float = 2.0, rate_hz: float = 100.0, release: float = 0.5,
          overwrite: bool = False) -> int:
    """Write the log; return the number of messages."""
    count = 0
    with Recorder(path, overwrite=overwrite) as rec:
        for k in range(int(round(duration * rate_hz)) + 1):
            t = k / rate_hz
            t_ns = START_NS + round(t * 1e9)
            position, quat, pitch_rate = pullup(t)
            rec.write('/cfem/bodies/aircraft/odom', ODOMETRY_TYPE, {
                'header': {'stamp': _stamp(t_ns), 'frame_id': 'world'},
                'child_frame_id': 'aircraft',
                'pose': {'pose': {'position': dict(zip('xyz', position)),
                                  'orientation': dict(zip('xyzw', quat))},
                         'covariance': [0.0] * 36},
                'twist': {'twist': {'linear': {'x': SPEED, 'y': 0.0, 'z': 0.0},
                                    'angular': {'x': 0.0, 'y': pitch_rate, 'z': 0.0}},
                          'covariance': [0.0] * 36}}, t_ns)
            count += 1
            if abs(t - release) < 0.5 / rate_hz:
                rec.write('/cfem/release', STRING_TYPE, {'data': 'hook'}, t_ns)
                count += 1
    return count


def main(argv=None) -> int:
    """Write the log named on the command line."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[1])
    parser.add_argument('-o', '--output', default='flight.mcap', help='log to write')
    parser.add_argument('--duration', type=float, default=2.0, help='s of flight (default 2)')
    parser.add_argument('--release', type=float, default=0.5,
                        help='s from the start when the hook is released (default 0.5)')
    parser.add_argument('--overwrite', action='store_true', help='replace the log')
    args = parser.parse_args(argv)
    count = write(args.output, duration=args.duration, release=args.release,
                  overwrite=args.overwrite)
    print(f'{args.output}: {count} messages')
    return 0


if __name__ == '__main__':
    sys.exit(main())
