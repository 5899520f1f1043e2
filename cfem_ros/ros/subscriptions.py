# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The node's inputs (SPEC section 3): wrenches, odometry and release commands to the session.

Each message becomes an ``Input`` (strings bounded, ``refusals.bounded``),
timed (``stamps.InputTiming``) and given to the session; a refused one is
counted and logged, throttled. ``Subscriptions`` is a part that
``node.CfemNode`` holds: it gives inputs to the node's run (``node.run``)
and moves it on through the node's pacing (``node.stepping``).
"""

import time
from typing import Optional

from cfem_ros.core.run.inputs import (Input, InputKind, odometry_input, release_input,
                                      wrench_input)
from cfem_ros.recording import schema
from cfem_ros.ros.qos import input_qos
from cfem_ros.ros.refusals import bounded
from geometry_msgs.msg import WrenchStamped
from nav_msgs.msg import Odometry
from std_msgs.msg import String


def taken(subscription):
    """Yield (message, MessageInfo) of each message waiting on a subscription, taking it."""
    while True:
        with subscription.handle:
            pair = subscription.handle.take_message(subscription.msg_type, subscription.raw)
        if pair is None:
            return
        yield pair


class QueueWatch:
    """
    Count the input messages a full queue lost, from the publishers' sequence numbers.

    A publisher numbers its messages 1, 2, 3...; a reader whose queue was
    full when the next came lost the oldest it held: the numbers the node
    takes then skip. Counted per topic (``dropped``) and warned about
    (the first time per topic, then counted), never silent. Messages sent
    before the node saw the publisher are not counted.
    """

    def __init__(self, depth: int, warn):
        self.depth, self.warn = depth, warn
        self.dropped = {}   # topic -> messages lost
        self._last = {}     # (topic, publisher gid) -> the last sequence number taken

    def took(self, topic: str, info):
        """Take the MessageInfo of a message the node takes from topic."""
        number = info.get('publication_sequence_number') if info else None
        gid = (info.get('publisher_gid') or {}).get('data') if info else None
        if not number or gid is None:   # an rmw that does not number its messages
            return
        last = self._last.get((topic, gid))
        self._last[(topic, gid)] = max(number, last or 0)
        if last is None or number <= last + 1:
            return
        lost = number - last - 1
        first = topic not in self.dropped
        self.dropped[topic] = self.dropped.get(topic, 0) + lost
        if first:
            self.warn(f'{topic}: {lost} messages were lost before the node took them: the '
                      f'input queue (input_queue_depth {self.depth}) was full while the node '
                      'was busy; raise input_queue_depth, or lower the rate of the inputs. '
                      'Further losses are counted (dropped_inputs)')

    @property
    def total(self) -> int:
        """Return the messages lost on every topic."""
        return sum(self.dropped.values())

    def summary(self) -> str:
        """Return ``dropped_inputs N`` and, if any, the topics that lost them with their counts."""
        if not self.total:
            return 'dropped_inputs 0'
        return f'dropped_inputs {self.total} (' + ', '.join(
            f'{count} on {topic}' for topic, count in sorted(self.dropped.items())) + ')'


class Subscriptions:
    """
    The input topics and what the node does with their messages.

    Parameters
    ----------
    node : CfemNode
        The node that holds it: the subscriptions are made on it; inputs go
        to its ``run``, and its ``stepping`` times them and goes on after them.
    model : Model
        The scenario: a wrench topic per body, odometry per kinematic body.
    depth : int
        Parameter ``input_queue_depth``.

    Attributes
    ----------
    queues : QueueWatch
        The messages full queues lost, per topic.
    refused : dict
        Messages refused, per topic.

    """

    def __init__(self, node, model, depth: int):
        self.node = node
        self.queues = QueueWatch(depth, node.refusals.warning)
        self.refused = {}   # topic -> messages refused
        self._early = []    # inputs that came before the run started
        self._taking = False   # in take_waiting
        qos = input_qos(depth)
        subscriptions = self._input_subscriptions = []
        for body in model.bodies:
            subscriptions.append(node.create_subscription(
                WrenchStamped, schema.WRENCH_INPUT.relative(body=body.name),
                lambda msg, info, name=body.name: self._on_wrench(name, msg, info), qos))
            if body.motion is not None:   # a kinematic body may follow odometry
                subscriptions.append(node.create_subscription(
                    Odometry, schema.ODOMETRY_INPUT.relative(body=body.name),
                    lambda msg, info, name=body.name: self._on_odometry(name, msg, info), qos))
        self._release_sub = node.create_subscription(
            String, schema.RELEASE_INPUT.relative(), self._on_release, qos)
        subscriptions.append(self._release_sub)

    def take_waiting(self):
        """
        Take every input message waiting in the node's queues now, before the run goes on.

        The executor would take one message per topic per wait, after the
        /clock that moves the run on: a busy node would then find inputs
        stamped well before the /clock it just followed, and apply them
        late. Taken here, in one pass (at most ``input_queue_depth`` a topic),
        each waits for its stamp as on an idle node.
        """
        self._taking = True
        try:
            for subscription in self._input_subscriptions:
                for _, (msg, info) in zip(range(self.queues.depth), taken(subscription)):
                    subscription.callback(msg, info)
        finally:
            self._taking = False

    def submit_early(self):
        """Give the session the inputs that came before the run started, in their order."""
        for item in self._early:
            self.submit(*item)
        self._early.clear()

    def _on_wrench(self, body: str, msg: WrenchStamped, info):
        stamp = msg.header.stamp
        header_ns = stamp.sec * 1_000_000_000 + stamp.nanosec
        f, m = msg.wrench.force, msg.wrench.torque
        topic = self.node.resolve_topic_name(schema.WRENCH_INPUT.relative(body=body))
        self.queues.took(topic, info)
        self.submit(topic, wrench_input(body, [f.x, f.y, f.z], [m.x, m.y, m.z],
                                        bounded(msg.header.frame_id), header_ns=header_ns), info)

    def _on_odometry(self, body: str, msg: Odometry, info):
        self.node.run.gate.seen += 1
        stamp = msg.header.stamp
        p, q = msg.pose.pose.position, msg.pose.pose.orientation
        v, w = msg.twist.twist.linear, msg.twist.twist.angular
        topic = self.node.resolve_topic_name(schema.ODOMETRY_INPUT.relative(body=body))
        self.queues.took(topic, info)
        self.submit(topic, odometry_input(
            body, [p.x, p.y, p.z], [q.x, q.y, q.z, q.w], [v.x, v.y, v.z], [w.x, w.y, w.z],
            bounded(msg.header.frame_id),
            header_ns=stamp.sec * 1_000_000_000 + stamp.nanosec), info)

    def _on_release(self, msg: String, info):
        self.queues.took(self._release_sub.topic_name, info)
        self.submit(self._release_sub.topic_name, release_input(bounded(msg.data.strip())),
                    info)

    def _arrival_time(self) -> Optional[float]:
        """
        Return the simulated time at which an input arriving now takes effect (None: at once).

        In real time, where the wall clock says the simulation is, in whole
        nanoseconds (as the recording logs it, so a replay applies it at the
        same time), never past the end of the run.
        """
        node = self.node
        if node.sim_time or node.pace.factor == 0:
            return None
        target = node.pace.target(time.monotonic())
        return min(round(target * 1e9) / 1e9, node.duration)

    def submit(self, topic: str, item: Input, info=None):
        """
        Give an input to the session; a refused one is logged (throttled) and counted.

        Strings are already cut to ``REFUSED_STRING_BYTES`` (``bounded``):
        longer ones never name a frame or joint, so they are refused, and
        recorded and logged in that bounded form. info: the message's
        MessageInfo (following /clock, an unstamped input takes the time of
        the /clock sent before it, ``Stepping.clock_of``).
        """
        node, stepping = self.node, self.node.stepping
        if node.exit_code is not None:
            return
        run = node.run
        if run.start_ns is None:
            self._early.append((topic, item, info))
            return
        # at its stamp if that is still ahead; else at the clock's time, which is ahead of
        # the simulation while it waits for odometry (``OdometryGate``), or at once
        run.odometry_check.check(topic, item)
        if node.sim_time:
            now = stepping.clock_of(info) if not item.header_ns else stepping.clock_limit
        else:
            now = self._arrival_time()
        item = run.timing.timed(topic, item, now)
        try:
            run.session.submit(item)
        except ValueError as err:
            self.refused[topic] = self.refused.get(topic, 0) + 1
            node.refusals.warning(f'{topic}: message not applied: {err}')
        if item.kind is InputKind.ODOM and run.gate.interpolate and not self._taking:
            # what waited for it goes on (taken with others: once they are all taken)
            if node.sim_time and stepping.clock_limit is not None:
                stepping.catch_up()
            elif not node.sim_time and node.pace.factor > 0:
                stepping.run_to(node.pace.target(time.monotonic()))
        if stepping.clock_moved and not self._taking:   # /clock taken to time this input
            stepping.clock_moved = False
            self.take_waiting()
            stepping.catch_up()
        if run.session.finished and node.exit_code is None:
            stepping.end()

    def log_refused(self):
        """Log how many messages each topic had refused (once: the counts are then cleared)."""
        if self.refused:
            self.node.get_logger().info('messages refused: ' + ', '.join(
                f'{count} on {topic}' for topic, count in sorted(self.refused.items())))
            self.refused = {}
