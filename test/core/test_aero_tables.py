# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""Mach and proximity tables: parsing, the compiled interpolation, ISA and the aero load."""

import math

from cfem_ros.core._kernel import testing
from cfem_ros.core.engine import aeropack

from cfem_ros.core.errors import ScenarioError
from cfem_ros.core.native import atmosphere, kernel
from cfem_ros.core.scenario import aeroparse
from cfem_ros.core.scenario.parse import parse_scenario
import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.interpolate import RegularGridInterpolator
from scipy.spatial.transform import Rotation

ext = kernel
rng = np.random.default_rng(8)

MASS, INERTIA = 907.1848, [27.1164, 488.0944, 488.0944]


def scenario(aero_spec, **extra):
    # the coefficients a case does not give are meant to be zero (SPEC 10: said, not left out)
    zero = [c for c in aeroparse.AERO_COEFFICIENTS if c not in aero_spec]
    aero_spec = {'zero': zero, **aero_spec} if zero else aero_spec
    doc = {'gravity': [0, 0, 9.80665],
           'bodies': {'aircraft': {'motion': {'velocity': [250.0, 0, 0]}},
                      'store': {'mass': MASS, 'inertia': INERTIA, 'position': [0.5, 0, 1.2]}},
           'aero': {'store': aero_spec}}
    doc.update(extra)
    return doc


BASE = {'area': 0.2027, 'length': 0.508, 'altitude': 7925.0, 'alpha_deg': [-20, 0, 20],
        'beta_deg': [-10, 10], 'mach': [0.6, 0.9, 1.2]}


def write_grid(path, axes, values, increments):
    """Write a long-format table: every grid point as a row, in a shuffled order."""
    mesh = np.meshgrid(*values, indexing='ij')
    rows = np.column_stack([m.ravel() for m in mesh]
                           + [increments[..., k].ravel() for k in range(increments.shape[-1])])
    rows = rows[rng.permutation(len(rows))]
    names = list(axes) + list(aeroparse.INCREMENTS)[:increments.shape[-1]]
    with open(path, 'w') as handle:
        handle.write('# synthetic test field\n' + ','.join(names) + '\n')
        for row in rows:
            handle.write(','.join(repr(float(v)) for v in row) + '\n')
    return rows


# ------------------------------------------------------------------ ISA

def test_isa_against_the_icao_table():
    # ICAO Doc 7488: density kg/m^3 and temperature K (the speed of sound is 340.294 m/s at
    # sea level and goes as the square root of the temperature)
    for altitude, density, temperature in ((0, 1.2250, 288.15), (5000, 0.73612, 255.65),
                                           (11000, 0.36392, 216.65), (20000, 0.088035, 216.65),
                                           (25000, 0.039466, 221.65), (-500, 1.2849, 291.40)):
        rho, a = atmosphere.isa(altitude)
        sound = 340.294 * math.sqrt(temperature / 288.15)
        assert abs(rho / density - 1) < 2e-4 and abs(a / sound - 1) < 2e-6, altitude


# ------------------------------------------------------------------ interpolation

@pytest.mark.parametrize('sizes', [(7,), (5, 3, 4), (3, 2, 4, 3, 2)])
def test_multilinear_against_scipy_regular_grid_interpolator(sizes):
    grids = [np.sort(rng.uniform(-3, 3, n)) for n in sizes]
    values = rng.standard_normal(tuple(sizes) + (6,))
    points = np.column_stack([rng.uniform(g[0] - 1, g[-1] + 1, 2000) for g in grids])
    ours = testing.multilinear(grids, values, points)
    # held outside the grid: scipy's interpolation at the point brought back to the grid
    inside = np.column_stack([np.clip(points[:, d], g[0], g[-1]) for d, g in enumerate(grids)])
    theirs = RegularGridInterpolator(grids, values)(inside)
    np.testing.assert_allclose(ours, theirs, rtol=0, atol=1e-13)
    # at the nodes, the node's values exactly
    nodes = np.column_stack([g[rng.integers(0, len(g), 50)] for g in grids])
    np.testing.assert_allclose(testing.multilinear(grids, values, nodes),
                               RegularGridInterpolator(grids, values)(nodes), atol=1e-15)


