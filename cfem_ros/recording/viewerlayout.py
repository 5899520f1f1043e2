# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
A Foxglove / Lichtblick layout that shows a scenario's separation with no click.

``layout(model)`` returns the layout (the JSON the apps import and export,
*Layouts > Import*): two 3D panels side by side with the body and load
markers on, one following the carrier's ``<body>_view`` (z up, the
separation as the aircraft sees it), the other the store's ``<body>_chase``
(z up, heading as the carrier's view: the store in view to the end however
it tumbles; ``viewframes``), both with the camera on the store's side; one
frame label per origin (frames that start at one point, like ``map``, the
scenario's frame and a body there, are named once); a Plot of the store's
position relative to its carrier, one of the loads on it (its hooks, else
its scheduled and aerodynamic loads: every series a topic the recording
has), and the events. The shipped examples' layouts are in
``config/viewer/``; for a scenario of yours, ``cfem-sim run SCENARIO -o
RUN.mcap --layout LAYOUT.json``, or without a run::

    python3 -m cfem_ros.recording.viewerlayout my_scenario.yaml -o my_layout.json
"""
from __future__ import annotations

import argparse
import json
import os
import sys

from cfem_ros.core import rotations
from cfem_ros.recording import schema, viewframes, visuals
import numpy as np

#: Which frame keeps its label where several start at one point: lower first.
_PRIORITY = {'dynamic': 0, 'joint': 1, 'carrier': 2, 'view': 3, 'chase': 4, 'scenario': 5,
             'root': 6}


def subject(model) -> int:
    """Return the body the layout watches: the first carried one (a store) that has a carrier."""
    carried = [i for i, b in enumerate(model.bodies)
               if b.dynamic and b.name not in visuals.carriers(model)]
    for body, reference in model.references:
        if body in carried and not model.bodies[reference].dynamic:
            return body
    return carried[0] if carried else 0


def _frames_at_start(model) -> list:
    """Return (name, kind, position at t = 0 in root axes) of every frame a recording has."""
    up = visuals.up_rotation(model.gravity)
    turn = np.eye(3) if up is None else rotations.matrices(np.array([up]))[0]
    root = visuals.root_frame(model)
    out = [(root, 'root', np.zeros(3))]
    if root != model.frame_id:
        out.append((model.frame_id, 'scenario', np.zeros(3)))
    for i, body in enumerate(model.bodies):
        at = turn @ np.asarray(body.position, dtype=float)
        out.append((body.name, 'dynamic' if body.dynamic else 'carrier', at))
        if i in viewframes.carriers(model):
            out.append((viewframes.frame_name(model, body.name), 'view', at))
        if body.dynamic:
            out.append((viewframes.chase_name(model, body.name), 'chase', at))
    out += [(j.name, 'joint', turn @ np.asarray(j.anchor, dtype=float)) for j in model.joints]
    return out


def hidden_frames(model) -> list:
    """Return the frames whose axes and label the layout hides: all but one per origin."""
    groups = {}
    for name, kind, at in _frames_at_start(model):
        groups.setdefault(tuple(np.round(at, 6)), []).append((_PRIORITY[kind], name))
    return sorted(name for group in groups.values() for _, name in sorted(group)[1:])


def _mm(value) -> float:
    """Return a length in m rounded to the millimetre (a layout file reads better)."""
    return round(float(value), 3) + 0.0


def _plot(paths: list, title: str) -> dict:
    return {'paths': [{'value': path, 'enabled': True, 'timestampMethod': 'receiveTime',
                       'label': label} for path, label in paths],
            'title': title, 'showXAxisLabels': True, 'showYAxisLabels': True,
            'showLegend': True, 'legendDisplay': 'floating', 'showPlotValuesInLegend': True,
            'isSynced': True, 'xAxisVal': 'timestamp'}


def _loads(model, store: int, ns: str) -> tuple:
    """
    Return the load plot's series and title: the store's hooks, else its other loads.

    The hooks (joints of the store, world axes) while it has any; a store
    free from t = 0 (ejectors only) gets its scheduled loads and its aero
    load instead, so that no plot is empty.
    """
    body = model.bodies[store].name
    hooks = [j for j in model.joints if store in (j.child, j.parent)]
    if hooks:
        return [(f'{schema.JOINT_WRENCH_WORLD.absolute(ns, joint=j.name)}.wrench.force.{c}',
                 f'{j.name} force {c} ({model.frame_id} axes), N')
                for j in hooks for c in 'xz'], 'hook loads'
    sources = [w.name for w in model.wrenches if w.body == store]
    sources += ['aero'] if any(a.body == store for a in model.aero) else []
    return [(f'{schema.APPLIED_WORLD.absolute(ns, body=body, source=source)}.wrench.force.'
             f'{c}', f'{source} force {c} ({model.frame_id} axes), N')
            for source in sources for c in 'xz'], f'loads on {body}'


def _three_d(follow: str, size: float, distance: float, target: list, model, ns: str) -> dict:
    """
    Return a 3D panel following a frame, the camera on the store's side aimed at target.

    size: the largest free body's (m), for the frames' axes and labels;
    distance: the camera's from target (m); target: in the followed frame.
    """
    return {
        'followTf': follow, 'followMode': 'follow-pose',
        'cameraState': {'distance': _mm(distance), 'perspective': True, 'phi': 75.0,
                        'thetaOffset': 0.0, 'fovy': 45.0, 'near': 0.05, 'far': 5000.0,
                        'targetOffset': [_mm(v) for v in target],
                        'target': [0.0, 0.0, 0.0], 'targetOrientation': [0.0, 0.0, 0.0, 1.0]},
        'scene': {'transforms': {'showLabel': True, 'axisScale': _mm(0.15 * size),
                                 'labelSize': _mm(0.04 * size)}},
        'topics': {schema.MARKERS.absolute(ns): {'visible': True},
                   schema.LOAD_MARKERS.absolute(ns): {'visible': True}},
        'transforms': {f'frame:{name}': {'visible': False} for name in hidden_frames(model)},
    }


def layout(model, namespace: str = '/cfem') -> dict:
    """Return the layout of a scenario's recording (or live node) under namespace."""
    ns = namespace.rstrip('/')
    store = subject(model)
    body = model.bodies[store]
    carrier = dict(model.references).get(store, -1)   # its relative pose is recorded
    carrier = carrier if carrier >= 0 and not model.bodies[carrier].dynamic else -1
    size = max(visuals.extent(visuals.body_shape(b)) for b in model.bodies if b.dynamic) \
        if any(b.dynamic for b in model.bodies) else 1.0
    up = visuals.up_rotation(model.gravity)
    turn = np.eye(3) if up is None else rotations.matrices(np.array([up]))[0]
    at = turn @ np.asarray(body.position, dtype=float)
    if carrier >= 0:   # follow the carrier, z up; aim below the store: it falls
        follow = viewframes.frame_name(model, model.bodies[carrier].name)
        at = at - turn @ np.asarray(model.bodies[carrier].position, dtype=float)
        topic = schema.RELATIVE_POSE.absolute(ns, body=body.name)
        position = [(f'{topic}.pose.position.{c}',
                     f'{body.name} {c} in {model.bodies[carrier].name} axes, m') for c in 'xz']
    else:
        follow = visuals.root_frame(model)
        topic = schema.POSE.absolute(ns, body=body.name)
        position = [(f'{topic}.pose.position.{c}',
                     f'{body.name} {c} in {model.frame_id} axes, m') for c in 'xz']
    loads, title = _loads(model, store, ns)
    chase = viewframes.chase_name(model, body.name) if body.dynamic else follow
    return {
        'configById': {
            '3D!cfem': _three_d(follow, size, 4.0 * size, [at[0], at[1], at[2] - 0.4 * size],
                                model, ns),
            '3D!chase': _three_d(chase, size, 3.0 * size, [0.0, 0.0, 0.0], model, ns),
            'Plot!position': _plot(position, f'{body.name} position'),
            'Plot!loads': _plot(loads, title),
            'RawMessages!events': {'topicPath': schema.EVENTS.absolute(ns), 'diffEnabled': False,
                                   'diffMethod': 'custom', 'diffTopicPath': '',
                                   'showFullMessageForDiff': False},
        },
        'globalVariables': {}, 'userNodes': {}, 'playbackConfig': {'speed': 0.2},
        'layout': {'first': {'first': '3D!cfem', 'second': '3D!chase', 'direction': 'row',
                             'splitPercentage': 50},
                   'second': {'first': 'Plot!position', 'direction': 'row',
                              'splitPercentage': 33, 'second': {
                                  'first': 'Plot!loads', 'second': 'RawMessages!events',
                                  'direction': 'row', 'splitPercentage': 50}},
                   'direction': 'column', 'splitPercentage': 64},
    }


def write(model, path: str, namespace: str = '/cfem'):
    """Write a scenario's layout to path as JSON (OSError if it cannot be)."""
    text = json.dumps(layout(model, namespace), indent=2) + '\n'
    os.makedirs(os.path.dirname(path) or os.curdir, exist_ok=True)
    with open(path, 'w') as out:
        out.write(text)


def main(argv=None) -> int:
    """Write a scenario's layout as JSON (``-o FILE``, else to standard output)."""
    from cfem_ros.core.errors import CfemError
    from cfem_ros.core.scenario.parse import load_scenario
    parser = argparse.ArgumentParser(
        prog='python3 -m cfem_ros.recording.viewerlayout',
        description="Write a Foxglove/Lichtblick layout that shows a scenario's separation.")
    parser.add_argument('scenario')
    parser.add_argument('-o', '--output', help='the layout file (default: standard output)')
    parser.add_argument('--namespace', default='/cfem')
    args = parser.parse_args(argv)
    try:
        model = load_scenario(args.scenario)
    except (CfemError, OSError) as err:
        print(f'ERROR: {err}', file=sys.stderr)
        return 2
    text = json.dumps(layout(model, args.namespace), indent=2) + '\n'
    if args.output is None:
        sys.stdout.write(text)
        return 0
    try:
        write(model, args.output, args.namespace)
    except OSError as err:
        print(f'ERROR: {args.output}: cannot write ({err.strerror})', file=sys.stderr)
        return 2
    return 0


if __name__ == '__main__':
    sys.exit(main())
