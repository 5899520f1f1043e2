# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The node's one ``Session`` output: each sample computed once, for every output (issue 47.3).

A sample's numbers (``Simulator.outputs``: poses, twists, loads, air,
relative states, in one kernel call) are computed once and handed to the
recording (``StateRecorder.sample``) and to the publishers
(``Publishers.publish``), which turn them with the same functions: what the
node publishes is what it records, by construction, and a sample costs one
joint solve, not one per output.
"""

from __future__ import annotations

from typing import Optional

from cfem_ros.core.run.session import Sink


class NodeOutputs(Sink):
    """
    The publishers and, if recording, the recorder, fed from one computation per sample.

    Parameters
    ----------
    publishers : Publishers
        The node's topics (``ros.publishers``).
    recorder : StateRecorder or None
        The recording's sampled state (``NodeRecording.state``), None when
        the node records nothing.

    """

    def __init__(self, publishers, recorder: Optional[object] = None):
        self.publishers = publishers
        self.recorder = recorder
        self._sinks = [publishers] + ([recorder] if recorder is not None else [])

    def received(self, item, t: float):
        """Hand an input that took effect at simulated time t to every output."""
        for sink in self._sinks:
            sink.received(item, t)

    def events(self):
        """Hand the simulator's new events to every output."""
        for sink in self._sinks:
            sink.events()

    def sample(self):
        """Compute the sample's numbers once; record them, then publish them."""
        sim = self.publishers.sim
        row = sim.outputs()   # a numerical failure here fails the run (Session._sample)
        if self.recorder is not None:
            self.recorder.sample(row)
        self.publishers.publish(row, sim.active_joints)
