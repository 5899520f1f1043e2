# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
CPU use and publish-period jitter of cfem_node in real-time mode.

For each paper scenario (dt = 1 ms, rate_hz 100, real_time_factor 1) the node
runs in its own process over Fast DDS; this process subscribes to a body's
pose. It prints the node's CPU seconds per simulated second (user + system,
from /proc, start-up excluded), the deviation of the pose arrival period
from 1/rate_hz (median and 99th percentile), as a subscriber sees it, and how
long after its stamp each pose was published (the DDS source timestamp, the
node's ROS time when it wrote it: the stamp is the ROS time of publication
to within this; median and 99th percentile). These were assertions in
test_node_time once; a wall-clock bound fails under load, so it is measured
here.

Usage: .venv/bin/python benchmarks/bench_node.py [--seconds 10]
"""

import argparse
import os
import pathlib
import random
import statistics
import subprocess
import sys
import tempfile
import time

CONFIG = pathlib.Path(__file__).resolve().parents[1] / 'config'
SCENARIOS = (('fixed_joint_spin', 'B'), ('double_pendulum', 'B'), ('store_separation', 'store'))
RATE_HZ = 100.0
#: The measurement starts at the first pose this process receives, which may
#: come seconds after the node starts (discovery, start-up): the node runs
#: this much longer than the measured span, and is stopped when it is done.
START_SLACK = 60.0
#: Seconds a stopped node has to exit before it is killed.
STOP_WAIT = 30.0


def cpu_seconds(pid: int) -> float:
    """User + system CPU time of a process so far, s."""
    fields = pathlib.Path(f'/proc/{pid}/stat').read_text().rsplit(')', 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf('SC_CLK_TCK')


def percentile(values, q):
    """Return the nearest-rank percentile q (0 to 100) of some values."""
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(round(q / 100 * (len(ordered) - 1))))]


def stop(process):
    """End a process: SIGTERM, then SIGKILL if it has not exited within STOP_WAIT s."""
    if process.poll() is None:
        process.terminate()
        try:
            process.wait(timeout=STOP_WAIT)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait(timeout=STOP_WAIT)


def measure(name, body, seconds):
    """Run the node on a scenario and measure it over `seconds` of its poses."""
    import rclpy
    from geometry_msgs.msg import PoseStamped
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.qos import QoSProfile, ReliabilityPolicy
    log = tempfile.TemporaryFile()   # the node's output, shown if it fails
    # a namespace of its own: no other node on the same domain can feed the measurement
    namespace = f'/bench_{os.getpid()}_{name}'
    node_process = subprocess.Popen(
        [str(pathlib.Path(sys.executable).parent / 'cfem_node'), '--ros-args',
         '-r', f'__ns:={namespace}',
         '-p', f'scenario:={CONFIG / f"{name}.yaml"}', '-p', f'rate_hz:={RATE_HZ}',
         '-p', 'real_time_factor:=1.0', '-p', f'duration:={seconds + START_SLACK}'],
        stdout=log, stderr=subprocess.STDOUT)
    context = rclpy.Context()
    rclpy.init(context=context)
    peer = rclpy.create_node('bench_peer', context=context)
    arrivals, cpu, delays = [], {}, []

    def on_pose(msg, info):
        t = msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9
        arrivals.append((time.monotonic(), t))
        delays.append((info['source_timestamp'] - msg.header.stamp.sec * 10 ** 9
                       - msg.header.stamp.nanosec) / 1e6)
        if len(arrivals) == 1:
            cpu['start'] = (cpu_seconds(node_process.pid), t)
        elif t - arrivals[0][1] >= seconds and 'end' not in cpu:
            cpu['end'] = (cpu_seconds(node_process.pid), t)

    peer.create_subscription(PoseStamped, f'{namespace}/bodies/{body}/pose', on_pose,
                             QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE))
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(peer)
    deadline = time.monotonic() + seconds + START_SLACK
    try:
        while ('end' not in cpu and time.monotonic() < deadline
               and node_process.poll() is None):
            executor.spin_once(timeout_sec=0.05)
    finally:
        stop(node_process)
        executor.shutdown()
        peer.destroy_node()
        rclpy.try_shutdown(context=context)
    if 'end' not in cpu:
        log.seek(0)
        output = log.read().decode(errors='replace').strip().splitlines()[-15:]
        why = (f'it exited with status {node_process.returncode}'
               if node_process.returncode not in (None, -15, 143) else
               f'{len(arrivals)} poses received in {seconds + START_SLACK:g} s')
        raise RuntimeError(f'{name}: the node did not publish for {seconds:g} s ({why}); '
                           'its output:\n' + '\n'.join(output))
    log.close()
    (cpu0, t0), (cpu1, t1) = cpu['start'], cpu['end']
    # skip the first second: discovery and the subscriber's own warm-up
    received = [a for a, t in arrivals if t0 + 1.0 <= t <= t1]
    periods = [b - a for a, b in zip(received, received[1:])]
    deviations = [abs(p - 1.0 / RATE_HZ) * 1e3 for p in periods]
    return {'cpu': (cpu1 - cpu0) / (t1 - t0), 'median': statistics.median(deviations),
            'p99': percentile(deviations, 99), 'period': statistics.median(periods) * 1e3,
            'n': len(periods), 'late': statistics.median(delays[100:] or delays),
            'late99': percentile(delays[100:] or delays, 99)}


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[1])
    parser.add_argument('--seconds', type=float, default=10.0,
                        help='simulated (= wall) seconds measured per scenario')
    args = parser.parse_args()
    os.environ.setdefault('ROS_DOMAIN_ID', str(random.randint(101, 200)))
    os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
    print(f'cfem_node, real time, dt = 1 ms, rate_hz {RATE_HZ:g}, {args.seconds:g} s each; '
          'jitter = |arrival period - 10 ms| at a subscriber in another process; '
          'published = publication - stamp')
    print(f'{"scenario":<18} {"CPU s per sim s":>16} {"period median ms":>17} '
          f'{"jitter median ms":>17} {"jitter p99 ms":>14} {"published median ms":>20} '
          f'{"published p99 ms":>17} {"periods":>8}')
    for name, body in SCENARIOS:
        r = measure(name, body, args.seconds)
        print(f'{name:<18} {r["cpu"]:>16.3f} {r["period"]:>17.3f} {r["median"]:>17.3f} '
              f'{r["p99"]:>14.3f} {r["late"]:>20.3f} {r["late99"]:>17.3f} {r["n"]:>8d}')


if __name__ == '__main__':
    main()
