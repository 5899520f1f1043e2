# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
A run's metrics from its samples: one function for sweeps and for recordings.

``Samples`` holds what a recording holds (per body time, position,
quaternion; per joint time, force, moment while active; the releases);
``Collector`` fills one while a ``Session`` runs, ``from_run`` makes one
from ``recording.analysis.open_run``. Both give the same numbers to the
bit, so ``compute`` gives the same metrics for a run and its recording.
"""

from __future__ import annotations

from dataclasses import dataclass, field
import math

from cfem_ros.core import rotations
from cfem_ros.core.engine.events import Event
from cfem_ros.core.native.kernel import SAMPLE
from cfem_ros.core.run.session import RowSink
from cfem_ros.recording.carriage import carriage_point, joint_anchors
from cfem_ros.recording.relative import velocity_seen
from cfem_ros.study import between
from cfem_ros.study.metricspec import STROKE_COLUMNS
from cfem_ros.study.shape_metrics import compute_distance
from cfem_ros.study.windowed import at_after, compute_extremes, release_edge_time
import numpy as np

NAN = float('nan')
#: Rows of the collector's buffer handed to the kernel at a time.
BUFFER_ROWS = 4096


@dataclass
class Samples:
    """
    A run's samples: the numbers its recording would hold.

    Attributes
    ----------
    bodies : dict of str to (time (n,), position (n, 3), quaternion (n, 4))
    joints : dict of str to (time (m,), force (m, 3), moment (m, 3))
        Only the samples where the joint was active.
    releases : list of (time, joint, cause)
    strokes : dict of str to (time, velocity (3,), rates (3,))
        End-of-stroke figures by wrench (SPEC section 7), the first of a name.
    contacts : list of (time, (body a, body b))
        The run's contact events.
    aero_outside : dict of str to float
        Per body with aero tables, the time it spent outside their range, s.
    cg_offsets : dict of str to ndarray (3,)
        Per body with a ``cg_offset``, the offset (body axes, m): points
        given from the CG are from the nominal CG (SPEC section 10).
    rates : dict of str to ndarray (n, 3)
        Per body its body rates at its samples, rad/s (body axes).
    velocities : dict of str to ndarray (n, 3)
        Per body its CG velocity at its samples, m/s (body axes).
    motions : dict of str to ndarray (n, ``kernel.TRACK.WIDTH``) or None
        Per body its track between the samples (``between.track``), made once
        for all the metrics that search between samples (``between.motion``).
    anchors : list of (joint, parent, child, anchor (3,))
        The run's joints, anchors in the world at t = 0
        (``carriage.joint_anchors``): an ``at`` entry's ``point: carriage``.

    """

    bodies: dict = field(default_factory=dict)
    joints: dict = field(default_factory=dict)
    releases: list = field(default_factory=list)
    strokes: dict = field(default_factory=dict)
    contacts: list = field(default_factory=list)
    aero_outside: dict = field(default_factory=dict)
    cg_offsets: dict = field(default_factory=dict)
    rates: dict = field(default_factory=dict)
    velocities: dict = field(default_factory=dict)
    motions: dict = field(default_factory=dict, repr=False, compare=False)
    anchors: list = field(default_factory=list)


def from_run(run) -> Samples:
    """Return the samples of a recording read by ``recording.analysis.open_run``."""
    return Samples(
        bodies={name: (b.time, b.position, b.quaternion) for name, b in run.bodies.items()},
        joints={name: (j.time, j.force, j.moment) for name, j in run.joints.items()},
        releases=list(run.releases()),
        strokes={name: (e['time'], e['velocity'], e['rates'])
                 for name, e in run.stroke_ends().items()},
        contacts=_contacts(run.events),
        aero_outside=_outside(run.events, max((float(b.time[-1]) for b in run.bodies.values()
                                               if len(b.time)), default=0.0)),
        rates={name: b.rates for name, b in run.bodies.items()},
        velocities={name: b.velocity for name, b in run.bodies.items()},
        anchors=_recorded_anchors(run))


def _recorded_anchors(run) -> list:
    """Return the joints' anchors of the scenario a recording names ([] if it is gone)."""
    from cfem_ros.recording.carriage import scenario_model
    model = scenario_model(run)
    return [] if model is None else joint_anchors(model)


