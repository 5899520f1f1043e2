# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""Contacts between watched shapes, located in the step: closed forms and a DOP853 event."""

import json
import math
import struct

from cfem_ros import cli
from cfem_ros.core.engine.simulator import Simulator
from cfem_ros.core.errors import ScenarioError
from cfem_ros.core.scenario.parse import parse_scenario
from mcap.reader import make_reader
import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq
from scipy.spatial.transform import Rotation
import yaml

G = 9.80665
#: The contact time asked for (issue 25), s.
TIME_TOLERANCE = 1e-9


def drop(shape, position, *, velocity=(0, 0, 0), rates=(0, 0, 0), rpy=(0, 0, 0),
         on_contact='stop', dt=0.001, inertia=(0.1, 0.12, 0.15)):
    """Return a scenario: a body with shape falling onto a fixed 4 x 4 x 0.2 m box at z = 0."""
    return {'gravity': [0, 0, -G], 'dt': dt,
            'bodies': {'floor': {'fixed': True, 'shape': {'box': [4, 4, 0.2]}},
                       'body': {'mass': 2.0, 'inertia': list(inertia), 'position': list(position),
                                'velocity': list(velocity), 'angular_velocity': list(rates),
                                'orientation_rpy_deg': list(rpy), 'shape': shape}},
            'contacts': [{'bodies': ['body', 'floor'], 'on_contact': on_contact}]}


def fall_time(height, v0=0.0):
    """Return when a body falling from rest (or at v0 downward) has dropped height, s."""
    return (-v0 + math.sqrt(v0 * v0 + 2 * G * height)) / G


def test_a_sphere_hits_the_box_at_the_closed_form_time_and_point():
    sim = Simulator(parse_scenario(drop({'sphere': 0.25}, [0.3, 0.2, 1.0])))
    assert not sim.advance_to(2.0) and sim.status == 'contact'
    event, = sim.events
    # the sphere's bottom falls from 1.0 - 0.25 to the top face at 0.1
    assert abs(event['time'] - fall_time(0.65)) < TIME_TOLERANCE
    assert event['bodies'] == ['body', 'floor']
    np.testing.assert_allclose(event['point'], [0.3, 0.2, 0.1], rtol=0, atol=1e-9)
    assert sim.t == event['time'] and 'body touches floor' in sim.message


def test_a_box_thrown_down_hits_flat_at_the_closed_form_time():
    # a box turned about z only stays flat: its bottom face drops to the floor's top
    sim = Simulator(parse_scenario(drop({'box': [0.6, 0.4, 0.3]}, [-0.5, 0.4, 2.0],
                                        velocity=[0, 0, -3.0], rpy=[0, 0, 37.0])))
    sim.advance_to(2.0)
    event, = sim.events
    assert abs(event['time'] - fall_time(2.0 - 0.15 - 0.1, 3.0)) < TIME_TOLERANCE
    assert event['point'][2] == pytest.approx(0.1, abs=1e-9)


def tumbling_reference(position, velocity, rpy_deg, rates, inertia, half, floor):
    """DOP853 on a free rigid body; the event: the lowest corner of the box at the floor."""
    inertia = np.diag(inertia)
    inverse = np.linalg.inv(inertia)
    corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1)
                        for sz in (-1, 1)]) * half

    def rhs(_, s):
        rot, w = s[6:15].reshape(3, 3), s[15:18]
        skew = np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])
        return np.concatenate([s[3:6], [0, 0, -G], (rot @ skew).ravel(),
                               inverse @ -np.cross(w, inertia @ w)])

    def lowest(_, s):
        return float(np.min(s[2] + corners @ s[6:15].reshape(3, 3)[2])) - floor

    lowest.terminal, lowest.direction = True, -1
    rot0 = Rotation.from_euler('ZYX', rpy_deg[::-1], degrees=True).as_matrix()
    state0 = np.concatenate([position, velocity, rot0.ravel(), rates])
    sol = solve_ivp(rhs, (0, 5), state0, method='DOP853', events=lowest, rtol=1e-13,
                    atol=1e-14)
    t = sol.t_events[0][0]
    s = sol.y_events[0][0]
    corner = s[0:3] + s[6:15].reshape(3, 3) @ corners[np.argmin(
        s[2] + corners @ s[6:15].reshape(3, 3)[2])]
    return t, corner


