# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The node's ``load_markers`` are sent when the recorder writes them (SPEC section 4).

The node's publishers and a recorder take one run side by side (one
``Session``, as in the node that records): the node sends the load arrows at
every sample and at each event that starts or ends a load (the release, the
sway braces letting go, the strokes' ends), stamped at the event, as the
recording holds them; each arrow starts at the same point, in the same
frame, along the same force (read from its ends and the scale its text
states), at the same scale: one for the run, fixed at t = 0.
"""

import pathlib
import types

from cfem_ros import cli
from cfem_ros.core.engine.simulator import Simulator
from cfem_ros.core.run.session import Session
from cfem_ros.core.scenario.parse import parse_scenario
from cfem_ros.recording.container import Recorder
from cfem_ros.recording.recorder import StateRecorder
from cfem_ros.ros import publishers as cfem_publishers
import numpy as np
from recordings import read_rosbags
import yaml

CONFIG = pathlib.Path(__file__).resolve().parents[2] / 'config'


class _Node:
    """What Publishers asks of a node: publishers that keep what they publish."""

    def __init__(self):
        self.published = {}

    def create_publisher(self, kind, topic, qos):
        sent = self.published.setdefault(topic, [])
        return types.SimpleNamespace(publish=sent.append)

    def destroy_publisher(self, publisher):
        pass

    def get_namespace(self):
        return '/cfem'

    def get_logger(self):
        return types.SimpleNamespace(info=lambda text: None, warning=lambda text: None)


def _arrows(array) -> tuple:
    """Return a MarkerArray's stamp (ns) and its arrows: (frame, ns, id, start, force, scale)."""
    first, *arrows = array.markers
    assert first.action == 3   # DELETEALL: a load no longer acting goes
    stamps = {m.header.stamp.sec * 10 ** 9 + m.header.stamp.nanosec for m in array.markers}
    (stamp,) = stamps
    out = []
    for m in arrows:
        per_metre = float(m.text.rsplit('= ', 1)[1].split()[0])
        start, end = (np.array([p.x, p.y, p.z]) for p in m.points)
        out.append((m.header.frame_id, m.ns, m.id, start, (end - start) * per_metre, per_metre))
    return stamp, out


def test_the_node_sends_the_arrows_the_recording_holds(tmp_path):
    document = yaml.safe_load((CONFIG / 'store_release_two_hooks.yaml').read_text())
    document['release_groups']['station_1']['release'] = {'time': 0.05}
    document['duration'] = 0.12
    sim = Simulator(parse_scenario(document))
    node = _Node()
    out = tmp_path / 'run.mcap'
    with Recorder(str(out), metadata={'start_stamp_ns': 0}) as recorder:
        sinks = [cfem_publishers.Publishers(node, sim), StateRecorder(recorder, sim)]
        Session(sim, rate_hz=100.0, duration=0.12, outputs=sinks).run()
    kinds = [e['event'] for e in sim.events]
    assert kinds.count('release') == 2 and kinds.count('stroke_end') == 2
    assert kinds.count('brace_contact') >= 4
    sent = [_arrows(a) for a in node.published['load_markers']]
    recorded = [_arrows(m) for topic, _, m in read_rosbags(out)[0]
                if topic == '/cfem/load_markers']
    # every sample (13), and each instant of a load event, stamped there, in one order
    events = {round(e['time'] * 1e9) for e in sim.events}
    samples = {round(k * 1e7) for k in range(13)}
    assert [s for s, _ in sent] == [s for s, _ in recorded]
    assert {s for s, _ in sent} == samples | events and len(events - samples) >= 3
    for (_, node_arrows), (_, file_arrows) in zip(sent, recorded):
        assert [a[:3] for a in node_arrows] == [a[:3] for a in file_arrows]
        for a, b in zip(node_arrows, file_arrows):
            assert np.allclose(a[3], b[3], rtol=0, atol=1e-12)   # the same point of action
            # the same force, to the 4 digits of the text's scale and the float32-free ends
            assert np.allclose(a[4], b[4], rtol=1e-9, atol=1e-6 * np.linalg.norm(b[4]))
    # one scale, the same in the node and in the recording
    assert len({a[5] for _, arrows in sent + recorded for a in arrows}) == 1
    # cfem-sim run (the kernel taking the samples, one sink) draws the same instants
    scenario, alone = tmp_path / 'two_hooks.yaml', tmp_path / 'alone.mcap'
    scenario.write_text(yaml.safe_dump(document))
    assert cli.main(['run', str(scenario), '-o', str(alone)]) == 0
    assert [_arrows(m)[0] for topic, _, m in read_rosbags(alone)[0]
            if topic == '/cfem/load_markers'] == [s for s, _ in recorded]