# ------------------------------------------------------------------ parsing

def test_mach_tables_nest_alpha_then_beta_then_mach():
    cm = rng.standard_normal((3, 2, 3))
    spec = dict(BASE, Cm=cm.tolist(), CX=[-0.3, -0.2, -0.3], CZ=[[1, 2], [3, 4], [5, 6]])
    a = parse_scenario(scenario(spec)).aero[0]
    assert a.coefficients.shape == (3, 2, 3, 6)
    np.testing.assert_array_equal(a.coefficients[..., 4], cm)
    np.testing.assert_array_equal(a.coefficients[:, 1, 2, 0], [-0.3, -0.2, -0.3])
    np.testing.assert_array_equal(a.coefficients[2, 1, :, 2], [6, 6, 6])
    np.testing.assert_array_equal(a.mach, [0.6, 0.9, 1.2])
    # no beta: the levels are alpha, then Mach
    spec = {k: v for k, v in BASE.items() if k != 'beta_deg'}
    a = parse_scenario(scenario(dict(spec, CX=[[1, 2, 3], [4, 5, 6], [7, 8, 9]]))).aero[0]
    np.testing.assert_array_equal(a.coefficients[:, 0, :, 0], [[1, 2, 3], [4, 5, 6], [7, 8, 9]])


@pytest.mark.parametrize('change, key', [
    ({'CX': [[[1, 2]] * 2] * 3}, 'aero.store.CX'),
    ({'mach': [0.9, 0.6]}, 'aero.store.mach'),
    ({'mach': [-0.1, 0.6]}, 'aero.store.mach'),
    ({'wind': [1, 0, 0], 'freestream': [2, 0, 0]}, 'aero.store.wind'),
    ({'altitude': None, 'density': 1.0}, 'aero.store.density'),
    ({'proximity': {'carrier': 'store', 'table': 'x.csv', 'outside': 'hold'}},
     'aero.store.proximity.carrier'),
    ({'proximity': {'carrier': 'aircraft', 'table': 'x.csv'}},
     'aero.store.proximity.outside'),
    ({'proximity': {'carrier': 'aircraft', 'table': 'x.csv', 'outside': {'fade': 0}}},
     'aero.store.proximity.outside.fade'),
    ({'proximity': {'carrier': 'aircraft', 'table': 'missing.csv', 'outside': 'hold'}},
     'aero.store.proximity.table'),
    ({'scale': {'dCm': 2.0}}, 'aero.store.scale.dCm'),
])
def test_bad_mach_and_proximity_input_is_refused_with_the_key_path(change, key):
    spec = {k: v for k, v in dict(BASE, **change).items() if v is not None}
    with pytest.raises(ScenarioError) as err:
        parse_scenario(scenario(spec))
    assert err.value.key == key


def test_proximity_table_is_read_in_any_row_order_from_csv_and_parquet(tmp_path):
    axes = ('dx', 'dz', 'dtheta_deg', 'mach')
    values = [np.array([-1.0, 0.0, 2.0]), np.array([0.0, 0.5, 1.0, 3.0]),
              np.array([-10.0, 10.0]), np.array([0.6, 1.2])]
    increments = rng.standard_normal((3, 4, 2, 2, 6))
    rows = write_grid(tmp_path / 'field.csv', axes, values, increments)
    spec = dict(BASE, proximity={'carrier': 'aircraft', 'table': 'field.csv',
                                 'outside': {'fade': 0.5}}, scale={'dCm': 2.0})
    source = tmp_path / 'scenario.yaml'
    source.write_text('')
    p = parse_scenario(scenario(spec), source=str(source)).aero[0].proximity
    assert p.axes == axes and p.fade == 0.5 and p.carrier == 0
    for g, v in zip(p.grids, values):
        np.testing.assert_array_equal(g, v)
    expected = increments * [1, 1, 1, 1, 2, 1]
    np.testing.assert_array_equal(p.increments, expected)
    pa = pytest.importorskip('pyarrow')
    import pyarrow.parquet as pq
    names = list(axes) + list(aeroparse.INCREMENTS)
    pq.write_table(pa.table({n: rows[:, k] for k, n in enumerate(names)}),
                   tmp_path / 'field.parquet')
    spec['proximity']['table'] = 'field.parquet'
    q = parse_scenario(scenario(spec), source=str(source)).aero[0].proximity
    np.testing.assert_array_equal(q.increments, expected)


