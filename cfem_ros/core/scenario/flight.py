# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The scenario's ``flight`` section (SPEC section 14): the release condition as stated.

Mach (or true airspeed), altitude, temperature offset, flight path angle,
normal load factor, roll rate and angle of attack of the carrier become:

- the carrier's steady manoeuvre, flown exactly: its body axes aligned with
  the flight path at t = 0 (pitched by ``flight_path_deg + alpha_deg``, no
  roll, heading along world +x), its velocity constant in its own axes and
  turning with it, its body rates constant: pitch rate
  ``q = g (n - cos(gamma)) / V`` and the roll rate about the flight path.
  A store on it carries ``n`` g normal to the flight path at t = 0
  (``native/motion.py``, kind ``KIND_ARC``, in closed form in ``cpp/motion.cpp``);
- gravity z-down (``[0, 0, g]``; a given gravity must be so);
- the atmosphere of every body with aero tables (ISA with the offset, the
  carrier at ``altitude``) and still air: the carrier flies through it.

This module only reads and checks; the parser (``parse.py``) calls it.
"""

from __future__ import annotations

from dataclasses import dataclass
import logging
import math

from cfem_ros.core import rotations
from cfem_ros.core.fileio.messages import show
from cfem_ros.core.model import shapes
from cfem_ros.core.model.bodies import Body, Motion
from cfem_ros.core.model.model import STANDARD_GRAVITY
from cfem_ros.core.native import kernel
from cfem_ros.core.native.atmosphere import ALTITUDE_RANGE, isa, OFFSET_RANGE
from cfem_ros.core.scenario.bodies import shape_dir
from cfem_ros.core.scenario.checker import Checker, key_path
import numpy as np

LOG = logging.getLogger('cfem_ros')

FLIGHT_KEYS = ('carrier', 'mach', 'airspeed', 'altitude', 'temperature_offset',
               'flight_path_deg', 'load_factor', 'roll_rate_deg_s', 'alpha_deg')
#: Keys of the carrier's body that flight gives instead (its motion, attitude and velocities).
CARRIER_GIVEN = ('motion', 'orientation_rpy_deg', 'orientation_xyzw', 'velocity',
                 'angular_velocity_deg', 'angular_velocity', 'cg_offset', 'fixed')
#: Keys of an aero body that flight gives instead (its atmosphere and the air's velocity).
AERO_GIVEN = ('freestream', 'wind', 'altitude', 'atmosphere', 'density')
#: Carrier keys a kinematic body has no use for (ignored, with a warning, as ``motion`` does).
IGNORED = ('mass', 'inertia')
#: Highest true airspeed, m/s, and Mach number, a flight may give.
MAX_AIRSPEED = 3000.0
MAX_MACH = 10.0
#: Largest angle of attack, deg (the body axes must point forward).
MAX_ALPHA = 60.0
#: Largest normal load factor magnitude, g.
MAX_LOAD_FACTOR = 50.0


@dataclass(frozen=True)
class Flight:
    """
    A checked ``flight`` section.

    Attributes
    ----------
    carrier : str
        The body that flies it.
    airspeed : float
        True airspeed, m/s.
    mach : float
        Mach number at the carrier's altitude.
    altitude : float
        The carrier's geopotential altitude at t = 0, m.
    temperature_offset : float
        K added to the ISA temperature.
    flight_path : float
        Flight path angle gamma, rad (climb +).
    load_factor : float
        Normal load factor n.
    roll_rate : float
        Roll rate about the flight path, rad/s.
    alpha : float
        Angle of attack of the carrier's body axes, rad.
    gravity : float
        The magnitude of gravity, m/s^2 (z-down).

    """

    carrier: str
    airspeed: float
    mach: float
    altitude: float
    temperature_offset: float
    flight_path: float
    load_factor: float
    roll_rate: float
    alpha: float
    gravity: float

    @property
    def pitch_rate(self) -> float:
        """Return q = g (n - cos gamma) / V, rad/s."""
        return self.gravity * (self.load_factor - math.cos(self.flight_path)) / self.airspeed

    def velocity_body(self) -> np.ndarray:
        """Return the carrier's CG velocity in its own axes, m/s."""
        return self.airspeed * np.array([math.cos(self.alpha), 0.0, math.sin(self.alpha)])

    def rates_body(self) -> np.ndarray:
        """Return the carrier's body rates, rad/s: pitch rate, and the roll about the path."""
        along = np.array([math.cos(self.alpha), 0.0, math.sin(self.alpha)])
        return self.roll_rate * along + np.array([0.0, self.pitch_rate, 0.0])

    def attitude(self) -> np.ndarray:
        """Return the carrier's attitude at t = 0, quaternion x y z w (pitch gamma + alpha)."""
        pitch = math.degrees(self.flight_path + self.alpha)
        return rotations.from_rpy_deg(np.array([0.0, pitch, 0.0]))


