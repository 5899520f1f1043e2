# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Write a synthetic flight-test log: a flight log plus a store measured by photogrammetry.

The "real" store is ``config/fit/pullup_ejectors.yaml`` with the ejector
forces given here (the truth a fit should find), run against the flight
log's odometry and release command. Its pose relative to the aircraft, in
the aircraft's axes, is written at 100 Hz as ``/photogrammetry/store``
(geometry_msgs/PoseStamped, ``frame_id`` aircraft) with seeded Gaussian
noise (5 mm, 0.3 deg), beside a copy of the flight log's messages, all on
the flight log's clock. See docs/guide/fitting.md.
"""

import argparse
import contextlib
import io
import os
import sys
import tempfile

from cfem_ros import cli
from cfem_ros.recording.analysis import open_run
from cfem_ros.recording.container import Recorder
from cfem_ros.recording.reader import decoded_messages, open_mcap
from cfem_ros.recording.replay import read_inputs_and_start
from cfem_ros.recording.schema import ODOMETRY_TYPE, POSE_TYPE, STRING_TYPE
import numpy as np
from scipy.spatial.transform import Rotation
import yaml

SCENARIO = os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', 'config', 'fit',
                        'pullup_ejectors.yaml')
SCHEMAS = {'nav_msgs/msg/Odometry': ODOMETRY_TYPE, 'std_msgs/msg/String': STRING_TYPE}


def _truth(flight: str, forward: float, aft: float, folder: str):
    """Run the store with the true forces against the flight log; return its recording."""
    with open(SCENARIO, encoding='utf-8') as stream:
        scenario = yaml.safe_load(stream)
    scenario['wrenches'][0]['force'][2] = forward
    scenario['wrenches'][1]['force'][2] = aft
    path = os.path.join(folder, 'truth.yaml')
    with open(path, 'w', encoding='utf-8') as stream:
        yaml.safe_dump(scenario, stream)
    recording = os.path.join(folder, 'truth.mcap')
    said = io.StringIO()
    with contextlib.redirect_stdout(said):
        status = cli.main(['run', path, '--inputs', flight, '-o', recording, '--rate', '100'])
    if status != 0:
        raise SystemExit(f'the run of the true store failed:\n{said.getvalue()}')
    return open_run(recording)


def write(flight: str, output: str, forward: float, aft: float, seed: int = 37,
          sigma_position: float = 0.005, sigma_attitude_deg: float = 0.3) -> int:
    """Write the log; return the number of poses measured."""
    _, start_ns = read_inputs_and_start(flight)
    with tempfile.TemporaryDirectory() as folder:
        run = _truth(flight, forward, aft, folder)
    store, aircraft = run.bodies['store'], run.bodies['aircraft']
    turn = Rotation.from_quat(aircraft.quaternion).inv()
    position = turn.apply(store.position - aircraft.position)
    attitude = turn * Rotation.from_quat(store.quaternion)
    rng = np.random.default_rng(seed)
    position = position + rng.normal(0.0, sigma_position, position.shape)
    noise = Rotation.from_rotvec(np.radians(rng.normal(0.0, sigma_attitude_deg,
                                                       position.shape)))
    quaternion = (noise * attitude).as_quat()
    with Recorder(output, overwrite=True) as rec:
        with open_mcap(flight) as reader:
            for channel, message, decoded in decoded_messages(reader, flight):
                schema = SCHEMAS.get(type(decoded).__name__, None)
                rec.write(channel.topic, schema or _schema_of(reader, channel),
                          _as_dict(decoded), message.log_time)
        for k, t in enumerate(store.time):
            t_ns = start_ns + round(t * 1e9)
            rec.write('/photogrammetry/store', POSE_TYPE, {
                'header': {'stamp': {'sec': t_ns // 10 ** 9, 'nanosec': t_ns % 10 ** 9},
                           'frame_id': 'aircraft'},
                'pose': {'position': dict(zip('xyz', position[k])),
                         'orientation': dict(zip('xyzw', quaternion[k]))}}, t_ns)
    return len(store.time)


def _schema_of(reader, channel) -> str:
    return reader.get_summary().schemas[channel.schema_id].name


def _as_dict(message):
    """Return a decoded ROS message as nested dicts and lists."""
    if hasattr(message, '__slots__'):
        return {k: _as_dict(getattr(message, k)) for k in message.__slots__}
    if isinstance(message, (list, tuple)):
        return [_as_dict(v) for v in message]
    return message


def main(argv=None) -> int:
    """Write the log named on the command line."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[1])
    parser.add_argument('flight', help='flight log (examples/write_pullup_log.py)')
    parser.add_argument('-o', '--output', required=True, help='log to write')
    parser.add_argument('--forward', type=float, default=11500.0,
                        help='true forward ejector force, N (default 11500)')
    parser.add_argument('--aft', type=float, default=37000.0,
                        help='true aft ejector force, N (default 37000)')
    parser.add_argument('--seed', type=int, default=37, help='seed of the noise')
    args = parser.parse_args(argv)
    count = write(args.flight, args.output, args.forward, args.aft, args.seed)
    print(f'{args.output}: the flight log and {count} measured poses of the store')
    return 0


if __name__ == '__main__':
    sys.exit(main())
