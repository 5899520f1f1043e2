# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""The ``wrenches`` section (SPEC sections 5, 7): scheduled loads, their tables and their times."""

from __future__ import annotations

from cfem_ros.core.fileio.messages import show
from cfem_ros.core.model.loads import Wrench
from cfem_ros.core.scenario import cgoffset
from cfem_ros.core.scenario.checker import body_of, Checker, one_of
import numpy as np

#: A wrench's start or end tied to a release (SPEC section 7).
TIED_KEYS = ('release', 'delay')
WRENCH_KEYS = ('name', 'body', 'point', 'force', 'moment', 'frame', 'start', 'end', 'stroke',
               'reacts_on')
TABLE_KEYS = ('against', 'table')


def parse_wrenches(check: Checker, doc, index: dict, bodies, frame_id: str, *,
                   releases=()) -> tuple:
    """Parse the scheduled loads (SPEC sections 5, 7); ``releases``: joints and groups."""
    if doc is None:
        return ()
    if not isinstance(doc, list):
        check.fail('wrenches', f'is {show(doc)}', 'a list of wrench mappings')
    wrenches = [_parse_wrench(check, k, spec, index, bodies, frame_id, releases)
                for k, spec in enumerate(doc)]
    seen = {}
    for k, wrench in enumerate(wrenches):
        if (wrench.body, wrench.name) in seen:
            check.fail(f'wrenches[{k}].name', f'{wrench.name!r} already names '
                       f'wrenches[{seen[wrench.body, wrench.name]}] on the same body',
                       'a name of its own (it becomes a topic name)')
        seen[wrench.body, wrench.name] = k
    return tuple(wrenches)


def _parse_wrench(check: Checker, k: int, spec, index: dict, bodies, frame_id: str,
                  releases=()) -> Wrench:
    key = f'wrenches[{k}]'
    spec = check.mapping(spec, key, WRENCH_KEYS, required=('body',))
    body = body_of(check, spec['body'], f'{key}.body', index)
    if bodies[body].fixed:
        check.fail(f'{key}.body', f'{show(spec["body"])} is fixed', 'a body that can move')
    if not bodies[body].dynamic:
        check.fail(f'{key}.body', f'{show(spec["body"])} is kinematic',
                   'a body moved by forces')
    name = check.name(spec.get('name', f'wrench{k}'), f'{key}.name')
    if name == 'wrench':
        check.fail(f'{key}.name', "'wrench' is the source of the wrench topic",
                   'another name')
    frame = spec.get('frame', bodies[body].name)
    if not isinstance(frame, str):   # a list or a mapping is no name (nor hashable)
        check.fail(f'{key}.frame', f'is {show(frame)}, not a name',
                   f'{frame_id} or one of ' + ', '.join(index))
    if frame == frame_id:
        frame_index = -1
    elif frame in index:
        frame_index = index[frame]
    else:
        check.fail(f'{key}.frame', f'{show(frame)} is neither the world frame nor a body',
                   f'{frame_id} or one of ' + ', '.join(index))
    point = cgoffset.from_cg(bodies[body], check.vector(spec.get('point', [0, 0, 0]),
                                                        f'{key}.point'))
    moment = check.vector(spec.get('moment', [0, 0, 0]), f'{key}.moment')
    if 'force' not in spec and 'moment' not in spec:
        check.fail(f'{key}.force', 'missing', 'a force or a moment')
    force_doc = spec.get('force', [0, 0, 0])
    table, against = np.zeros((0, 7)), None
    if isinstance(force_doc, dict):
        against, table = _parse_force_table(check, force_doc, f'{key}.force', moment)
        force, moment = np.zeros(3), np.zeros(3)
    else:
        force = check.vector(force_doc, f'{key}.force')
    start, start_release = _parse_time_or_release(check, spec.get('start', 0.0),
                                                  f'{key}.start', releases)
    end = end_release = None
    if isinstance(spec.get('end'), dict):
        end, end_release = _parse_time_or_release(check, spec['end'], f'{key}.end', releases)
        if end_release == start_release and end <= start:
            check.fail(f'{key}.end.delay', f'is {end:g}, not after the start delay {start:g}',
                       'a delay after the start, s')
    elif spec.get('end') is not None:
        end = check.number(spec['end'], f'{key}.end')
        if start_release is None and end <= start:
            check.fail(f'{key}.end', f'is {end:g}, not after start {start:g}',
                       'a time after start, s')
    stroke = None
    if spec.get('stroke') is not None:
        stroke = check.number(spec['stroke'], f'{key}.stroke', positive=True)
    reacts_on = -1
    if spec.get('reacts_on') is not None:
        reacts_on = body_of(check, spec['reacts_on'], f'{key}.reacts_on', index)
        if reacts_on == body:
            check.fail(f'{key}.reacts_on', f'is {show(spec["reacts_on"])}, the loaded body',
                       'another body (a load on itself cancels)')
    return Wrench(name=name, body=body, point=point, force=force, moment=moment,
                  frame=frame_index, start=start, end=end, stroke=stroke, reacts_on=reacts_on,
                  table=table, table_against=against, start_release=start_release,
                  end_release=end_release)


def _parse_force_table(check: Checker, doc, key: str, moment: np.ndarray):
    """Parse ``{against: time|stroke, table: [[x, fx, fy, fz], ...]}`` into (k, 7) rows."""
    doc = check.mapping(doc, key, TABLE_KEYS, required=TABLE_KEYS)
    against = doc['against']
    if against not in ('time', 'stroke'):
        check.fail(f'{key}.against', f'is {show(against)}',
                   'time (s from start) or stroke (m)')
    rows = doc['table']
    if not isinstance(rows, list) or len(rows) < 2:
        check.fail(f'{key}.table', f'is {show(rows)}',
                   'a list of at least 2 rows [x, fx, fy, fz]')
    table = np.zeros((len(rows), 7))
    for i, row in enumerate(rows):
        table[i, :4] = check.vector(row, f'{key}.table[{i}]', 4)
        table[i, 4:] = moment
        if against == 'stroke' and table[i, 0] < 0.0:
            check.fail(f'{key}.table[{i}][0]', f'is {table[i, 0]:g}', 'a stroke >= 0, m')
        if i and not table[i, 0] > table[i - 1, 0]:
            check.fail(f'{key}.table[{i}][0]', f'is {table[i, 0]:g}, not after the row '
                       f'before ({table[i - 1, 0]:g})', 'strictly increasing abscissae')
    return against, table


def _parse_time_or_release(check: Checker, value, key: str, releases):
    """Return (s, None) for a time, (delay, name) for ``{release: name, delay: s}``."""
    if not isinstance(value, dict):
        return check.number(value, key, minimum=0.0), None
    value = check.mapping(value, key, TIED_KEYS, required=('release',))
    name = value['release']
    if not isinstance(name, str) or name not in releases:
        check.fail(f'{key}.release', f'{show(name)} is not a joint or a release group',
                   one_of(releases) if releases else 'a joint or a release group (there '
                   'are none)')
    return check.number(value.get('delay', 0.0), f'{key}.delay', minimum=0.0), name