def test_a_missing_grid_point_is_named(tmp_path):
    values = [np.array([0.0, 1.0, 2.0]), np.array([-5.0, 5.0])]
    increments = np.zeros((3, 2, 1))
    rows = write_grid(tmp_path / 'field.csv', ('dz', 'dtheta_deg'), values, increments)
    keep = (~((rows[:, 0] == 1.0) & (rows[:, 1] == 5.0))
            & ~((rows[:, 0] == 2.0) & (rows[:, 1] == -5.0)))
    with open(tmp_path / 'holes.csv', 'w') as handle:
        handle.write('dz,dtheta_deg,dCX\n')
        for row in rows[keep]:
            handle.write(','.join(str(v) for v in row) + '\n')
    spec = dict(BASE, proximity={'carrier': 'aircraft', 'table': str(tmp_path / 'holes.csv'),
                                 'outside': 'hold'})
    with pytest.raises(ScenarioError, match=r'misses dz=1, dtheta_deg=5 \(the first missing'):
        parse_scenario(scenario(spec))
    with open(tmp_path / 'twice.csv', 'w') as handle:
        handle.write('dz,dtheta_deg,dCX\n')
        for row in np.vstack([rows, rows[:1]]):
            handle.write(','.join(str(v) for v in row) + '\n')
    spec['proximity']['table'] = str(tmp_path / 'twice.csv')
    with pytest.raises(ScenarioError, match='repeats the grid point'):
        parse_scenario(scenario(spec))
    with open(tmp_path / 'column.csv', 'w') as handle:
        handle.write('dz,dalpha,dCX\n0,0,0\n')
    spec['proximity']['table'] = str(tmp_path / 'column.csv')
    with pytest.raises(ScenarioError, match="has a column 'dalpha'"):
        parse_scenario(scenario(spec))


# ------------------------------------------------------------------ the load

def reference_wrench(a, model, position, velocity, quat, rates, carrier_position, carrier_quat):
    """Return the aerodynamic load as the user guide writes it, with scipy (world axes)."""
    rot = Rotation.from_quat(quat).as_matrix()
    up = -np.asarray(model.gravity) / np.linalg.norm(model.gravity)
    altitude = a.altitude + position @ up
    density, sound = atmosphere.isa(altitude)
    u, v, w = rot.T @ (velocity - a.freestream)
    speed = math.sqrt(u * u + v * v + w * w)
    alpha, beta, mach = math.atan2(w, u), math.asin(v / speed), speed / sound

    def held(grids, x):
        return [np.clip(x[d], g[0], g[-1]) for d, g in enumerate(grids)]

    grids = (a.alpha, a.beta, a.mach)
    c = RegularGridInterpolator(grids, a.coefficients)([held(grids, (alpha, beta, mach))])[0]
    p = a.proximity
    carrier = Rotation.from_quat(carrier_quat)
    start = aeropack.start_in_carrier(model, a.body, p.carrier)
    dx, dy, dz = carrier.as_matrix().T @ (position - carrier_position) - start
    # scipy's intrinsic 'ZYX' Euler angles are yaw, pitch, roll
    dpsi, dtheta, dphi = (carrier.inv() * Rotation.from_quat(quat)).as_euler('ZYX', degrees=True)
    at = {'dx': dx, 'dy': dy, 'dz': dz, 'dphi_deg': dphi, 'dtheta_deg': dtheta,
          'dpsi_deg': dpsi, 'mach': mach}
    x = [at[name] for name in p.axes]
    d = RegularGridInterpolator(p.grids, p.increments)([held(p.grids, x)])[0]
    gap = math.sqrt(sum(max(g[0] - xi, 0.0, xi - g[-1]) ** 2 for name, g, xi in
                        zip(p.axes, p.grids, x) if name in aeroparse.POSITION_AXES))
    c = c + d * max(0.0, 1.0 - gap / p.fade)
    qs = 0.5 * density * speed ** 2 * a.area
    force = qs * c[:3]
    moment = qs * a.length * (c[3:] + a.damping * rates * a.length / (2 * speed))
    return np.concatenate([rot @ force, rot @ moment])