def test_a_tumbling_box_hits_the_plate_when_dop853_says():
    half = np.array([0.5, 0.2, 0.1])
    args = {'position': [0.2, -0.1, 1.5], 'velocity': [0.4, 0.0, 0.5],
            'rpy': [10.0, -25.0, 40.0], 'rates': [3.0, -5.0, 2.0],
            'inertia': (0.0333, 0.1733, 0.1933)}
    t_ref, corner = tumbling_reference(np.array(args['position']), np.array(args['velocity']),
                                       np.array(args['rpy']), np.array(args['rates']),
                                       args['inertia'], half, 0.1)
    sim = Simulator(parse_scenario(drop({'box': list(2 * half)}, dt=0.0005, **args)))
    sim.advance_to(3.0)
    event, = sim.events
    # RK4's own error at dt = 0.5 ms moves the corner by about 1e-11 m here
    assert abs(event['time'] - t_ref) < 1e-8, (event['time'], t_ref)
    np.testing.assert_allclose(event['point'], corner, rtol=0, atol=1e-6)
    assert 0.4 < t_ref < 1.0   # it tumbled a while first


def test_a_bar_spinning_in_place_hits_the_box_when_its_tip_comes_down():
    # its CG never moves: only the bound's turn term (skipping GJK while the distance last
    # found exceeds what the shape can have moved) lets the kernel see the tip come down
    scenario = drop({'box': [2.0, 0.1, 0.1]}, [0.3, 0.2, 0.6], rates=[0, 2.0, 0])
    scenario['gravity'] = [0, 0, 0]
    sim = Simulator(parse_scenario(scenario))
    assert not sim.advance_to(2.0) and sim.status == 'contact'
    event, = sim.events
    # turned by 2 t about y, the lowest corner (1, y, -0.05) is at
    # 0.6 - sin(2 t) - 0.05 cos(2 t): the top face (0.1) when sin(2 t + atan(0.05)) = 0.5 / |.|
    angle = math.asin(0.5 / math.hypot(1.0, 0.05)) - math.atan(0.05)
    assert abs(event['time'] - angle / 2.0) < TIME_TOLERANCE
    assert event['point'][2] == pytest.approx(0.1, abs=1e-9)


def test_the_spinning_bar_as_the_pair_s_second_body_hits_at_the_same_time():
    # the pair named the other way round: the bound now sees the fixed box's pose in the
    # turning bar's axes, so its turn term is the second body's
    scenario = drop({'box': [2.0, 0.1, 0.1]}, [0.3, 0.2, 0.6], rates=[0, 2.0, 0])
    scenario['gravity'] = [0, 0, 0]
    scenario['contacts'] = [{'bodies': ['floor', 'body'], 'on_contact': 'stop'}]
    sim = Simulator(parse_scenario(scenario))
    assert not sim.advance_to(2.0) and sim.status == 'contact'
    event, = sim.events
    angle = math.asin(0.5 / math.hypot(1.0, 0.05)) - math.atan(0.05)
    assert event['bodies'] == ['floor', 'body']
    assert abs(event['time'] - angle / 2.0) < TIME_TOLERANCE
    assert event['point'][2] == pytest.approx(0.1, abs=1e-9)


def test_a_turning_carrier_moving_on_hits_a_sphere_at_rest_when_brentq_says():
    # the kinematic bar both translates and turns: the bound must follow the carrier's
    # motion, not only a free body's; the reference is the box-point distance in the
    # bar's axes along its known motion, root by brentq
    speed, rate, radius = 0.5, 2.0, 0.1
    centre, half = np.array([0.8, 0.0, -0.5]), np.array([1.0, 0.05, 0.05])
    scenario = {'gravity': [0, 0, 0], 'dt': 0.001,
                'bodies': {'bar': {'motion': {'velocity': [speed, 0, 0],
                                              'angular_velocity_deg': [0, math.degrees(rate), 0]},
                                   'shape': {'box': (2 * half).tolist()}},
                           'ball': {'mass': 1.0, 'inertia': [0.1, 0.1, 0.1],
                                    'position': centre.tolist(), 'shape': {'sphere': radius}}},
                'contacts': [{'bodies': ['bar', 'ball'], 'on_contact': 'stop'}]}
    sim = Simulator(parse_scenario(scenario))
    assert not sim.advance_to(2.0) and sim.status == 'contact'
    event, = sim.events

    def gap(t):
        turned = Rotation.from_rotvec([0, rate * t, 0]).as_matrix()
        local = turned.T @ (centre - [speed * t, 0, 0])
        return np.linalg.norm(np.maximum(np.abs(local) - half, 0.0)) - radius

    times = np.linspace(0, 1.0, 1001)
    first = np.flatnonzero(np.array([gap(t) for t in times]) <= 0)[0]
    t_ref = brentq(gap, times[first - 1], times[first], xtol=1e-14)
    assert 0.2 < t_ref < 1.0
    assert abs(event['time'] - t_ref) < TIME_TOLERANCE, (event['time'], t_ref)