def _outside(events, t_end: float) -> dict:
    """Return each body's time outside its aero tables from the run's events, s."""
    from cfem_ros.core.engine.aero import AERO_EVENTS, seconds_outside
    bodies = dict.fromkeys(e['body'] for e in events if e.get('event') in AERO_EVENTS)
    return {body: seconds_outside(events, body, t_end) for body in bodies}


def _contacts(events) -> list:
    """Return the contact events as (time, (body a, body b))."""
    return [(float(e['time']), tuple(e['bodies'])) for e in events
            if e.get('event') == Event.CONTACT and 'time' in e and len(e.get('bodies', ())) == 2]


def sample_times(times) -> np.ndarray:
    """Return sample times as a recording gives them back (whole ns, then s)."""
    return np.rint(np.asarray(times) * 1e9).astype(np.int64) / 1e9


class Collector(RowSink):
    """
    A ``Session`` output that keeps every sample's bodies and active joints' loads.

    A row sink (``sample_rows()``/``took_rows(times)``), so ``Session.run``
    lets the kernel write the rows; with ``forward`` (a ``StateRecorder``)
    the rows are the recorder's own and the samples are recorded as well.

    Parameters
    ----------
    sim : Simulator
    forward : StateRecorder, optional

    """

    def __init__(self, sim, forward=None):
        self.sim = sim
        self.forward = forward
        self._blocks = []       # (active joints, times, rows)
        self._buffers = {}
        self._rows = None
        self._active = None

    def sample_rows(self) -> np.ndarray:
        """Return rows for the next samples (``Simulator.outputs`` layout)."""
        self._active = self.sim.active_joints
        if self.forward is not None:
            self._rows = self.forward.sample_rows()
            return self._rows
        rows = self._buffers.get(self._active)
        if rows is None:
            rows = self._buffers[self._active] = np.empty(
                (BUFFER_ROWS, self.sim.sampling.outputs_size()))
        self._rows = rows
        return rows

    def took_rows(self, times: np.ndarray):
        """Keep the samples at these times, in the first rows handed out."""
        k = len(times)
        self._blocks.append((self._active, sample_times(times), self._rows[:k].copy()))
        if self.forward is not None:
            self.forward.took_rows(times)

    def sample(self):
        """Keep one sample of the current state."""
        row = self.sim.outputs()
        self._blocks.append((self.sim.active_joints, sample_times([self.sim.t]), row[None]))
        if self.forward is not None:
            self.forward.sample()

    def events(self):
        """Pass the events on to the recorder, if any."""
        if self.forward is not None:
            self.forward.events()

    def received(self, item, t: float):
        """Pass an input on to the recorder, if any."""
        if self.forward is not None:
            self.forward.received(item, t)

    def samples(self) -> Samples:
        """Return the samples kept, with the simulator's releases."""
        model = self.sim.model
        n = len(model.bodies)
        times = (np.concatenate([b[1] for b in self._blocks]) if self._blocks
                 else np.empty(0))
        rows = [b[2][:, :SAMPLE.BODY * n] for b in self._blocks]
        state = (np.concatenate(rows) if rows else np.empty((0, SAMPLE.BODY * n))).reshape(
            len(times), n, SAMPLE.BODY)   # (samples, bodies, a sample's body numbers)
        bodies = {b.name: (times, state[:, i, SAMPLE.span('O_POSITION')],
                           state[:, i, SAMPLE.span('O_QUATERNION')])
                  for i, b in enumerate(model.bodies)}
        joints = {}
        for j, joint in enumerate(model.joints):
            parts = [(t, _joint_numbers(rows, n, active.index(j)))
                     for active, t, rows in self._blocks if j in active]
            if parts:
                loads = np.concatenate([p[1] for p in parts])
                joints[joint.name] = (np.concatenate([p[0] for p in parts]),
                                      loads[:, SAMPLE.span('O_FORCE')],
                                      loads[:, SAMPLE.span('O_MOMENT')])
        releases = sorted((e['time'], e.get('joint', '?'), e.get('cause', '?'))
                          for e in self.sim.events if e.get('event') == Event.RELEASE)
        strokes = {}
        for e in self.sim.events:
            if e.get('event') == Event.STROKE_END:
                strokes.setdefault(e['wrench'], (e['time'], e['velocity'], e['rates']))
        rates = {b.name: state[:, i, SAMPLE.span('O_RATES')]
                 for i, b in enumerate(model.bodies)}
        velocities = {b.name: state[:, i, SAMPLE.span('O_VELOCITY')]
                      for i, b in enumerate(model.bodies)}
        return Samples(bodies=bodies, joints=joints, releases=releases, strokes=strokes,
                       contacts=_contacts(self.sim.events),
                       aero_outside=_outside(self.sim.events, self.sim.t),
                       cg_offsets={b.name: b.cg_offset for b in model.bodies
                                   if np.any(b.cg_offset)},
                       rates=rates, velocities=velocities, anchors=joint_anchors(model))