def test_aero_wrench_with_mach_and_proximity_against_the_documented_model(tmp_path):
    axes = ('dx', 'dz', 'dphi_deg', 'dtheta_deg', 'mach')
    values = [np.array([-2.0, 0.0, 1.5]), np.array([0.0, 0.4, 1.0, 2.5]),
              np.array([-20.0, 20.0]), np.array([-30.0, 0.0, 30.0]), np.array([0.7, 0.95])]
    write_grid(tmp_path / 'field.csv', axes, values,
               0.3 * rng.standard_normal((3, 4, 2, 3, 2, 6)))
    spec = dict(BASE, wind=[-20.0, 5.0, 0.0], Clp=-3.0, Cmq=-40.0, Cnr=-35.0,
                proximity={'carrier': 'aircraft', 'table': str(tmp_path / 'field.csv'),
                           'outside': {'fade': 0.8}})
    for c in aeroparse.AERO_COEFFICIENTS:
        spec[c] = (0.2 * rng.standard_normal((3, 2, 3))).tolist()
    model = parse_scenario(scenario(spec))
    a = model.aero[0]
    packed = aeropack.pack(a, model)
    n = 500
    position = rng.uniform([-3, -1, -1], [3, 1, 4], (n, 3)) + [0.5, 0, 1.2]
    velocity = np.array([250.0, 0, 0]) + rng.uniform(-60, 60, (n, 3))
    quat = Rotation.from_euler('ZYX', rng.uniform(-35, 35, (n, 3)), degrees=True).as_quat()
    rates = rng.uniform(-2, 2, (n, 3))
    carrier_position = rng.uniform(-1, 1, (n, 3))
    carrier_quat = Rotation.from_euler('ZYX', rng.uniform(-5, 5, (n, 3)),
                                       degrees=True).as_quat()
    rot = Rotation.from_quat(quat).as_matrix().reshape(n, 9)
    crot = Rotation.from_quat(carrier_quat).as_matrix().reshape(n, 9)
    ours, air = ext.aero_wrench(packed, position, velocity, rot, rates, carrier_position, crot)
    faded = 0
    for k in range(n):
        expected = reference_wrench(a, model, position[k], velocity[k], quat[k], rates[k],
                                    carrier_position[k], carrier_quat[k])
        scale = np.abs(expected).max()
        np.testing.assert_allclose(ours[k], expected, rtol=0, atol=1e-11 * scale)
        faded += 0 < np.abs(air[k, 12:]).max() and air[k, 0] != 0
    assert 1.0 > air[:, 2].min() and air[:, 2].max() > 0.6   # Mach through the table
    assert faded > n // 4