def test_continue_goes_through_and_records_the_contact_once():
    sim = Simulator(parse_scenario(drop({'sphere': 0.25}, [0.3, 0.2, 1.0],
                                        on_contact='continue')))
    assert sim.advance_to(1.0) and sim.status == 'running'
    event, = sim.events   # it fell through the floor and out below it: one contact
    assert abs(event['time'] - fall_time(0.65)) < TIME_TOLERANCE
    assert sim.position[1][2] < -0.35   # through and below


def test_run_exits_3_at_a_contact_with_a_complete_recording(tmp_path, capsys):
    scenario = tmp_path / 'drop.yaml'
    scenario.write_text(yaml.safe_dump(drop({'capsule': [0.2, 1.0]}, [0, 0, 1.0],
                                            rpy=[0, 30, 0])))
    out = tmp_path / 'drop.mcap'
    assert cli.main(['run', str(scenario), '-o', str(out)]) == 3
    printed = capsys.readouterr()
    assert 'contact body floor at t = ' in printed.out and 'stopped:' in printed.err
    with open(out, 'rb') as handle:
        events = [json.loads(m.data[8:].decode().rstrip('\0'))
                  for _, _, m in make_reader(handle).iter_messages(topics=['/cfem/events'])]
    contact, = [e for e in events if e['event'] == 'contact']
    # the capsule's lower end (0.5 - 0.2 m from its centre along x, pitched 30 deg) at 0.1 m
    lowest = 1.0 - 0.3 * math.sin(math.radians(30)) - 0.2
    assert abs(contact['time'] - fall_time(lowest - 0.1)) < TIME_TOLERANCE
    assert not any(e['event'] == 'error' for e in events)
    assert cli.main(['info', str(out)]) == 0
    assert f'contact body floor at t = {contact["time"]:.9f} s' in capsys.readouterr().out


@pytest.mark.parametrize('change, key', [
    ({'contacts': [{'bodies': ['body', 'body']}]}, 'contacts[0].bodies'),
    ({'contacts': [{'bodies': ['body', 'floor']}, {'bodies': ['floor', 'body']}]},
     'contacts[1].bodies'),
    ({'contacts': [{'bodies': ['body', 'floor'], 'on_contact': 'bounce'}]},
     'contacts[0].on_contact'),
    ({'contacts': [{'bodies': ['body', 'wing']}]}, 'contacts[0].bodies[1]'),
    ({'contacts': {'bodies': ['body', 'floor']}}, 'contacts'),
])
def test_bad_contacts_are_refused_with_the_key_path(change, key):
    doc = dict(drop({'sphere': 0.25}, [0, 0, 1.0]), **change)
    with pytest.raises(ScenarioError) as err:
        parse_scenario(doc)
    assert err.value.key == key


def test_a_watched_body_needs_a_shape():
    doc = drop({'sphere': 0.25}, [0, 0, 1.0])
    del doc['bodies']['body']['shape']
    with pytest.raises(ScenarioError, match='bodies.body.shape: missing'):
        parse_scenario(doc)


def write_stl(path, triangles):
    """Write a binary STL of triangles (k, 3, 3)."""
    with open(path, 'wb') as handle:
        handle.write(b'\0' * 80 + struct.pack('<I', len(triangles)))
        for tri in triangles:
            handle.write(struct.pack('<12fH', 0, 0, 0, *np.ravel(tri), 0))


def test_a_mesh_collides_by_its_convex_hull(tmp_path):
    # an octahedron with an inner point (a dent the hull ignores), scaled 2x in z
    top, bottom = [0, 0, 0.3], [0, 0, -0.3]
    ring = [[0.3, 0, 0], [0, 0.3, 0], [-0.3, 0, 0], [0, -0.3, 0]]
    triangles = [[ring[k], ring[(k + 1) % 4], pole] for k in range(4) for pole in (top, bottom)]
    triangles.append([[0, 0, 0], [0.01, 0, 0], [0, 0.01, 0]])
    write_stl(tmp_path / 'octahedron.stl', np.array(triangles, dtype=float))
    doc = drop({'mesh': 'octahedron.stl', 'scale': [1, 1, 2]}, [0, 0, 1.5])
    scenario = tmp_path / 'drop.yaml'
    scenario.write_text(yaml.safe_dump(doc))
    from cfem_ros.core.scenario.parse import load_scenario
    model = load_scenario(str(scenario))
    # the inner points are not on the hull
    assert len(model.bodies[model.body_index('body')].shape.hull) == 6
    sim = Simulator(model)
    sim.advance_to(2.0)
    event, = sim.events
    # STL keeps float32: the lower tip is at 2 float32(0.3) below the CG
    assert abs(event['time'] - fall_time(1.5 - 2 * float(np.float32(0.3)) - 0.1)) \
        < TIME_TOLERANCE