def _velocity_at(entry, samples) -> list:
    """
    Return an ``at`` entry's u_rel, v_rel, w_rel: the CG's velocity seen from its carrier.

    In the carrier's axes, m/s (``relative.velocity_seen``), at the sample
    (NaN if the run has none there); after a release between two samples,
    interpolated linearly between theirs as the position is (``at_after``).
    """
    t = np.asarray(samples.bodies[entry.body][0])
    if entry.after is None:
        when = entry.time
    else:
        when = release_edge_time(entry.after, entry.time, samples.releases, entry.groups)
    if math.isnan(when) or not len(t) or not t[0] - 0.5e-9 <= when <= t[-1] + 0.5e-9:
        return [NAN] * 3
    k = int(np.searchsorted(t, when - 0.5e-9))
    if abs(t[min(k, len(t) - 1)] - when) <= 0.5e-9:
        rows, fraction = [min(k, len(t) - 1)] * 2, 0.0
    elif entry.after is None:   # not a sample time: no number, as the pose
        return [NAN] * 3
    else:
        rows, fraction = [k - 1, k], (when - t[k - 1]) / (t[k] - t[k - 1])
    states = []
    for name in (entry.body, entry.relative_to):
        _, position, quaternion = samples.bodies[name]
        quaternion = np.asarray(quaternion, dtype=float)[rows]
        velocity = samples.velocities.get(name, np.full((len(t), 3), NAN))
        world = np.einsum('nij,nj->ni', rotations.matrices(
            quaternion / np.linalg.norm(quaternion, axis=1)[:, None]),
            np.asarray(velocity, dtype=float)[rows])   # body axes -> world
        rates = np.asarray(samples.rates.get(name, np.full((len(t), 3), NAN)))[rows]
        states += [np.asarray(position, dtype=float)[rows], world, quaternion, rates]
    seen = velocity_seen(*states)
    return [float(v) for v in seen[0] + fraction * (seen[1] - seen[0])]


def _from_point(entry, samples, values: list) -> list:
    """Return an ``at`` entry's values with x, y, z from its ``point`` of the carrier."""
    if entry.point is None:
        return values
    if isinstance(entry.point, str):   # carriage: the run's anchors, the carrier at t = 0
        t, position, quaternion = samples.bodies[entry.relative_to]
        released = [joint for _, joint, _ in samples.releases]
        point = None
        if len(t) and abs(float(t[0])) <= 0.5e-9:
            point = carriage_point(samples.anchors, entry.body, entry.relative_to, released,
                                   position[0], quaternion[0])
        if point is None:   # no joint between them, or no sample at t = 0: no number
            point = np.full(3, NAN)
    else:
        point = entry.point
    return [float(v - c) for v, c in zip(values[:3], point)] + list(values[3:])


def _kernel():
    """Return the compiled kernel (imported on first use: ``summarize`` may not need it)."""
    from cfem_ros.core.native import kernel
    return kernel