def test_no_airspeed_no_load():
    model = parse_scenario(scenario(dict(BASE, CX=-0.3, Cm=0.1)))
    packed = aeropack.pack(model.aero[0], model)
    # gravity along +z: the body 1.2 m below the origin flies 1.2 m lower
    ours, air = ext.aero_wrench(packed, np.array([[0.5, 0, 1.2]]), np.zeros((1, 3)),
                                np.eye(3).reshape(1, 9), np.ones((1, 3)), np.zeros((1, 3)),
                                np.eye(3).reshape(1, 9))
    assert not ours.any()
    assert air[0, 4] == pytest.approx(atmosphere.isa(7925.0 - 1.2)[0], rel=1e-14)


# ------------------------------------------------------------------ a whole run

def test_a_store_falling_through_a_proximity_field_against_dop853(tmp_path):
    # a store dropped from a carrier flying at 250 m/s through a synthetic field: Mach
    # tables, increments over dx, dz, dtheta and Mach fading outside the grid, a wind,
    # the ISA density and speed of sound at the store's own altitude
    axes = ('dx', 'dz', 'dtheta_deg', 'mach')
    values = [np.array([-1.0, 0.0, 1.0]), np.array([-0.2, 0.3, 0.8, 1.5]),
              np.array([-20.0, 0.0, 20.0]), np.array([0.7, 0.9])]
    field = 0.4 * rng.standard_normal((3, 4, 3, 2, 6))
    field[..., 4] -= 0.5   # a nose-down pitching increment near the carrier
    write_grid(tmp_path / 'field.csv', axes, values, field)
    spec = dict(BASE, wind=[5.0, -3.0, 1.0], Clp=-3.0, Cmq=-40.0, Cnr=-35.0,
                proximity={'carrier': 'aircraft', 'table': str(tmp_path / 'field.csv'),
                           'outside': {'fade': 0.6}})
    for c, scale in zip(aeroparse.AERO_COEFFICIENTS, (0.05, 0.3, 0.3, 0.02, 0.2, 0.2)):
        spec[c] = (scale * rng.standard_normal((3, 2, 3))).tolist()
    doc = scenario(spec, dt=0.00025)
    doc['bodies']['store'].update(velocity=[250.0, 0.0, 0.0], angular_velocity=[0.3, 0.5, -0.2])
    model = parse_scenario(doc)
    a = model.aero[0]
    from cfem_ros.core.engine.simulator import Simulator
    sim = Simulator(model)
    t_end = 0.6
    sim.advance_to(t_end)
    store = model.body_index('store')

    inertia = np.diag(INERTIA)
    inverse = np.linalg.inv(inertia)
    gravity = np.asarray(model.gravity)
    identity = np.array([0.0, 0.0, 0.0, 1.0])

    def rhs(t, s):
        rot = s[6:15].reshape(3, 3)
        quat = Rotation.from_matrix(rot).as_quat()
        w = s[15:18]
        wrench = reference_wrench(a, model, s[0:3], s[3:6], quat, w,
                                  np.array([250.0 * t, 0, 0]), identity)
        moment = rot.T @ wrench[3:]
        skew = np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])
        return np.concatenate([s[3:6], gravity + wrench[:3] / MASS, (rot @ skew).ravel(),
                               inverse @ (moment - np.cross(w, inertia @ w))])

    state0 = np.concatenate([[0.5, 0, 1.2], [250.0, 0, 0], np.eye(3).ravel(), [0.3, 0.5, -0.2]])
    s = solve_ivp(rhs, (0, t_end), state0, method='DOP853', rtol=1e-12, atol=1e-12).y[:, -1]
    np.testing.assert_allclose(sim.position[store], s[0:3], rtol=0, atol=1e-6)
    np.testing.assert_allclose(sim.velocity[store], s[3:6], rtol=0, atol=1e-6)
    np.testing.assert_allclose(Rotation.from_quat(sim.orientation[store]).as_matrix(),
                               s[6:15].reshape(3, 3), rtol=0, atol=1e-6)
    np.testing.assert_allclose(sim.rates[store], s[15:18], rtol=0, atol=1e-6)
    # it went through the grid and beyond it, where the increments fade
    assert s[2] - 1.2 > 1.5
