# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Drive a cfem_node in its own process over real DDS, from the test process.

``NodeProcess`` starts the console script with ROS arguments and keeps its
output; ``Peer`` is an rclpy node in the test process that publishes inputs
and ``/clock`` and collects everything the node publishes. Every wait has a
deadline: a test fails, it never hangs on discovery.
"""

import argparse
import json
import math
import os
import pathlib
import signal
import subprocess
import sys
import time

from geometry_msgs.msg import PoseStamped, TwistStamped, WrenchStamped
import rclpy
from rclpy._rclpy_pybind11 import RCLError
from rclpy.executors import SingleThreadedExecutor
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rclpy.signals import SignalHandlerOptions
from rosgraph_msgs.msg import Clock
from std_msgs.msg import String
from visualization_msgs.msg import MarkerArray

BIN = pathlib.Path(sys.executable).parent
RELIABLE = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE,
                      durability=DurabilityPolicy.VOLATILE)
#: Like ros2 bag play --clock.
CLOCK = QoSProfile(depth=1, reliability=ReliabilityPolicy.BEST_EFFORT)
LATCHED = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE,
                     durability=DurabilityPolicy.TRANSIENT_LOCAL)


def stamp_ns(header) -> int:
    """Nanoseconds of a header's stamp."""
    return header.stamp.sec * 1_000_000_000 + header.stamp.nanosec


def clock_through(peer, received, clocks, what: str):
    """Publish each /clock time until a message stamped with it is in received (10 s each)."""
    for clock in clocks:
        tries = 0
        while not any(stamp_ns(m.header) == clock for m in received):
            assert tries < 40, f'no {what} at /clock {clock} ns'
            peer.clock(clock)
            peer.spin_for(0.25)
            tries += 1


class NodeProcess:
    """
    A cfem_node process; its stdout and stderr go to a file under directory.

    Parameters go after ``--params-file`` (which they override) as ``-p``
    arguments; booleans are written as ROS expects them. ``preexec_fn`` runs
    in the child before the node starts (a file size limit, say).
    """

    def __init__(self, directory, scenario, executable=None, env=None, params_file=None,
                 preexec_fn=None, **parameters):
        self.log_path = pathlib.Path(directory) / 'node.log'
        args = [str(executable or BIN / 'cfem_node'), '--ros-args']
        if params_file is not None:
            args += ['--params-file', str(params_file)]
        if scenario is not None:
            args += ['-p', f'scenario:={scenario}']
        for name, value in parameters.items():
            if isinstance(value, bool):
                value = str(value).lower()
            args += ['-p', f'{name}:={value}']
        self._log = open(self.log_path, 'w')
        self.process = subprocess.Popen(args, stdout=self._log, stderr=subprocess.STDOUT,
                                        env=env, preexec_fn=preexec_fn)

    @property
    def output(self) -> str:
        """Everything the node printed so far."""
        if not self._log.closed:
            self._log.flush()
        return self.log_path.read_text()

    def alive(self) -> bool:
        """Tell whether the process is still running."""
        return self.process.poll() is None

    def stop(self, sig=signal.SIGINT, timeout=20.0) -> int:
        """Send sig and return the exit status (kill after timeout)."""
        if self.alive():
            self.process.send_signal(sig)
        try:
            return self.process.wait(timeout=timeout)
        finally:
            if self.alive():
                self.process.kill()
                self.process.wait()
            self._log.close()

    def wait(self, timeout=60.0) -> int:
        """Wait for the process to end by itself; return its exit status."""
        try:
            return self.process.wait(timeout=timeout)
        finally:
            if self.alive():
                self.process.kill()
                self.process.wait()
            self._log.close()