def parse_flight(check: Checker, top: dict) -> Flight:
    """Check ``flight`` (and the gravity and carrier it needs) in the scenario mapping top."""
    doc = check.mapping(top['flight'], 'flight', FLIGHT_KEYS, required=('carrier', 'altitude'))
    bodies = top.get('bodies')
    carrier = doc['carrier']
    if not isinstance(carrier, str) or not isinstance(bodies, dict) or carrier not in bodies:
        names = ', '.join(str(n) for n in list(bodies)[:8]) if isinstance(bodies, dict) else ''
        check.fail('flight.carrier', f'is {show(carrier)}, not a body',
                   f'the name of the body that flies the condition (one of {names})')
    spec = bodies[carrier]
    if not isinstance(spec, dict):
        spec = {}
    for given in CARRIER_GIVEN:
        if given in spec:
            check.fail(f'{key_path("bodies", carrier)}.{given}', 'given together with flight',
                       f'none: flight flies {carrier} (its motion, attitude and velocities '
                       'follow from the flight condition)')
    gravity = _gravity(check, top)
    altitude = check.number(doc['altitude'], 'flight.altitude')
    if not ALTITUDE_RANGE[0] <= altitude <= ALTITUDE_RANGE[1]:
        check.fail('flight.altitude', f'is {altitude:g} m',
                   f'a geopotential altitude from {ALTITUDE_RANGE[0]:g} to '
                   f'{ALTITUDE_RANGE[1]:g} m (ISA)')
    offset = check.number(doc.get('temperature_offset', 0.0), 'flight.temperature_offset')
    if not OFFSET_RANGE[0] <= offset <= OFFSET_RANGE[1]:
        check.fail('flight.temperature_offset', f'is {offset:g} K',
                   f'K added to the ISA temperature, from {OFFSET_RANGE[0]:g} to '
                   f'{OFFSET_RANGE[1]:g}')
    _, sound = isa(altitude, offset)
    given = [k for k in ('mach', 'airspeed') if k in doc]
    if len(given) != 1:
        check.fail(f'flight.{given[1] if given else "mach"}',
                   'given together with mach' if given else 'missing',
                   'one of mach or airspeed (true, m/s)')
    if 'mach' in doc:
        mach = check.number(doc['mach'], 'flight.mach', positive=True, limit=MAX_MACH)
        airspeed = mach * sound
    else:
        airspeed = check.number(doc['airspeed'], 'flight.airspeed', positive=True,
                                limit=MAX_AIRSPEED)
        mach = airspeed / sound
    path = check.number(doc.get('flight_path_deg', 0.0), 'flight.flight_path_deg')
    if not -90.0 <= path <= 90.0:
        check.fail('flight.flight_path_deg', f'is {path:g}', 'an angle from -90 to 90 deg '
                   '(climb +, dive -)')
    alpha = check.number(doc.get('alpha_deg', 0.0), 'flight.alpha_deg', limit=MAX_ALPHA)
    load = check.number(doc.get('load_factor', 1.0), 'flight.load_factor',
                        limit=MAX_LOAD_FACTOR)
    roll = check.number(doc.get('roll_rate_deg_s', 0.0), 'flight.roll_rate_deg_s',
                        limit=3600.0)
    return Flight(carrier=carrier, airspeed=airspeed, mach=mach, altitude=altitude,
                  temperature_offset=offset, flight_path=math.radians(path),
                  load_factor=load, roll_rate=math.radians(roll), alpha=math.radians(alpha),
                  gravity=gravity)


