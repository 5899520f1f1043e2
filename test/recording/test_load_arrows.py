# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Every load is drawn where it acts, at one scale per sending (``load_markers``).

The near-pylon example for 0.12 s (hooks until 0.05 s, two ejectors, aero)
with a wrench held on the store by an input at a point: each arrow, read
back with rosbags, against the loads the same recording publishes (the
applied topics in body axes, the joint's in its frame).
"""

import pathlib

from cfem_ros import cli
from cfem_ros.recording.container import Recorder
from cfem_ros.recording.loadarrows import COLORS, newtons_per_metre
from cfem_ros.recording.schema import WRENCH_TYPE
import numpy as np
import pytest
from recordings import read_rosbags
from scipy.spatial.transform import Rotation

CONFIG = pathlib.Path(__file__).resolve().parents[2] / 'config'
HELD_AT = np.array([1.0, 0.0, 0.0])   # body axes, from the CG, m
HELD = np.array([0.0, 3000.0, 0.0])   # N, world axes


@pytest.fixture(scope='module')
def near(tmp_path_factory):
    folder = tmp_path_factory.mktemp('load_arrows')
    inputs = folder / 'inputs.mcap'
    with Recorder(str(inputs)) as recorder:
        recorder.write('/cfem/bodies/store/wrench', WRENCH_TYPE, {
            'header': {'stamp': {'sec': 0, 'nanosec': 0}, 'frame_id': 'world@1.0,0,0'},
            'wrench': {'force': dict(zip('xyz', HELD))}}, 0)
    out = folder / 'near.mcap'
    assert cli.main(['run', str(CONFIG / 'store_release_near_pylon.yaml'), '-o', str(out),
                     '--duration', '0.12', '--inputs', str(inputs)]) == 0
    messages, _ = read_rosbags(out)
    return messages


def _vector(v):
    return np.array([v.x, v.y, v.z])


def test_each_load_from_where_it_acts_along_its_force(near):
    arrays = [(t, m) for topic, t, m in near if topic == '/cfem/load_markers']
    assert [t for t, _ in arrays] == [0, 100_000_000]
    pose = {t: m.pose.orientation for topic, t, m in near if topic == '/cfem/bodies/store/pose'}
    largest = 42703.0   # the scale starts from the largest scheduled load: the aft ejector
    for t, array in arrays:
        arrows = {m.text.split(':')[0]: m for m in array.markers if m.action == 0}
        # the hooks until their release; the input from just after the sample at 0
        expected = {'forward_ejector ejector', 'aft_ejector ejector', 'aero aero'} | (
            {'hooks joint'} if t == 0 else {'store input'})
        assert set(arrows) == expected
        scales = {float(m.text.rsplit('= ', 1)[1].split()[0]) for m in arrows.values()}
        (per_metre,) = scales   # one scale per sending, stated in every text
        lengths, forces = [], []
        for label, arrow in arrows.items():
            source, kind = label.split()
            assert arrow.frame_locked and arrow.type == 0
            assert (arrow.color.r, arrow.color.g, arrow.color.b) == pytest.approx(
                COLORS[kind][:3])
            start, end = (_vector(p) for p in arrow.points)
            drawn = (end - start) * per_metre   # the force, N, in the frame's axes
            lengths.append(np.linalg.norm(end - start))
            forces.append(np.linalg.norm(drawn))
            if kind == 'joint':
                (load,) = [m.wrench for topic, s, m in near
                           if topic == '/cfem/joints/hooks/wrench' and s == t]
                assert arrow.header.frame_id == 'hooks' and not start.any()
                np.testing.assert_allclose(drawn, _vector(load.force), rtol=1e-9)
                continue
            assert arrow.header.frame_id == 'store'
            if kind == 'input':
                q = pose[t]
                turn = Rotation.from_quat([q.x, q.y, q.z, q.w])
                np.testing.assert_array_equal(start, HELD_AT)
                np.testing.assert_allclose(drawn, turn.inv().apply(HELD), rtol=1e-9)
                continue
            (load,) = [m.wrench for topic, s, m in near
                       if topic == f'/cfem/bodies/store/applied/{source}' and s == t]
            force, moment = _vector(load.force), _vector(load.torque)
            np.testing.assert_allclose(drawn, force, rtol=1e-9)
            if kind == 'ejector':   # at the scenario's point (its x station, on the top)
                assert start[2] == -0.25 and start[0] in (0.1798, -0.3292)
            else:   # aero: on its line of action (the moment about the CG is start x force)
                along = moment @ force / (force @ force) * force
                np.testing.assert_allclose(np.cross(start, force), moment - along,
                                           atol=1e-9 * np.linalg.norm(moment))
                assert 0 < np.linalg.norm(start) <= 1.5   # on the store (3 m long)
        # the largest so far about the size of the store (3.0 m): 1, 2 or 5 N per m times 10^k
        largest = max([largest] + forces)
        assert per_metre == newtons_per_metre(largest, 3.0)
        assert 0.4 * 3.0 <= largest / per_metre <= 3.0 and max(lengths) <= 3.0