class Peer:
    """The other side: publishes inputs and /clock, records what the node publishes."""

    def __init__(self, scenario_bodies, scenario_joints, namespace='/cfem', applied=()):
        self.context = rclpy.Context()
        rclpy.init(context=self.context, signal_handler_options=SignalHandlerOptions.NO)
        self.node = rclpy.create_node('test_peer', context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self.ns = namespace
        self.received = {}
        #: relative topic -> ROS time (ns) at which each message of received arrived
        self.arrivals = {}
        #: relative topic -> the publisher's time (ns) of writing each one (DDS source
        #: timestamp: the system clock, which is ROS time without /clock)
        self.published = {}
        for body in scenario_bodies:
            self._collect(PoseStamped, f'bodies/{body}/pose')
            self._collect(TwistStamped, f'bodies/{body}/twist')
        for joint in scenario_joints:
            self._collect(WrenchStamped, f'joints/{joint}/wrench')
            self._collect(WrenchStamped, f'joints/{joint}/wrench_world')
        for body, source in applied:
            self._collect(WrenchStamped, f'bodies/{body}/applied/{source}')
            self._collect(WrenchStamped, f'bodies/{body}/applied_world/{source}')
        self._collect(String, 'events')
        self._collect(MarkerArray, 'markers', LATCHED)
        if scenario_joints:   # the joint-load arrows (none without joints)
            self._collect(MarkerArray, 'load_markers')
        self.wrench_pubs = {b: self.node.create_publisher(
            WrenchStamped, f'{namespace}/bodies/{b}/wrench', RELIABLE) for b in scenario_bodies}
        self.release_pub = self.node.create_publisher(String, f'{namespace}/release', RELIABLE)
        self.clock_pub = self.node.create_publisher(Clock, '/clock', CLOCK)

    def _collect(self, kind, relative, qos=RELIABLE):
        topic = f'{self.ns}/{relative}'
        received, arrivals = self.received[relative], self.arrivals[relative] = [], []
        published = self.published[relative] = []
        clock = self.node.get_clock()

        def take(msg, info):
            arrivals.append(clock.now().nanoseconds)
            published.append(info['source_timestamp'])
            received.append(msg)
        self.node.create_subscription(kind, topic, take, qos)

    def spin_until(self, condition, timeout=20.0, what='a condition'):
        """Spin until condition() is true; fail the test after timeout seconds."""
        deadline = time.monotonic() + timeout
        while not condition():
            if time.monotonic() > deadline:
                raise AssertionError(f'timed out after {timeout:g} s waiting for {what}')
            self.executor.spin_once(timeout_sec=0.02)

    def spin_for(self, seconds):
        """Spin for a while."""
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            self.executor.spin_once(timeout_sec=0.02)

    def connected(self, timeout=20.0):
        """Wait until the node and this peer see each other's topics."""
        pubs = list(self.wrench_pubs.values()) + [self.release_pub]
        self.spin_until(lambda: all(p.get_subscription_count() > 0 for p in pubs)
                        and all(self.node.count_publishers(f'{self.ns}/{topic}') > 0
                                for topic in self.received if topic != 'events'),
                        timeout, 'discovery between the node and the test')

    def send(self, publisher, msg):
        """Publish (reliable: delivered while this peer lives) and spin a moment."""
        publisher.publish(msg)
        self.spin_for(0.05)

    def now_ns(self) -> int:
        """Return the ROS time of this peer's clock, ns."""
        return self.node.get_clock().now().nanoseconds

    def wrench(self, body, force, torque=(0.0, 0.0, 0.0), frame_id='world', stamp=0):
        """Send a wrench on bodies/<body>/wrench with a header stamp in ns."""
        msg = WrenchStamped()
        msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(int(stamp), 1_000_000_000)
        msg.header.frame_id = frame_id
        f, m = msg.wrench.force, msg.wrench.torque
        f.x, f.y, f.z = map(float, force)
        m.x, m.y, m.z = map(float, torque)
        self.send(self.wrench_pubs[body], msg)

    def release(self, joint):
        """Send a release command."""
        self.send(self.release_pub, String(data=joint))

    def clock(self, clock_ns):
        """Publish /clock at clock_ns (best effort, as ros2 bag play does)."""
        msg = Clock()
        msg.clock.sec, msg.clock.nanosec = divmod(int(clock_ns), 1_000_000_000)
        self.clock_pub.publish(msg)

    def events(self):
        """Return the events received so far, decoded."""
        return [json.loads(m.data) for m in self.received['events']]

    def close(self):
        """Destroy the peer and its context."""
        self.node.destroy_node()
        self.executor.shutdown()
        rclpy.try_shutdown(context=self.context)


#: What a flood sends, in turn: (kind, topic: 'wrench' or 'release', payload).
#: Good wrenches carry a sequence number in force.x so that each can be found.
BIG = 'x' * (1 << 20)
FLOOD_MIX = (
    ('good', 'wrench', None),
    ('nan', 'wrench', ('world', math.nan)),
    ('inf', 'wrench', ('world', math.inf)),
    ('unknown frame', 'wrench', ('nowhere', 1.0)),
    ('empty frame', 'wrench', ('', 1.0)),
    ('good', 'wrench', None),
    ('unknown joint', 'release', 'nope'),
    ('empty joint', 'release', ''),
    ('repeated release', 'release', 'pivot'),
    ('good', 'wrench', None),
)


def flood(namespace, body, seconds, rate_hz, big_every=100, wait=30.0):
    """
    Publish a mix of good and bad wrenches and releases as fast as rate_hz allows.

    Every big_every-th message is a 1 MiB string (a frame_id or a joint
    name). Return a summary: counts per kind, the good forces sent, the
    rate reached.
    """
    context = rclpy.Context()
    rclpy.init(context=context, signal_handler_options=SignalHandlerOptions.NO)
    node = rclpy.create_node('flood', context=context)
    wrench_pub = node.create_publisher(WrenchStamped, f'{namespace}/bodies/{body}/wrench',
                                       RELIABLE)
    release_pub = node.create_publisher(String, f'{namespace}/release', RELIABLE)
    deadline = time.monotonic() + wait
    while wrench_pub.get_subscription_count() == 0 or release_pub.get_subscription_count() == 0:
        if time.monotonic() > deadline:
            raise SystemExit('flood: the node never subscribed')
        time.sleep(0.05)
    counts, good = {}, []
    wrench, text = WrenchStamped(), String()
    msg = wrench
    start = time.monotonic()
    n = 0
    while True:
        now = time.monotonic()
        if now - start >= seconds:
            break
        if n >= (now - start) * rate_hz:
            time.sleep(min(0.001, n / rate_hz - (now - start)))
            continue
        kind, topic, payload = FLOOD_MIX[n % len(FLOOD_MIX)]
        if n % big_every == big_every - 1:
            kind, topic, payload = (('huge frame', 'wrench', (BIG, 1.0)) if (n // big_every) % 2
                                    else ('huge joint', 'release', BIG))
        if topic == 'wrench':
            frame, value = ('world', (len(good) + 1) / 1024) if payload is None else payload
            msg.header.frame_id = frame
            msg.wrench.force.x = value
            msg.wrench.torque.y = value if math.isfinite(value) else 0.0
            publisher = wrench_pub
        else:
            text.data = payload
            msg, publisher = text, release_pub
        try:
            publisher.publish(msg)
        except RCLError:   # DDS pushing back (a reliable writer's history full): not sent
            kind = 'not sent'
        else:
            if topic == 'wrench' and payload is None:
                good.append(value)
        msg = wrench
        counts[kind] = counts.get(kind, 0) + 1
        n += 1
    elapsed = time.monotonic() - start
    node.destroy_node()
    rclpy.try_shutdown(context=context)
    return {'sent': n, 'seconds': elapsed, 'rate_hz': n / elapsed, 'counts': counts,
            'good_forces': good}


class Flood:
    """A flood() in its own process; ``result()`` waits for its summary."""

    def __init__(self, directory, namespace, body, seconds, rate_hz=10_000.0):
        self.out = pathlib.Path(directory) / 'flood.json'
        self.process = subprocess.Popen(
            [sys.executable, __file__, '--ns', namespace, '--body', body,
             '--seconds', repr(seconds), '--rate', repr(rate_hz), '--out', str(self.out)],
            env=dict(os.environ))

    def result(self, timeout):
        """Wait for the flood to end; return its summary."""
        try:
            status = self.process.wait(timeout=timeout)
        finally:
            if self.process.poll() is None:
                self.process.kill()
                self.process.wait()
        assert status == 0, f'the flood process ended with {status}'
        return json.loads(self.out.read_text())


def _flood_main():
    parser = argparse.ArgumentParser(description='flood a cfem_node with inputs')
    parser.add_argument('--ns', default='/cfem')
    parser.add_argument('--body', required=True)
    parser.add_argument('--seconds', type=float, default=3.0)
    parser.add_argument('--rate', type=float, default=10_000.0)
    parser.add_argument('--out', required=True)
    args = parser.parse_args()
    result = flood(args.ns, args.body, args.seconds, args.rate)
    pathlib.Path(args.out).write_text(json.dumps(result))


if __name__ == '__main__':
    _flood_main()