def _gravity(check: Checker, top: dict) -> float:
    """Return the magnitude of gravity, which must be z-down with flight (default standard)."""
    if 'gravity' not in top:
        return STANDARD_GRAVITY
    vector = check.vector(top['gravity'], 'gravity')
    if vector[0] != 0.0 or vector[1] != 0.0 or not vector[2] > 0.0:
        check.fail('gravity', f'is {show(top["gravity"])} with flight',
                   '[0, 0, g] with g > 0 (z down: the flight path, load factor and aero '
                   'conventions are z-down), or no gravity (standard, z-down)')
    return float(vector[2])


def gravity_vector(flight: Flight) -> np.ndarray:
    """Return the world gravity with flight: z-down, m/s^2."""
    return np.array([0.0, 0.0, flight.gravity])


def carrier_body(check: Checker, flight: Flight, spec) -> Body:
    """Return the carrier as a kinematic body flying the steady manoeuvre."""
    name = flight.carrier
    key = key_path('bodies', name)
    check.name(name, key)
    spec = check.mapping(spec if spec is not None else {}, key,
                         ('position', 'shape', 'reference') + IGNORED + CARRIER_GIVEN)
    ignored = [k for k in IGNORED if k in spec]
    if ignored:
        LOG.warning('%s: %s: %s ignored: a kinematic body follows its motion (flight)',
                    check.source, key, ' and '.join(ignored))
    position = check.vector(spec.get('position', [0, 0, 0]), f'{key}.position')
    shape = None
    if 'shape' in spec:
        shape = shapes.parse_shape(spec['shape'], f'{key}.shape', check.fail, check.number,
                                   check.vector, shape_dir(check, spec['shape']))
    quat = flight.attitude()
    velocity_body, rates = flight.velocity_body(), flight.rates_body()
    velocity = rotations.matrices(quat[None])[0] @ velocity_body
    return Body(name=name, fixed=False, mass=0.0, inertia=np.zeros((3, 3)), position=position,
                orientation_xyzw=quat, velocity_world=velocity, rates_body=rates, shape=shape,
                motion=Motion(velocity=velocity, rates=rates, velocity_body=velocity_body))


def flown_aero(check: Checker, flight: Flight, doc, carrier: Body):
    """
    Return the ``aero`` section with every body's atmosphere from the flight, in still air.

    A body's given ``freestream``, ``wind``, ``altitude``, ``atmosphere`` or
    ``density`` is refused: the flight sets them. The atmosphere's altitude
    (at the world origin, SPEC section 10) puts the carrier at ``altitude``.
    """
    if not isinstance(doc, dict):
        return doc   # the aero parser names what is wrong
    origin = flight.altitude + float(carrier.position[2])   # z down: the origin is above
    if not ALTITUDE_RANGE[0] <= origin <= ALTITUDE_RANGE[1]:
        check.fail('flight.altitude', f'is {flight.altitude:g} m with {flight.carrier} at '
                   f'z = {carrier.position[2]:g} m, so the world origin is at {origin:g} m',
                   f'the world origin from {ALTITUDE_RANGE[0]:g} to {ALTITUDE_RANGE[1]:g} m')
    out = {}
    for name, spec in doc.items():
        if isinstance(spec, dict):
            for given in AERO_GIVEN:
                if given in spec:
                    check.fail(f'aero.{name}.{given}', 'given together with flight',
                               'none: flight.altitude and flight.temperature_offset set the '
                               'atmosphere of every body, and the air is still (the carrier '
                               'flies through it)')
            spec = {**spec, 'atmosphere': {'altitude': origin,
                                           'temperature_offset': flight.temperature_offset}}
        out[name] = spec
    return out


def describe(flight: Flight) -> str:
    """Return the flight condition on one line (``cfem-sim check``)."""
    density, _ = isa(flight.altitude, flight.temperature_offset)
    return (f'flight: {flight.carrier} at Mach {flight.mach:.4g} ({flight.airspeed:.5g} m/s '
            f'true), {flight.altitude:g} m, ISA {flight.temperature_offset:+g} K, flight path '
            f'{math.degrees(flight.flight_path):g} deg, n = {flight.load_factor:g}: pitch rate '
            f'{math.degrees(flight.pitch_rate):.5g} deg/s, dynamic pressure '
            f'{float(kernel.dynamic_pressure(density, flight.airspeed)):.6g} Pa')
