# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
What a simulator's state becomes as messages (SPEC section 3), recorded without rclpy.

``StateRecorder`` is a ``Session`` sink: each sample's poses, twists, loads,
air and /tf as rows of a ``SampleLayout``, the events and markers as they
come, the inputs as received; the topics, types, frames and periods are
``schema``'s. The file itself is a ``container.Recorder``. The load arrows
of every sample and of each event that starts or ends a load (at the
event's state, stamped with its time) are written as they come, in time
order, at the one scale fixed at t = 0 (``loadarrows.LoadArrows``).
"""

from __future__ import annotations

import json
import os

from cfem_ros.core.engine.aero import AIR_TOPICS
from cfem_ros.core.engine.events import Event
from cfem_ros.core.native.kernel import SAMPLE
from cfem_ros.core.run.inputs import InputKind, odometry_parts, stamp_problem
from cfem_ros.core.run.session import RowSink
from cfem_ros.recording import loadarrows, schema, viewframes, visuals
from cfem_ros.recording.container import encoder, offered_qos, Recorder
from cfem_ros.recording.markerbytes import MarkerArrayEncoder
from cfem_ros.recording.samplelayout import InBodyAxes, SampleLayout, TransformsOf
import numpy as np


#: The events that start or end a load: the load arrows are drawn at each (SPEC section 4).
LOAD_EVENTS = loadarrows.LOAD_EVENTS
#: A pose message's numbers (CG position, quaternion) and a twist's (CG velocity, rates):
#: a sample's body columns (``SAMPLE``), in their order.
POSE = SAMPLE.width('O_POSITION') + SAMPLE.width('O_QUATERNION')
TWIST = SAMPLE.width('O_VELOCITY') + SAMPLE.width('O_RATES')


def stamp(stamp_ns: int) -> dict:
    """builtin_interfaces/Time of integer nanoseconds."""
    sec, nanosec = divmod(int(stamp_ns), 1_000_000_000)
    return {'sec': sec, 'nanosec': nanosec}


def seconds_to_ns(t: float) -> int:
    """Integer nanoseconds nearest to t seconds."""
    return int(round(t * 1e9))


def run_metadata(model, scenario: str, rate_hz: float, start_ns: int, **extra) -> dict:
    """Describe a run for its ``cfem_ros`` metadata record (what it is, where t = 0 is)."""
    return {'scenario': os.path.abspath(scenario), 'name': model.name,
            'start_stamp_ns': int(start_ns), 'dt': repr(model.dt), 'rate_hz': repr(rate_hz),
            'frame_id': model.frame_id,
            'gravity': '[' + ', '.join(repr(float(g)) for g in model.gravity) + ']', **extra}


def _vector(v) -> dict:
    return {'x': float(v[0]), 'y': float(v[1]), 'z': float(v[2])}


class StateRecorder(RowSink):
    """
    Record a simulator's outputs and inputs as the node publishes them.

    Parameters
    ----------
    recorder : Recorder
    sim : Simulator
    namespace : str
        Prefix of every topic (SPEC section 3), '/cfem' by default.
    start_ns : int
        Stamp of simulated time 0, ns.

    """

    def __init__(self, recorder: Recorder, sim, namespace: str = '/cfem', start_ns: int = 0):
        self.recorder = recorder
        self.sim = sim
        self.namespace = namespace.rstrip('/')
        self.start_ns = int(start_ns)
        self.world = sim.model.frame_id
        model = sim.model
        self._events_written = 0
        self._layouts = {}   # active joints -> SampleLayout
        self._rows_layout = None   # the layout of the rows last handed out
        #: Samples recorded so far.
        self.samples = 0
        moving = [i for i, b in enumerate(model.bodies) if not b.fixed]
        self._transforms = TransformsOf(
            self.world, tuple(model.bodies[i].name for i in moving),
            tuple(SAMPLE.BODY * i + SAMPLE.O_POSITION for i in moving)) if moving else None
        # the carriers' z-up frames, computed from their poses, in the same message (a
        # viewer seeking shows the last /tf message before the time: it must hold all)
        self._views = viewframes.of_model(model)
        if self._views is not None:
            views = self._views
            self._transforms = TransformsOf(
                (self.world,) * len(moving) + (views.root,) * len(views.names),
                self._transforms.children + views.names,
                self._transforms.columns + tuple(7 * k for k in range(len(views.names))),
                computed=len(views.names))
        self._scene_written = False
        # the next sending of the markers: one period after the scene's
        self._marker_cadence = schema.Cadence(schema.MARKERS.period, first=1)
        self._marker_bytes = MarkerArrayEncoder(encoder(schema.MARKERS.msgtype))
        self._arrows = loadarrows.LoadArrows(model, self.namespace, sim.applied_sources)
        loadarrows.watch_loads(sim)   # the state at a load event stepped over
        # drawn with joints or applied loads, and from the first wrench input on
        self._arrows_on = bool(model.joints or sim.applied_sources)

    def topic(self, topic: schema.Topic, **names) -> str:
        """Return the absolute name of a topic of the schema, of these names."""
        return topic.absolute(self.namespace, **names)

    def _write(self, topic: schema.Topic, message, stamp_ns: int, **names):
        """Write a message of a topic of the schema (its type and recorded QoS)."""
        self.recorder.write(self.topic(topic, **names), topic.msgtype, message, stamp_ns,
                            qos=offered_qos(topic.in_recording))

    def _between(self, k: int, topic: schema.Topic, message, stamp_ns: int) -> tuple:
        """Return a message to write before the k-th of some samples (``commit_rows``)."""
        return (k, self.topic(topic), topic.msgtype, message, stamp_ns,
                offered_qos(topic.in_recording))

    def stamp_ns(self, t: float) -> int:
        """Stamp of simulated time t, ns."""
        return self.start_ns + seconds_to_ns(t)

    def _scene(self):
        """Record the fixed bodies' frames and the markers, once, at t = 0."""
        self._scene_written = True
        when = self.stamp_ns(0.0)
        self._write(schema.TF_STATIC, visuals.static_transforms(self.sim.model, stamp(when)),
                    when)
        self._markers(when)

    def _markers_again(self, times) -> list:
        """
        Return the markers to send again among samples at these times (s), as ``between``.

        One sending after the first sample of each ``schema.MARKERS.period``
        of simulated time, for the viewers that join late with volatile
        durability (RViz's default, live or during ``ros2 bag play``).
        """
        out = []
        for k, t in enumerate(times):
            if self._marker_cadence.take(t):
                when = self.stamp_ns(t)
                out.append(self._between(k + 1, schema.MARKERS, self._marker_array(when, t),
                                         when))
        return out

    def _arrows_among(self, times, rows, active) -> list:
        """
        Return the load arrows of samples at these times (s), as ``between``.

        From the samples' numbers (rows in ``Simulator.outputs`` order, these
        joints active) and the wrenches held on the bodies; each written
        just after its sample, with its stamp. Before anything is drawn
        (no joint, no applied load, no wrench input yet) the first sample
        still fixes the scale, as the node's does.
        """
        if not self._arrows_on:
            self._arrows.fix_scale([])
            return []
        held = self.sim.held_wrenches()
        out = []
        for k, t in enumerate(times):
            when = self.stamp_ns(t)
            out.append(self._between(k + 1, schema.LOAD_MARKERS,
                                     self._arrow_bytes(when, rows[k], active, held), when))
        return out

    def _arrow_bytes(self, stamp_ns: int, row, active, held) -> bytes:
        """Return the load arrows of a state (``LoadArrows.message``) stamped stamp_ns, CDR."""
        message, kind = self._arrows.message(stamp(stamp_ns), row, active, held)
        return self._marker_bytes(message, kind=kind)

    def _marker_array(self, stamp_ns: int, t: float) -> bytes:
        """Return the MarkerArray at simulated time t (the joints released by then in red), CDR."""
        released = {e['joint'] for e in self.sim.events
                    if e.get('event') == Event.RELEASE and e['time'] <= t}
        contacts = [e for e in self.sim.events
                    if e.get('event') == Event.CONTACT and e['time'] <= t]
        return self._marker_bytes(visuals.markers(self.sim.model, stamp(stamp_ns),
                                                  self.namespace, released, contacts))

    def _markers(self, stamp_ns: int):
        t = (stamp_ns - self.start_ns) / 1e9
        self._write(schema.MARKERS, self._marker_array(stamp_ns, t), stamp_ns)

    def sample(self, outputs=None):
        """
        Record poses, twists and active joints' wrenches at the current state.

        outputs: the sample's numbers (``Simulator.outputs``) if already
        computed: the node computes each sample once for all its outputs.
        """
        if not self._scene_written:
            self._scene()
        sim = self.sim
        layout = self._layout(sim.active_joints)
        row = layout.next_row()
        if outputs is None:
            sim.outputs(out=row)
        else:
            row[:] = outputs
        arrows = self._arrows_among([sim.t], [row], sim.active_joints)
        self.recorder.add_sample(layout, self.stamp_ns(sim.t))
        self.samples += 1
        for _, *message in arrows + self._markers_again([sim.t]):
            self.recorder.write(*message)

    def sample_rows(self) -> np.ndarray:
        """Return buffer rows for the next samples' ``Simulator.outputs`` (see ``took_rows``)."""
        if not self._scene_written:
            self._scene()
        self._rows_active = self.sim.active_joints
        self._rows_layout = self._layout(self._rows_active)
        return self.recorder.free_rows(self._rows_layout)

    def took_rows(self, times: np.ndarray):
        """Record the samples at these simulated times (s), in the first rows given."""
        stamps = self.start_ns + np.rint(np.asarray(times) * 1e9).astype(np.int64)
        layout = self._rows_layout
        rows = layout.values[layout.count:layout.count + len(stamps)]
        between = self._arrows_among(times, rows, self._rows_active) + self._markers_again(times)
        self.recorder.commit_rows(layout, stamps, sorted(between, key=lambda m: m[0]))
        self.samples += len(stamps)

    def _layout(self, active) -> 'SampleLayout':
        layout = self._layouts.get(active)
        if layout is None:
            layout = self._layouts[active] = self.recorder.layout(self._messages(active))
        return layout

    def _messages(self, active):
        """
        List the messages of a sample with these joints active.

        First those whose numbers a sample holds, in ``Simulator.outputs``
        order (the loads in world axes); then the loads again in the axes
        where they act (the joint's child, the loaded body: SPEC sections
        3 and 5), turned from those numbers, and /tf.
        """
        messages, turned = [], []
        model = self.sim.model
        bodies = model.bodies
        row = self._sampled
        for body in bodies:
            messages += [row(schema.POSE, POSE, body=body.name),
                         row(schema.TWIST, TWIST, body=body.name)]
        column = SAMPLE.BODY * len(bodies)
        for k in active:
            joint = model.joints[k]
            messages.append(row(schema.JOINT_WRENCH_WORLD, SAMPLE.JOINT, joint=joint.name))
            turned.append(row(schema.JOINT_WRENCH, InBodyAxes(
                column, SAMPLE.BODY * joint.child + SAMPLE.O_QUATERNION), joint=joint.name))
            column += SAMPLE.JOINT
        for body, source in self.sim.applied_sources:   # scheduled loads
            messages.append(row(schema.APPLIED_WORLD, SAMPLE.WRENCH, body=body, source=source))
            turned.append(row(schema.APPLIED, InBodyAxes(
                column, SAMPLE.BODY * model.body_index(body) + SAMPLE.O_QUATERNION),
                body=body, source=source))
            column += SAMPLE.WRENCH
        for entry in model.aero:   # the air each body sees (SPEC section 10), 3 a topic
            body = bodies[entry.body].name
            messages += [row(schema.AIR, 3, body=body, quantity=name) for name, _ in AIR_TOPICS]
        for body, ref in self.sim.model.references:   # in a carrier's frame (core/motion.py)
            names = {'body': bodies[body].name, 'reference': bodies[ref].name}
            messages += [row(schema.RELATIVE_POSE, POSE, **names),
                         row(schema.RELATIVE_TWIST, TWIST, **names)]
        messages += turned
        if self._transforms is not None:
            messages.append((self.topic(schema.TF), schema.TF.msgtype, self._transforms,
                             self._views))
        return messages

    def _sampled(self, topic: schema.Topic, count, **names) -> tuple:
        """Return a message of a sample for ``Recorder.layout``: topic, type, frame, count."""
        return (self.topic(topic, **names), topic.msgtype,
                topic.frame_id(world=self.world, **names), count)

    def events(self):
        """Record the simulator's events not yet recorded, at their own times."""
        if len(self.sim.events) == self._events_written:
            return
        new = self.sim.events[self._events_written:]
        # what acts from each load event on, drawn at its instant after the events there
        drawn = loadarrows.event_states(self.sim, new) if self._arrows_on else []
        for event in new:
            while drawn and drawn[0][0] < event['time']:
                self._event_arrows(*drawn.pop(0))
            self._write(schema.EVENTS, {'data': json.dumps(event)}, self.stamp_ns(event['time']))
            if event.get('event') == Event.RELEASE:
                self._zero_load(event['joint'], self.stamp_ns(event['time']))
        self._events_written = len(self.sim.events)
        for state in drawn:
            self._event_arrows(*state)
        if self._scene_written and any(e.get('event') in (Event.RELEASE, Event.CONTACT)
                                       for e in new):
            # released joints change colour; contacts get their marker
            self._markers(self.stamp_ns(new[-1]['time']))

    def _event_arrows(self, t: float, row, active, held):
        """Record the load arrows of the state just after load events at time t (s)."""
        when = self.stamp_ns(t)
        self._write(schema.LOAD_MARKERS, self._arrow_bytes(when, row, active, held), when)

    def _zero_load(self, joint: str, stamp_ns: int):
        """Record a released joint's load as zero once, at its release: plots end at zero."""
        zero = {'force': _vector((0, 0, 0)), 'torque': _vector((0, 0, 0))}
        for topic in (schema.JOINT_WRENCH, schema.JOINT_WRENCH_WORLD):
            self._write(topic, {'header': {'stamp': stamp(stamp_ns), 'frame_id': topic.frame_id(
                world=self.world, joint=joint)}, 'wrench': zero}, stamp_ns, joint=joint)

    def note(self, event: dict):
        """Record an event of the node's own (a pause, a step, a reset) at its time."""
        self._write(schema.EVENTS, {'data': json.dumps(event)}, self.stamp_ns(event['time']))

    def restart(self, sim, start_ns: int):
        """Go on recording a new run of the same model (a reset): sim from start_ns on."""
        self.sim = sim
        loadarrows.watch_loads(sim)
        self.start_ns = int(start_ns)
        self._events_written = 0
        self._marker_cadence.restart()
        self._markers(self.stamp_ns(0.0))

    def failed(self):
        """Record the run's failure as an ``error`` event at the time it stopped."""
        sim = self.sim
        self._write(schema.EVENTS, {'data': json.dumps(
            {'event': Event.ERROR, 'time': sim.t, 'message': sim.message})}, self.stamp_ns(sim.t))

    def received(self, item, t: float):
        """
        Record an input as received, logged at the simulated time t it took effect.

        The log time is what ``cfem-sim run --inputs`` replays it at; a
        wrench's header keeps the stamp it arrived with (the log time if it
        had none).
        """
        stamp_ns = self.stamp_ns(t)
        if item.kind is InputKind.RELEASE:
            self._write(schema.RELEASE_INPUT, {'data': item.target}, stamp_ns)
            return
        header_ns = stamp_ns if item.header_ns is None else item.header_ns
        if stamp_problem(header_ns):   # refused, and no header can hold it: the log time's
            header_ns = stamp_ns
        self._arrows_on = self._arrows_on or item.kind is InputKind.WRENCH
        if item.kind is InputKind.ODOM:
            position, quaternion, velocity, rates = odometry_parts(item.values)
            self._write(schema.ODOMETRY_INPUT, {
                'header': {'stamp': stamp(header_ns), 'frame_id': item.frame_id},
                'child_frame_id': item.target,
                'pose': {'pose': {'position': _vector(position),
                                  'orientation': dict(zip('xyzw', map(float, quaternion)))},
                         'covariance': [0.0] * 36},
                'twist': {'twist': {'linear': _vector(velocity), 'angular': _vector(rates)},
                          'covariance': [0.0] * 36},
            }, stamp_ns, body=item.target)
            return
        self._write(schema.WRENCH_INPUT, {
            'header': {'stamp': stamp(header_ns), 'frame_id': item.frame_id},
            'wrench': {'force': _vector(item.force), 'torque': _vector(item.torque)},
        }, stamp_ns, body=item.target)
