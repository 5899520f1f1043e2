# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Sway braces against the step: a pad RK4 cannot follow with dt is refused.

A stiff pad makes the motion of its body a fast oscillation (or, heavily
damped, a fast decay); explicit RK4 with step dt follows it only while
every eigenvalue lambda of the braced bodies' linearised motion has
``|R(lambda dt)| <= 1``, R(z) = 1 + z + z^2/2 + z^3/6 + z^4/24 (RK4's
amplification). Beyond it the run's pads gain energy at every step and
let go and touch again without end. The bodies are taken free, at t = 0,
all pads touching, the carriers that do not move held: a joint only takes
degrees of freedom away, which lowers the fastest eigenvalue, so this is
the motion after the release, the stiffest the pads meet.
"""

from __future__ import annotations

import math

from cfem_ros.core import rotations
from cfem_ros.core.scenario.checker import MIN_DT
import numpy as np

#: The stability bound is taken with this margin (RK4's region is left at |R| = 1).
MARGIN = 0.9


def amplification(z: np.ndarray) -> np.ndarray:
    """Return |R(z)| of RK4 at the complex numbers z = lambda dt (inf or NaN: beyond it)."""
    # a pad of 1e300 N/m gives z of 1e149: z^4 overflows, which is unstable all the same
    # (inf, or NaN, is not <= 1), without numpy's warning before the refusal
    with np.errstate(over='ignore', invalid='ignore'):
        return np.abs(1.0 + z * (1.0 + z * (0.5 + z * (1.0 / 6.0 + z / 24.0))))


def eigenvalues(braces, bodies, springs: bool = True, dashpots: bool = True) -> np.ndarray:
    """
    Return the eigenvalues of the braced bodies' linearised motion at t = 0, 1/s.

    ``springs`` and ``dashpots`` keep the pads' stiffness and damping (both
    by default; one alone tells which of the two a step cannot follow).
    """
    moving = sorted({i for b in braces for i in (b.body, b.carrier) if bodies[i].dynamic})
    slot = {i: k for k, i in enumerate(moving)}
    size = 6 * len(moving)
    mass = np.zeros((size, size))
    for i, k in slot.items():
        turn = rotations.matrices(np.asarray(bodies[i].orientation_xyzw, dtype=float)[None])[0]
        mass[6 * k:6 * k + 3, 6 * k:6 * k + 3] = bodies[i].mass * np.eye(3)
        mass[6 * k + 3:6 * k + 6, 6 * k + 3:6 * k + 6] = turn @ bodies[i].inertia @ turn.T
    spring, dashpot = np.zeros((size, size)), np.zeros((size, size))
    for brace in braces:
        body = bodies[brace.body]
        turn = rotations.matrices(np.asarray(body.orientation_xyzw, dtype=float)[None])[0]
        axis, arm = turn @ brace.direction, turn @ brace.point
        row = np.zeros(size)
        k = slot[brace.body]
        row[6 * k:6 * k + 3], row[6 * k + 3:6 * k + 6] = axis, np.cross(arm, axis)
        if brace.carrier in slot:   # the carrier takes the opposite push at the same point
            c = slot[brace.carrier]
            lever = body.position + arm - bodies[brace.carrier].position
            row[6 * c:6 * c + 3], row[6 * c + 3:6 * c + 6] = -axis, -np.cross(lever, axis)
        spring += brace.stiffness * springs * np.outer(row, row)
        dashpot += brace.damping * dashpots * np.outer(row, row)
    inverse = np.linalg.inv(mass)
    system = np.block([[np.zeros((size, size)), np.eye(size)],
                       [-inverse @ spring, -inverse @ dashpot]])
    with np.errstate(all='ignore'):
        return np.linalg.eigvals(system)


def stable_step(lams: np.ndarray, dt: float) -> float:
    """Return the longest step <= dt (s) with every |R(lambda h)| <= 1, found by bisection."""
    if np.all(amplification(lams * dt) <= 1.0 + 1e-12):
        return dt
    low, high = 0.0, dt
    for _ in range(60):
        mid = 0.5 * (low + high)
        if np.all(amplification(lams * mid) <= 1.0 + 1e-12):
            low = mid
        else:
            high = mid
    return low


def check_step(check, braces, bodies, dt: float):
    """Refuse braces whose linearised motion RK4 cannot follow with dt, naming a dt that would."""
    if not braces:
        return
    lams = _moving(eigenvalues(braces, bodies))
    if lams is None:
        return   # the inertia checks have refused what could make them so
    h = stable_step(lams, dt)
    if h >= dt:
        return
    # the key to name: the pads' stiffness (a fast oscillation) or their damping (a fast
    # decay), whichever alone asks for the shorter step; then the pad with most of it
    alone = {key: _moving(eigenvalues(braces, bodies, springs=key == 'stiffness',
                                      dashpots=key == 'damping'))
             for key in ('stiffness', 'damping')}
    steps = {key: dt if lam is None or not lam.size else stable_step(lam, dt)
             for key, lam in alone.items()}
    key = 'damping' if steps['damping'] < steps['stiffness'] else 'stiffness'
    k = max(range(len(braces)), key=lambda j: getattr(braces[j], key))
    brace, fastest, would = braces[k], float(np.max(np.abs(lams))), _round_down(MARGIN * h)
    shown = (f'is {brace.damping:g} N s/m (stiffness {brace.stiffness:g} N/m)'
             if key == 'damping' else
             f'is {brace.stiffness:g} N/m (damping {brace.damping:g} N s/m)')
    motion = 'decay' if key == 'damping' else 'move'
    pad = f'{"less damped" if key == "damping" else "softer"} pad'
    # no dt of the scenario's range follows the pad: say so, not 'dt <= 0 s'
    expected = (f'dt <= {would:.2g} s with these braces, or a {pad}' if would >= MIN_DT else
                f'a {pad} (no step of at least {MIN_DT:g} s can follow these braces)')
    check.fail(f'sway_braces[{k}].{key}',
               f'{shown}: the braced bodies {motion} at up to {fastest:.4g} 1/s, which RK4 '
               f'with dt = {dt:g} s cannot follow (the pads would gain energy at every step '
               'and chatter)', expected)


def _moving(lams: np.ndarray):
    """Return the eigenvalues that are not rigid motions (None if any is not finite)."""
    if not np.all(np.isfinite(lams)):
        return None
    # the free bodies' rigid motions are zero eigenvalues, found to round-off
    return lams[np.abs(lams) > 1e-6 * float(np.max(np.abs(lams), initial=0.0))]


def _round_down(value: float) -> float:
    """Return value rounded down to two significant digits."""
    if value <= 0.0:
        return value
    scale = 10.0 ** (math.floor(math.log10(value)) - 1)
    return math.floor(value / scale) * scale
