# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""Event location at its edges: a grazing contact, a touch at a step's end, unbounded shapes."""

import json
import pathlib
import struct

from cfem_ros import cli
from cfem_ros.cli.common import EXIT_CONTACT
from cfem_ros.core.engine.simulator import Simulator
from cfem_ros.core.errors import ScenarioError
from cfem_ros.core.scenario.parse import load_scenario, parse_scenario
from mcap.reader import make_reader
import numpy as np
import pytest
import yaml

CONFIG = pathlib.Path(__file__).resolve().parents[2] / 'config'
G = 9.80665


def pylon_and_store(force_n: float) -> dict:
    """Return store_separation watching [pylon, store], with a held world-z force on the store."""
    doc = yaml.safe_load((CONFIG / 'store_separation.yaml').read_text())
    doc['contacts'] = [{'bodies': ['pylon', 'store']}]
    doc['wrenches'] = [{'body': 'store', 'force': [0, 0, force_n], 'frame': 'world'}]
    doc['duration'] = 0.3
    return doc


def contact_time(tmp_path, force_n: float) -> float:
    """Run the scenario as ``cfem-sim run`` does (sampled at 100 Hz); return the contact time."""
    scenario = tmp_path / f'touch_{force_n:g}.yaml'
    scenario.write_text(yaml.safe_dump(pylon_and_store(force_n)))
    out = tmp_path / f'touch_{force_n:g}.mcap'
    assert cli.main(['run', str(scenario), '-o', str(out)]) == EXIT_CONTACT
    with open(out, 'rb') as stream:
        events = [json.loads(m.data[8:].decode().rstrip('\0')) for _, _, m in
                  make_reader(stream).iter_messages(topics=['/cfem/events'])]
    contact, = [e for e in events if e.get('event') == 'contact']
    return contact['time']


def test_a_grazing_contact_is_located_not_a_same_signs_error(tmp_path):
    # issue 41.2: at 100 N the aft end grazes the pylon's corner at a step's end, where the
    # contact check and the search's own distance differ in the last bits (warm-started);
    # the search must not assume the sign change the check saw
    times = [contact_time(tmp_path, f) for f in (99.0, 100.0, 101.0)]
    # the contact time is continuous in the force: the three within two steps
    assert max(times) - min(times) < 2e-3
    assert 0.17 < times[1] < 0.19


def test_a_touch_at_a_step_s_end_is_found_once_at_that_time():
    # a sphere falling from rest touches the floor after exactly 200 steps of 1 ms
    height = 0.5 * G * 0.2 ** 2
    doc = {'gravity': [0, 0, -G], 'dt': 0.001,
           'bodies': {'floor': {'fixed': True, 'shape': {'box': [4, 4, 0.2]}},
                      'ball': {'mass': 2.0, 'inertia': [0.1, 0.1, 0.1],
                               'position': [0, 0, 0.1 + 0.25 + height],
                               'shape': {'sphere': 0.25}}},
           'contacts': [{'bodies': ['ball', 'floor']}]}
    sim = Simulator(parse_scenario(doc))
    sim.advance_to(1.0)
    event, = sim.events
    assert sim.status == 'contact' and abs(event['time'] - 0.2) < 1e-9


@pytest.mark.parametrize('radius', [1e30, 1e10])
def test_a_sphere_radius_is_bounded_like_a_box(radius):
    doc = pylon_and_store(0.0)
    doc['bodies']['store']['shape'] = {'sphere': radius}
    with pytest.raises(ScenarioError, match=r'bodies\.store\.shape\.sphere: is 1e\+\d+'):
        parse_scenario(doc)


def test_a_mesh_beyond_1e9_m_is_refused_with_its_key(tmp_path):
    points = 1e30 * np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=float)
    faces = [(0, 1, 2), (0, 1, 3), (0, 2, 3), (1, 2, 3)]
    with open(tmp_path / 'huge.stl', 'wb') as handle:
        handle.write(b'\0' * 80 + struct.pack('<I', len(faces)))
        for face in faces:
            handle.write(struct.pack('<12fH', 0, 0, 0, *np.ravel(points[list(face)]), 0))
    doc = pylon_and_store(0.0)
    doc['bodies']['store']['shape'] = {'mesh': 'huge.stl'}
    (tmp_path / 's.yaml').write_text(yaml.safe_dump(doc))
    with pytest.raises(ScenarioError, match=r'bodies\.store\.shape\.mesh: huge\.stl has a '
                       r'vertex 1e\+30 m from its origin'):
        load_scenario(str(tmp_path / 's.yaml'))