def _c(array) -> np.ndarray:
    """Return a float array in C order (what the compiled kernel takes)."""
    return np.ascontiguousarray(array, dtype=float)


def _relative(position, quat, position_r, quat_r):
    """
    Return a CG position and attitude in the axes of a reference body (one sample).

    The position in the reference's axes (its attitude normalized) and the
    attitude conj(quat_r) quat (``to_rpy_deg`` normalizes it), in plain
    floats: one sample costs less without numpy.
    """
    rx, ry, rz, rw = (float(c) for c in quat_r)
    x, y, z, w = (float(c) for c in quat)
    norm = math.sqrt(rx * rx + ry * ry + rz * rz + rw * rw)
    a, b, c, d = rx / norm, ry / norm, rz / norm, rw / norm
    dx, dy, dz = (float(p) - float(r) for p, r in zip(position, position_r))
    # R^T (p - p_r), R the reference's body-to-world matrix (rotations.matrices)
    relative = [(1.0 - 2.0 * (b * b + c * c)) * dx + 2.0 * (a * b + d * c) * dy
                + 2.0 * (a * c - d * b) * dz,
                2.0 * (a * b - d * c) * dx + (1.0 - 2.0 * (a * a + c * c)) * dy
                + 2.0 * (b * c + d * a) * dz,
                2.0 * (a * c + d * b) * dx + 2.0 * (b * c - d * a) * dy
                + (1.0 - 2.0 * (a * a + b * b)) * dz]
    # conj(q_r) q, Hamilton product (rotations.multiply)
    attitude = [rw * x - rx * w - ry * z + rz * y,
                rw * y + rx * z - ry * w - rz * x,
                rw * z - rx * y + ry * x - rz * w,
                rw * w + rx * x + ry * y + rz * z]
    return relative, attitude


