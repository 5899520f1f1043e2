# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Every load as an arrow where it acts (``load_markers``, SPEC section 4).

One arrow per active joint (at the joint's frame, along the force on its
child), per applied load (ejectors and other scheduled wrenches, their
reactions, aerodynamic loads, sway braces) and per wrench held on a body by
an input: each from its point of action along its force, in the frame of the
body it acts on (frame-locked, so it rides with the body between sendings),
coloured by kind. Moments are not drawn (plot them).

Points of action: a scheduled wrench's ``point`` on its body; its reaction
at the ejector on the carrier (where the point was, in the carrier's axes,
when the load came on); a sway brace at its pad on each body (the body's
contact point, fixed on the body, and that point where it is now in the
carrier's axes: the carrier takes the opposite force at the same point);
a wrench held by an input at its point. An aerodynamic load has no point: it
is drawn on its line of action, at its point nearest the CG (force x moment
/ |force|^2, the central axis), or at the CG when that point lies outside
the body.

Scale: one for the whole recording, fixed at its first state (t = 0) from
what is known then, so that arrows of two instants compare and every arrow
is written as the run goes, in time order (a cut or killed recording keeps
the arrows of the run so far): the scenario's ``load_scale`` (N per m) if
stated, else 1, 2 or 5 times a power of ten newtons per metre that draws the
largest load known at t = 0 (``start_largest``) about the size of the
largest body that moves under its loads. A larger load later is drawn
longer at that scale. The node and the recorder draw with this class, so
they draw at the same scale. The scale is stated in each arrow's text
(``fwd_hook joint: 8.897e+03 N, 1 m = 5e+03 N``), always as wide, so that a
recording encodes the arrows from one template (``markerbytes``).
"""

from __future__ import annotations

import math

from cfem_ros.core import rotations
from cfem_ros.core.engine.events import LOAD_EVENTS   # the events that start or end a load
from cfem_ros.core.native.kernel import LOADS, SAMPLE
from cfem_ros.recording import visuals
import numpy as np

ARROW, DELETEALL = 0, 3
#: Colours (r, g, b, a) of the kinds of load.
COLORS = {
    'joint': (0.9, 0.1, 0.1, 0.95),
    'ejector': (0.95, 0.2, 0.85, 0.95),
    'load': (1.0, 0.55, 0.0, 0.95),
    'reaction': (0.55, 0.3, 0.3, 0.95),
    'aero': (0.0, 0.12, 0.5, 0.95),   # navy: it shows on the palette's blue store too
    'brace': (0.55, 0.3, 0.95, 0.95),
    'input': (0.0, 0.85, 0.85, 0.95),
}
#: An arrow's shaft diameter, head diameter and head length, per metre of the scale's size.
SHAFT, HEAD, HEAD_LENGTH = 0.02, 0.045, 0.07
#: Forces smaller than this fraction of the largest drawn are not drawn (rounding).
SMALLEST = 1e-9
#: The columns the arrows read, once: a body's CG and attitude, a joint's force, an
#: applied source's force and moment as a (2, 3) index (``kernel.SAMPLE``), a held load's
#: force and point (``kernel.LOADS``).
_POSITION, _QUATERNION = SAMPLE.span('O_POSITION'), SAMPLE.span('O_QUATERNION')
_JOINT_FORCE = SAMPLE.span('O_FORCE')
_WRENCH = np.array([np.arange(SAMPLE.width(name)) + getattr(SAMPLE, name)
                    for name in ('O_WRENCH_FORCE', 'O_WRENCH_MOMENT')])
_HELD_FORCE, _HELD_POINT = LOADS.span('H_FORCE'), LOADS.span('H_POINT')


def event_states(sim, new_events) -> list:
    """
    Return the state at each instant of new events that start or end a load, in time order.

    Each as (t, row, active, held): the time (s) and, just after the
    events there, ``Simulator.outputs()``, ``active_joints`` and
    ``held_wrenches()``: the current ones when the simulator is still at
    that instant, else those it kept (``Simulator.load_states``, which the
    caller turns on: ``watch_loads``). The recorder and the node both draw
    their arrows at these, so they draw the same instants.
    """
    out = []
    kept = sim.load_states or {}
    for t in sorted({e['time'] for e in new_events if e.get('event') in LOAD_EVENTS}):
        if t == sim.t:
            out.append((t, sim.outputs(), sim.active_joints, sim.held_wrenches()))
        elif t in kept:
            out.append((t, *kept[t]))
    return out


def watch_loads(sim):
    """Have sim keep the state at each load event it steps over (``event_states``)."""
    if sim.load_states is None:
        sim.load_states = {}


def scale_size(model) -> float:
    """Return the size (m) the largest force is drawn at: the largest body moved by forces."""
    shapes = [visuals.body_shape(b) for b in model.bodies if b.dynamic] or [
        visuals.body_shape(b) for b in model.bodies]
    return max((visuals.extent(s) for s in shapes), default=1.0)


def newtons_per_metre(largest: float, size: float) -> float:
    """Return the arrows' scale: 1, 2 or 5 times a power of ten, the largest force <= size m."""
    if not largest > 0.0:
        return 1.0
    raw = largest / size
    power = 10.0 ** math.floor(math.log10(raw))
    for step in (1.0, 2.0, 5.0, 10.0):
        if step * power >= raw * (1.0 - 1e-12):
            return step * power
    return 10.0 * power


def stated_largest(model) -> float:
    """
    Return the largest load the scenario states, N.

    Each scheduled wrench's force (its table's largest), each sway brace's
    preload and each free body's weight, m |g|.
    """
    sizes = [0.0]
    weight = float(np.linalg.norm(model.gravity))
    sizes += [b.mass * weight for b in model.bodies if b.dynamic]
    for wrench in model.wrenches:
        sizes.append(float(np.linalg.norm(wrench.force)))
        if len(wrench.table):
            sizes.append(float(np.linalg.norm(wrench.table[:, 1:4], axis=1).max()))
    sizes += [float(brace.preload) for brace in model.braces]
    return max(sizes)


def start_largest(model, first: list) -> float:
    """
    Return the largest load known at t = 0, N: the stated ones and those drawn first.

    first: the arrows of the first state (``LoadArrows.arrows`` at t = 0):
    each joint's load there (a carrier's manoeuvre included), the applied
    loads then (aero, braces) and any wrench held by an input.
    """
    drawn = [float(np.linalg.norm(arrow[6])) for arrow in first]
    return max([stated_largest(model)] + drawn)


def source_kind(model, body: int, source: str) -> tuple:
    """
    Return the kind of an applied load and where it acts: (kind, place).

    place: ('point', p) a point fixed on the body (body axes, m); ('anchor',
    wrench) a reaction, at the wrench's point in this body's axes when it
    came on; ('contact', brace) a brace's reaction on its carrier, at the
    pad's contact point where it is now; ('line', None) on the line of
    action (aero). A scheduled wrench acting on its own body is an ejector
    (with a stroke) or a load; on its ``reacts_on`` body it is a reaction;
    ``aero`` is aerodynamic; a sway brace is a brace.
    """
    if source == 'aero':
        return 'aero', ('line', None)
    for wrench in model.wrenches:
        if wrench.name == source:
            if wrench.body != body:
                return 'reaction', ('anchor', wrench)
            kind = 'ejector' if wrench.stroke is not None else 'load'
            return kind, ('point', np.asarray(wrench.point, dtype=float))
    for brace in model.braces:
        if brace.name == source:
            if brace.body != body:
                return 'brace', ('contact', brace)
            return 'brace', ('point', np.asarray(brace.point, dtype=float))
    return 'load', ('line', None)


class LoadArrows:
    """
    The ``load_markers`` MarkerArray of a model, from a sample's numbers.

    Parameters
    ----------
    model : Model
    namespace : str
        The markers' ``ns`` prefix (the node's namespace).
    sources : list of (str, str)
        (body, source) of each applied load of a sample (``Simulator.applied_sources``).

    """

    def __init__(self, model, namespace: str, sources):
        self.model = model
        self.namespace = namespace
        self.size = scale_size(model)
        self.sources = [(model.body_index(body), source) for body, source in sources]
        self.kinds = [source_kind(model, i, source) for i, source in self.sources]
        self.half_extents = [0.5 * visuals.extent(visuals.body_shape(b)) for b in model.bodies]
        self._scale = {'x': SHAFT * self.size, 'y': HEAD * self.size,
                       'z': HEAD_LENGTH * self.size}
        #: The reactions' points, carrier axes, m, by source index: set when they come on.
        self.anchors = {}
        #: The arrows' scale, N per m: the scenario's ``load_scale``, else fixed at the
        #: first state drawn (``fix_scale``), then the same to the end.
        self.per_metre = model.load_scale

    def arrows(self, row: np.ndarray, active, held: np.ndarray) -> list:
        """
        Return the arrows of one state: (ns, id, frame, kind, label, start, force), body axes.

        row: the state's numbers in ``Simulator.outputs`` order, these joints
        active; held: ``Simulator.held_wrenches()``.
        """
        model = self.model
        n = len(model.bodies)
        state = row[:SAMPLE.BODY * n].reshape(n, SAMPLE.BODY)
        turns = rotations.matrices(state[:, _QUATERNION])   # body to world
        out = []
        first = SAMPLE.BODY * n
        joints = row[first:first + SAMPLE.JOINT * len(active)].reshape(-1, SAMPLE.JOINT)
        for i, k in enumerate(active):
            joint = model.joints[k]
            force = joints[i, _JOINT_FORCE] @ turns[joint.child]
            out.append(('joint_loads', k, joint.name, 'joint', joint.name, np.zeros(3), force))
        first += SAMPLE.JOINT * len(active)
        applied = row[first:first + SAMPLE.WRENCH * len(self.sources)].reshape(-1, SAMPLE.WRENCH)
        for j, ((body, source), (kind, place)) in enumerate(zip(self.sources, self.kinds)):
            force, moment = applied[j][_WRENCH] @ turns[body]   # in body axes
            start = self._start(j, body, place, state, turns, force, moment)
            out.append(('applied_loads', j, model.bodies[body].name, kind, source, start, force))
        forces = held[:, _HELD_FORCE]
        for body in np.flatnonzero(np.abs(forces).sum(axis=1) > 0.0):
            force = forces[body] if held[body, LOADS.H_AXES] else forces[body] @ turns[body]
            out.append(('held_loads', int(body), model.bodies[body].name, 'input',
                        model.bodies[body].name, held[body, _HELD_POINT], force))
        largest = max((float(np.linalg.norm(a[6])) for a in out), default=0.0)
        return [a for a in out if np.linalg.norm(a[6]) > SMALLEST * largest]

    def _start(self, j: int, body: int, place: tuple, state, turns, force, moment):
        """Return where applied load j acts now, in its body's axes, m (``source_kind``)."""
        how, what = place
        if how == 'point':
            return what
        if how == 'line':
            return self._on_line(body, force, moment)
        if how == 'anchor':   # the ejector on the carrier: where the point was as it came on
            if j not in self.anchors:
                if not force.any():
                    return np.zeros(3)
                self.anchors[j] = _in_axes(state, turns, body, what.body, what.point)
            return self.anchors[j]
        return _in_axes(state, turns, body, what.body, what.point)   # a brace's pad, now

    def _on_line(self, body: int, force: np.ndarray, moment: np.ndarray) -> np.ndarray:
        """Return the point of a load's line of action nearest the CG (the CG if off the body)."""
        size = float(force @ force)
        if size == 0.0:
            return np.zeros(3)
        point = np.cross(force, moment) / size
        return point if np.linalg.norm(point) <= self.half_extents[body] else np.zeros(3)

    def fix_scale(self, first: list) -> float:
        """
        Return the arrows' scale, N per m, fixing it at the first call.

        first: the arrows of the first state drawn (t = 0): the scale draws
        ``start_largest`` about ``size`` long (``newtons_per_metre``),
        unless the scenario states ``load_scale``.
        """
        if self.per_metre is None:
            self.per_metre = newtons_per_metre(start_largest(self.model, first), self.size)
        return self.per_metre

    def message(self, stamp: dict, row: np.ndarray, active, held: np.ndarray) -> tuple:
        """
        Return the MarkerArray of one state (a dict) at the run's one scale, and its kind.

        States are given in time order from t = 0 (the first fixes the
        scale: ``fix_scale``); the kind is for ``MarkerArrayEncoder``.
        """
        arrows = self.arrows(row, active, held)
        return self.array(stamp, arrows, self.fix_scale(arrows))

    def array(self, stamp: dict, arrows: list, per_metre: float) -> tuple:
        """
        Return a MarkerArray of arrows (``arrows``) at a scale (N/m) and its kind.

        A first DELETEALL clears the arrows of loads no longer drawn.
        """
        ns = f'{self.namespace}/'
        out = [{'header': {'stamp': stamp, 'frame_id': self.model.frame_id},
                'ns': ns + 'joint_loads', 'id': 0, 'action': DELETEALL}]
        for space, k, frame, kind, label, start, force in arrows:
            end = start + force / per_metre
            out.append({'header': {'stamp': stamp, 'frame_id': frame}, 'ns': ns + space,
                        'id': k, 'type': ARROW, 'action': 0, 'frame_locked': True,
                        'pose': {'orientation': {'x': 0.0, 'y': 0.0, 'z': 0.0, 'w': 1.0}},
                        'points': [_xyz(start), _xyz(end)], 'scale': self._scale,
                        'color': dict(zip('rgba', COLORS[kind])),
                        'text': f'{label} {kind}: {np.linalg.norm(force):.3e} N, '
                                f'1 m = {per_metre:.0e} N'})
        kind = ('loads', self.namespace, self.model.frame_id, self.size, tuple(
            (a[0], a[1], a[2], a[3]) for a in arrows))
        return {'markers': out}, kind


def _in_axes(state: np.ndarray, turns: np.ndarray, axes: int, body: int,
             point: np.ndarray) -> np.ndarray:
    """Return a point fixed on body (its axes, m) in the axes of body ``axes``, from its CG."""
    cg = state[:, _POSITION]
    world = cg[body] + turns[body] @ point
    return (world - cg[axes]) @ turns[axes]


def _xyz(v) -> dict:
    return {'x': float(v[0]), 'y': float(v[1]), 'z': float(v[2])}
