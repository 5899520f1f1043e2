# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The node's run: a simulator, the session that steps it, and what the session feeds.

``NodeRun`` is the part of ``node.CfemNode`` that a reset replaces as a
whole (``restart``): the simulator, its ``Session``, the odometry gate and
the input timing that read them, and the one session output that publishes
and records each sample (``outputs.NodeOutputs``). The node's pacing
(``stepping.Stepping``), inputs (``subscriptions.Subscriptions``) and run
control (``runcontrol.RunControl``) act on the run through these public
attributes and methods, never through one another's private state.
"""

from __future__ import annotations

from typing import Optional

from cfem_ros.core.engine.simulator import Simulator
from cfem_ros.core.run.session import Session
from cfem_ros.ros.outputs import NodeOutputs
from cfem_ros.ros.pacing import OdometryGate
from cfem_ros.ros.stamps import CURE_CLOCK, CURE_REAL_TIME, InputTiming, OdometryCheck


class NodeRun:
    """
    The simulation a node runs and its outputs, from t = 0 to a reset or the end.

    Parameters
    ----------
    sim : Simulator
        The simulation, at t = 0.
    publishers : Publishers
        The node's topics (``ros.publishers``).
    recording : NodeRecording or None
        The node's recording (parameter ``record``), None when it records nothing.
    rate_hz : float
        Sample rate, Hz.
    duration : float
        Where the run ends, s (``math.inf``: never).
    following_clock : bool
        True when the node follows /clock (``use_sim_time``).
    interpolate : bool
        Parameter ``interpolate_odometry``.
    warn : callable
        Takes the warning of a refused input (the node's throttled refusals).
    log_warning : callable
        Takes the odometry check's warnings (the node's logger).

    Attributes
    ----------
    sim, session, gate, timing
        The simulator, its session, the odometry gate and the input timing
        of the run now (all replaced together by ``restart``).
    publishers, recording
        The node's topics and its recording (None when not recording, or once finished).
    start_ns : int or None
        The ROS stamp of the run's t = 0, ns (None before the run starts).
    odometry_check : OdometryCheck
        Warns once per topic of odometry that disagrees with itself, over the node's life.

    """

    def __init__(self, sim, publishers, recording, *, rate_hz: float, duration: float,
                 following_clock: bool, interpolate: bool, warn, log_warning):
        self.sim = sim
        self.publishers = publishers
        self.recording = recording
        self.rate_hz, self.duration = rate_hz, duration
        self.following_clock, self.interpolate = following_clock, interpolate
        self.warn = warn
        self.odometry_check = OdometryCheck(log_warning)
        self.start_ns: Optional[int] = None
        self.timing: Optional[InputTiming] = None
        self.new_session()

    def new_session(self):
        """Make the session (and what times its inputs) of a run of self.sim from t = 0."""
        outputs = NodeOutputs(self.publishers,
                              self.recording.state if self.recording else None)
        self.session = Session(self.sim, rate_hz=self.rate_hz, duration=self.duration,
                               outputs=[outputs], warn=self.warn,
                               interpolate_odometry=self.interpolate)
        self.gate = OdometryGate(self.sim, self.session, interpolate=self.interpolate,
                                 following_clock=self.following_clock,
                                 subscribed=any(b.motion is not None
                                                for b in self.sim.model.bodies))
        late = self.timing
        self.timing = InputTiming(self.sim, self.warn,
                                  CURE_CLOCK if self.following_clock else CURE_REAL_TIME)
        if late is not None:   # counted over the node's life, resets included
            self.timing.late_inputs, self.timing.late_topics = late.late_inputs, late.late_topics

    def begin(self, start_ns: int):
        """Stamp the run's t = 0 as start_ns (ROS time, ns), for every output."""
        self.start_ns = self.timing.start_ns = int(start_ns)
        self.publishers.start_ns = self.start_ns

    def restart(self, start_ns: int):
        """
        Start again from t = 0 of the scenario on a new simulator, stamped from start_ns.

        The publishers and the recording go on with the new simulator (its
        samples in the same recording); a new session takes it.
        """
        old = self.sim
        self.sim = Simulator(old.model, logger=old.log)
        self.publishers.restart(self.sim, start_ns)
        if self.recording is not None:
            self.recording.sim = self.sim
            self.recording.state.restart(self.sim, start_ns)
        self.new_session()
        self.start_ns = self.timing.start_ns = int(start_ns)

    def finish_recording(self):
        """Finish the recording, if any (safe to call twice)."""
        if self.recording is not None:
            recording, self.recording = self.recording, None
            recording.finish()

    def recording_failed(self, err):
        """Keep what the recording holds after a failed write, and record no more."""
        recording, self.recording = self.recording, None
        recording.failed(err, self.start_ns)