def compute(samples: Samples, metrics) -> dict:
    """
    Return the metrics of one run (``spec.Metrics``) as a dict of column -> value.

    Clearance: the least distance over point pairs and the window, between
    samples included (``between``; the first least sample if nothing between
    them is lower), its time and the two points' indices. Releases:
    each joint's release time (NaN if none) and cause ('' if none). Peaks:
    the largest |force| and |moment| of each joint over the samples while it
    was active (NaN if never sampled). ``at``: the body's CG position and
    Z-Y-X roll, pitch, yaw at the sample at that time (NaN if the run has no
    sample there), relative to the ``relative_to`` body's frame if given,
    from its ``point`` (``carriage`` or [x, y, z], its axes) if given: a
    carriage the run's joints do not give (no joint between the two) is NaN.

    Raises
    ------
    KeyError
        If a body the metrics need is not in the samples.

    """
    out = {}
    for c in metrics.clearance:
        for name in (c.body_a, c.body_b):
            if name not in samples.bodies:
                raise KeyError(f'no body {name!r} in the run')
        t, pos_a, quat_a = samples.bodies[c.body_a]
        _, pos_b, quat_b = samples.bodies[c.body_b]
        inside = c.window.mask(np.asarray(t), samples.releases)
        if not inside.all():   # a window (from/to): only its samples
            t, pos_a, quat_a = np.asarray(t)[inside], np.asarray(pos_a)[inside], \
                np.asarray(quat_a)[inside]
            pos_b, quat_b = np.asarray(pos_b)[inside], np.asarray(quat_b)[inside]
        values = (NAN, NAN, -1, -1)
        if len(t):
            best = np.empty(4)
            # points given from the nominal CG: from the actual CG they lie less the offset
            points_a = c.points_a - samples.cg_offsets.get(c.body_a, 0.0)
            points_b = c.points_b - samples.cg_offsets.get(c.body_b, 0.0)
            _kernel().clearance(_c(pos_a), _c(quat_a), _c(points_a), _c(pos_b),
                                _c(quat_b), _c(points_b), best)
            if best[1] >= 0:
                values = (float(best[0]), float(t[int(best[1])]), int(best[2]), int(best[3]))
            # between samples (SPEC section 15): the least of the continuous trajectory
            found = between.least_point_distance(samples, c.body_a, points_a, c.body_b,
                                                 points_b, *c.window.bounds(samples.releases))
            if not math.isnan(found[0]) and (math.isnan(values[0])
                                             or found[0] < values[0] - between.GAIN):
                values = found
        for suffix, value in zip(('min', 'min_time', 'point_a', 'point_b'), values):
            out[f'{c.prefix}_{suffix}'] = value
    for entry in metrics.distance:
        out.update(compute_distance(entry, samples))
    released = {}
    for t, joint, cause in samples.releases:
        released.setdefault(joint, (float(t), str(cause)))
    for joint in metrics.joints:
        t, cause = released.get(joint, (NAN, ''))
        out[f'release_{joint}_time'] = t
        out[f'release_{joint}_cause'] = cause
    for joint in metrics.joints:
        track = samples.joints.get(joint)
        if track is None or not len(track[0]):
            force = moment = NAN
        else:
            force = float(np.sqrt((track[1] ** 2).sum(axis=1)).max())
            moment = float(np.sqrt((track[2] ** 2).sum(axis=1)).max())
        out[f'peak_force_{joint}'] = force
        out[f'peak_moment_{joint}'] = moment
    for entry in metrics.at:
        names = entry.columns()
        values = [NAN] * 6
        for name in (entry.body, entry.relative_to):
            if name is not None and name not in samples.bodies:
                raise KeyError(f'no body {name!r} in the run')
        if entry.relative_to is not None:   # the velocity seen from the carrier (SPEC 15)
            out.update(zip(names[6:], _velocity_at(entry, samples)))
        if entry.after is not None:   # s after a release (SPEC section 12)
            out.update(zip(names, _from_point(entry, samples, at_after(entry, samples))))
            continue
        t, pos, quat = samples.bodies[entry.body]
        want = int(round(entry.time * 1e9))
        k = int(np.searchsorted(t, entry.time - 0.5e-9))
        if k < len(t) and int(round(t[k] * 1e9)) == want:
            p, q = pos[k], quat[k]
            if entry.relative_to is not None:
                _, pos_r, quat_r = samples.bodies[entry.relative_to]
                p, q = _relative(p, q, pos_r[k], quat_r[k])
            rpy = rotations.to_rpy_deg(np.asarray(q, dtype=float))
            values = [float(p[0]), float(p[1]), float(p[2])] + [float(a) for a in rpy]
        out.update(zip(names, _from_point(entry, samples, values)))
    for wrench in getattr(metrics, 'strokes', ()):
        t, velocity, rates = samples.strokes.get(wrench, (NAN, [NAN] * 3, [NAN] * 3))
        # rates in deg/s, as the export's _p, _q, _r (SPEC 15: one unit per quantity)
        values = ([float(t)] + [float(v) for v in velocity]
                  + [float(v) for v in np.degrees(np.asarray(rates, dtype=float))])
        out.update(zip((f'stroke_{wrench}_{s}' for s in STROKE_COLUMNS), values))
    for body in getattr(metrics, 'aero', ()):
        out[f'aero_outside_{body}'] = float(samples.aero_outside.get(body, 0.0))
    for entry in getattr(metrics, 'extremes', ()):
        out.update(compute_extremes(entry, samples))
    return out


def empty(metrics) -> dict:
    """Return the metrics of a run that produced nothing (NaN, -1 indices, '' causes)."""
    out = {}
    for name in metrics.columns():
        if name.endswith('_cause'):
            out[name] = ''
        elif name.endswith(('_point_a', '_point_b')):
            out[name] = -1
        else:
            out[name] = NAN
    return out


def _joint_numbers(rows: np.ndarray, n: int, k: int) -> np.ndarray:
    """Return the k-th sampled joint's numbers (``SAMPLE.JOINT``) of sample rows of n bodies."""
    first = SAMPLE.BODY * n + SAMPLE.JOINT * k
    return rows[:, first:first + SAMPLE.JOINT]
