# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The figures a flight-dynamics engineer looks at, from recordings (``cfem-sim plot``).

Every function returns a matplotlib Figure (Agg backend, no display needed);
``write_figures`` saves them as PNG. Release events are marked on every time
axis and in the 3D view.
"""

from __future__ import annotations

import os

from cfem_ros.core import rotations
from cfem_ros.core.engine.aero import outside_spans
from cfem_ros.core.errors import CfemError
from cfem_ros.recording.analysis import attitude_difference_deg, euler_continuous, Run
from cfem_ros.recording.comparison import pose_in
import matplotlib
matplotlib.use('Agg')
import matplotlib.pyplot as plt  # noqa: E402, I100 - after choosing the backend
import numpy as np  # noqa: E402, I100

AXES = ('x', 'y', 'z')
EULER = ('roll', 'pitch', 'yaw')
RATES = ('p', 'q', 'r')
QUATERNION = ('x', 'y', 'z', 'w')

#: Loads smaller than this fraction of a joint's largest load (forces, and
#: moments counted with a lever arm of 1 m) are rounding, drawn as zero.
ROUNDING = 1e-9
COLORS = ('tab:blue', 'tab:orange', 'tab:green', 'black')
DPI = 110


#: Releases closer than this fraction of the time axis get their labels one under another.
CLOSE_RELEASES = 0.15


def release_groups(run: Run) -> list:
    """
    Return the run's releases as (time, 'joint, joint', 'cause') groups, in time order.

    Joints released in the same instant (a group, or triggers met together)
    make one group: one mark and one label, not labels printed over each other.
    """
    groups = []
    for t, joint, cause in sorted(run.releases()):
        if groups and abs(t - groups[-1][0]) <= 1e-9 * max(1.0, abs(t)):
            groups[-1][1].append(joint)
            groups[-1][2].add(cause)
        else:
            groups.append((t, [joint], {cause}))
    return [(t, ', '.join(joints), ', '.join(sorted(causes))) for t, joints, causes in groups]


def _mark_releases(ax, run: Run, label: bool):
    span, previous, row = max(run.duration, 1e-9), None, 0
    for t, joints, cause in release_groups(run):
        ax.axvline(t, color='tab:red', linestyle='--', linewidth=1.0, alpha=0.8)
        if label:
            row = row + 1 if previous is not None and t - previous < CLOSE_RELEASES * span \
                else 0
            previous = t
            ax.annotate(f'{joints} released ({cause}) t = {t:.4f} s', xy=(t, 1.0),
                        xycoords=('data', 'axes fraction'), xytext=(3, -12 - 11 * row),
                        textcoords='offset points', color='tab:red', fontsize=8)


def _time_axes(fig, run: Run, rows: int):
    axes = fig.subplots(rows, 1, sharex=True)
    for i, ax in enumerate(axes):
        ax.grid(True, alpha=0.3)
        _mark_releases(ax, run, label=(i == 0))
        ax.set_xlim(0.0, max(run.duration, 1e-9))
    axes[-1].set_xlabel('time [s]')
    return axes


def _lines(ax, series, names, unit, title):
    """Plot component k of every (time, values, style, suffix) series in color k."""
    for k, name in enumerate(names):
        for t, values, style, suffix in series:
            ax.plot(t, values[:, k], style, color=COLORS[k], label=f'{name}{suffix}')
    ax.set_ylabel(unit)
    ax.set_title(title, fontsize=10, loc='left')
    ax.legend(loc='best', fontsize=8, ncol=len(names) * len(series))


def _one(t, values):
    return [(t, values, '-', '')]


def _two(ta, va, tb, vb, labels):
    return [(ta, va, '-', f' {labels[0]}'), (tb, vb, '--', f' {labels[1]}')]


def _attitude(ax, series, singular_tracks):
    """Draw attitudes as continuous Euler angles, or as quaternions where those are singular."""
    if not any(track.euler_singular for track in singular_tracks):
        _lines(ax, [(t, track.euler_continuous_deg, style, suffix)
                    for t, track, style, suffix in series], EULER, 'angle [deg]',
               'attitude: roll, pitch, yaw (Z-Y-X, continuous)')
        return
    _lines(ax, [(t, track.quaternion_continuous, style, suffix)
                for t, track, style, suffix in series], QUATERNION, 'quaternion',
           'attitude as a quaternion (body to world): pitch passes near +-90 deg, '
           'where roll and yaw are undefined')


def body_figure(run: Run, name: str):
    """CG position, attitude (continuous Z-Y-X angles, or a quaternion) and body rates."""
    track = run.bodies[name]
    fig = plt.figure(figsize=(10, 9), layout='constrained')
    fig.suptitle(f'{name}: motion of the CG and attitude ({os.path.basename(run.path)})')
    axes = _time_axes(fig, run, 3)
    t = track.time
    _lines(axes[0], _one(t, track.position), AXES, 'position [m]', 'CG position, world axes')
    _attitude(axes[1], [(t, track, '-', '')], [track])
    _lines(axes[2], _one(t, np.degrees(track.rates)), RATES, 'rate [deg/s]',
           'body rates p, q, r (body axes)')
    return fig


def _without_rounding(values: np.ndarray, scale: float) -> np.ndarray:
    """Return values with every number below ROUNDING x scale set to zero."""
    out = np.array(values, dtype=float, copy=True)
    out[np.abs(out) <= ROUNDING * scale] = 0.0
    return out


def _load_scales(force: np.ndarray, moment: np.ndarray):
    """Scales of a joint's force (N) and moment (N m, a 1 m lever arm on the force)."""
    biggest_force = float(np.nanmax(np.abs(force), initial=0.0))
    return biggest_force, max(float(np.nanmax(np.abs(moment), initial=0.0)), biggest_force)


def joint_figure(run: Run, name: str):
    """Constraint force and moment of one joint (on its child), with magnitudes."""
    track = run.joints[name]
    fig = plt.figure(figsize=(10, 7), layout='constrained')
    fig.suptitle(f'joint {name}: load on the child, world axes '
                 f'({os.path.basename(run.path)})')
    axes = _time_axes(fig, run, 2)
    scales = _load_scales(track.force, track.moment)
    for ax, values, scale, unit, title in (
            (axes[0], track.force, scales[0], 'force [N]', 'constraint force'),
            (axes[1], track.moment, scales[1], 'moment [N m]',
             'constraint moment about the joint point')):
        with_norm = _without_rounding(
            np.column_stack([values, np.linalg.norm(values, axis=1)]), scale)
        _lines(ax, _one(track.time, with_norm), AXES + ('magnitude',), unit, title)
        _zero_floor(ax, scale)
    return fig


def _zero_floor(ax, scale: float):
    """Keep a panel's y span at least ROUNDING x scale x 1e3, so rounding never fills it."""
    low, high = ax.get_ylim()
    floor = max(ROUNDING * scale * 1e3, 1e-300)
    if high - low < 2 * floor:
        middle = (high + low) / 2
        ax.set_ylim(middle - floor, middle + floor)


def applied_figure(run: Run, key: str):
    """Force and moment about the CG of one applied load source ('<body>/<source>')."""
    track = run.applied[key]
    body, source = key.split('/', 1)
    fig = plt.figure(figsize=(10, 7), layout='constrained')
    fig.suptitle(f'{source} on {body}: applied load, world axes '
                 f'({os.path.basename(run.path)})')
    axes = _time_axes(fig, run, 2)
    for ax, values, unit, title in ((axes[0], track.force, 'force [N]', 'applied force'),
                                    (axes[1], track.moment, 'moment [N m]',
                                     'applied moment about the CG')):
        with_norm = np.column_stack([values, np.linalg.norm(values, axis=1)])
        _lines(ax, _one(track.time, with_norm), AXES + ('magnitude',), unit, title)
    return fig


def _at(track, t):
    return np.array([np.interp(t, track.time, track.position[:, k]) for k in range(3)])


def _z_down(run: Run) -> bool:
    gravity = run.metadata.get('gravity', '')
    try:
        return float(gravity.strip('[]').split(',')[2]) > 0
    except (IndexError, ValueError):
        return False


def joint_points(run: Run) -> dict:
    """
    Return each joint's point, carried by its child body, over the run (world, m).

    The joint's anchor comes from the scenario named in the recording's
    metadata; without a readable scenario there are none (an empty dict).
    """
    try:
        from cfem_ros.core.scenario.parse import load_scenario
        model = load_scenario(run.metadata['scenario'])
    except (KeyError, CfemError):
        return {}
    out = {}
    for joint in model.joints:
        child = model.bodies[joint.child]
        track = run.bodies.get(child.name)
        if track is None or not len(track.time):
            continue
        local = rotations.matrices(child.orientation_xyzw[None])[0].T @ (
            joint.anchor - child.position)
        out[joint.name] = (track.position
                           + np.einsum('nij,j->ni', rotations.matrices(track.quaternion), local))
    return out


def trajectory_figure(run: Run):
    """3D CG trajectories of the moving bodies and joint points; start, release, end marked."""
    fig = plt.figure(figsize=(8, 8), layout='constrained')
    ax = fig.add_subplot(projection='3d')
    points = []
    for k, track in enumerate(run.moving_bodies()):
        color = f'C{k}'
        p = track.position
        ax.plot(p[:, 0], p[:, 1], p[:, 2], color=color, label=f'{track.name} CG')
        ax.scatter(*p[0], color=color, marker='o', s=30)
        ax.scatter(*p[-1], color=color, marker='s', s=30)
        points.append(p)
        for t, joint, _ in run.releases():
            if track.time[0] <= t <= track.time[-1]:
                ax.scatter(*_at(track, t), color='tab:red', marker='*', s=120)
    for k, (name, path) in enumerate(joint_points(run).items()):
        ax.plot(path[:, 0], path[:, 1], path[:, 2], ':', color=f'C{k + 5}', linewidth=1.5,
                label=f'joint {name} point (on its child)')
        points.append(path)
    for t, joints, cause in release_groups(run):
        ax.scatter([], [], [], color='tab:red', marker='*', s=120,
                   label=f'{joints} released ({cause}), t = {t:.4f} s')
    ax.scatter([], [], [], color='gray', marker='o', label='start')
    ax.scatter([], [], [], color='gray', marker='s', label='end')
    equal = True
    if points:
        equal = _limits(ax, np.vstack(points))
    ax.set_box_aspect((1, 1, 1))
    ax.set_xlabel('x [m]')
    ax.set_ylabel('y [m]')
    ax.set_zlabel('z [m]')
    down = _z_down(run)
    if down:
        ax.invert_zaxis()
    scales = 'equal scales' if equal else 'scales differ by axis (a long path)'
    ax.set_title(f'CG trajectories, world frame, {scales}{" (z down)" if down else ""}')
    ax.legend(loc='upper left', fontsize=8)
    return fig


#: A path longer than this many times its extent across it is drawn with its own scale
#: on each axis: at equal scales a separation of metres within a flight of hundreds
#: of metres is a single line.
LONG_PATH = 10.0


def _limits(ax, every: np.ndarray) -> bool:
    """Set a 3D axes' limits around points (n, 3): equal scales unless the path is long."""
    center = (every.max(axis=0) + every.min(axis=0)) / 2
    spans = np.ptp(every, axis=0)
    across = np.sort(spans)[1]   # the middle span: across the path's length
    if spans.max() <= LONG_PATH * max(across, 1e-3):
        half = max(spans.max() / 2, 1e-3) * 1.05
        for setter, c in zip((ax.set_xlim, ax.set_ylim, ax.set_zlim), center):
            setter(c - half, c + half)
        return True
    floor = max(across / 2, 1e-3)
    for setter, c, span in zip((ax.set_xlim, ax.set_ylim, ax.set_zlim), center, spans):
        half = max(span / 2, floor) * 1.05
        setter(c - half, c + half)
    return False


#: Smallest span of a relative-trajectory axis, m.
MIN_SPAN = 0.1


def relative_trajectory_figure(run: Run):
    """CG trajectories in the carrier's frame (x forward, z up or down as recorded)."""
    fig, axes = plt.subplots(1, 2, figsize=(12, 5.5), layout='constrained')
    for k, track in enumerate(run.relative.values()):
        p = track.position
        label = f'{track.name} in {track.reference} axes'
        for ax, (i, j) in zip(axes, ((0, 2), (1, 2))):
            ax.plot(p[:, i], p[:, j], color=f'C{k}', label=label, zorder=2)
            # hollow start and end marks above the release star, which may share the spot
            for row, marker in ((0, 'o'), (-1, 's')):
                ax.scatter(p[row, i], p[row, j], facecolors='none', edgecolors=f'C{k}',
                           marker=marker, s=70, linewidths=1.5, zorder=4)
            for t, _, _ in release_groups(run):
                if len(track.time) and track.time[0] <= t <= track.time[-1]:
                    at = [np.interp(t, track.time, p[:, c]) for c in (i, j)]
                    ax.scatter(*at, color='tab:red', marker='*', s=120, zorder=3)
    for ax, (a, b) in zip(axes, (('x', 'z'), ('y', 'z'))):
        ax.set_xlabel(f'{a} [m]')
        ax.set_ylabel(f'{b} [m]')
        # at least MIN_SPAN each way: rounding is not drawn as motion
        center = (np.mean(ax.get_xlim()), np.mean(ax.get_ylim()))
        ax.update_datalim([[c - MIN_SPAN / 2 for c in center], [c + MIN_SPAN / 2 for c in center]])
        ax.autoscale_view()
        ax.set_aspect('equal', adjustable='datalim')
        ax.grid(True, alpha=0.3)
        if _z_down(run):
            ax.invert_yaxis()
    axes[0].set_title('relative to the carrier: side view (x-z)')
    axes[1].set_title('relative to the carrier: front view (y-z)')
    for t, joints, cause in release_groups(run):
        axes[0].scatter([], [], color='tab:red', marker='*', s=120,
                        label=f'{joints} released ({cause}), t = {t:.4f} s')
    for marker, label in (('o', 'start'), ('s', 'end')):
        axes[0].scatter([], [], facecolors='none', edgecolors='gray', marker=marker, s=70,
                        linewidths=1.5, label=label)
    # below the panels, where it hides no mark
    fig.legend(*axes[0].get_legend_handles_labels(), loc='outside lower center', fontsize=8,
               ncol=4)
    return fig


def compare_body_figure(a: Run, b: Run, name: str, labels=('A', 'B')):
    """Overlay one body's motion from two runs (A solid, B dashed), with A - B below."""
    ta, tb = a.bodies[name], b.bodies[name]
    fig = plt.figure(figsize=(10, 11), layout='constrained')
    fig.suptitle(f'{name}: {_which(a, b, labels)}')
    axes = _time_axes(fig, a, 4)
    _lines(axes[0], _two(ta.time, ta.position, tb.time, tb.position, labels), AXES,
           'position [m]', 'CG position, world axes')
    _attitude(axes[1], [(ta.time, ta, '-', f' {labels[0]}'), (tb.time, tb, '--', f' {labels[1]}')],
              [ta, tb])
    _lines(axes[2], _two(ta.time, np.degrees(ta.rates), tb.time, np.degrees(tb.rates),
                         labels), RATES, 'rate [deg/s]', 'body rates p, q, r (body axes)')
    t, diff = _difference(ta.time, ta.position, tb.time, tb.position)
    _lines(axes[3], _one(t, diff), AXES, 'position [m]',
           f'{labels[0]} - {labels[1]}: CG position (world axes); attitude angle (right)')
    t, angle = attitude_difference_deg(ta, tb)
    right = axes[3].twinx()
    right.plot(t, angle, color=COLORS[3], linestyle=':', label='attitude angle')
    right.set_ylabel('attitude angle [deg]')
    right.legend(loc='upper right', fontsize=8)
    return fig


def _which(a: Run, b: Run, labels) -> str:
    """Name the two runs of a comparison: which is solid, which dashed, and their files."""
    return (f'{labels[0]} (solid) = {os.path.basename(a.path)}, '
            f'{labels[1]} (dashed) = {os.path.basename(b.path)}')


def _difference(t_a, values_a, t_b, values_b):
    """Return A's times inside B's span and A - B there (B interpolated linearly)."""
    inside = (t_a >= t_b[0] - 1e-12) & (t_a <= t_b[-1] + 1e-12) if len(t_b) else t_a < -1
    t = t_a[inside]
    theirs = np.column_stack([np.interp(t, t_b, values_b[:, k])
                              for k in range(values_b.shape[1])])
    return t, values_a[inside] - theirs


def compare_joint_figure(a: Run, b: Run, name: str, labels=('A', 'B')):
    """Overlay one joint's load from two runs (A solid, B dashed)."""
    ja, jb = a.joints[name], b.joints[name]
    fig = plt.figure(figsize=(10, 7), layout='constrained')
    fig.suptitle(f'joint {name}: {_which(a, b, labels)}')
    axes = _time_axes(fig, a, 3)
    force_scale, moment_scale = _load_scales(np.vstack([ja.force, jb.force]),
                                             np.vstack([ja.moment, jb.moment]))
    _lines(axes[0], _two(ja.time, _without_rounding(ja.force, force_scale), jb.time,
                         _without_rounding(jb.force, force_scale), labels), AXES, 'force [N]',
           'constraint force')
    _lines(axes[1], _two(ja.time, _without_rounding(ja.moment, moment_scale), jb.time,
                         _without_rounding(jb.moment, moment_scale), labels), AXES,
           'moment [N m]', 'constraint moment about the joint point')
    t, diff = _difference(ja.time, ja.force, jb.time, jb.force)
    _lines(axes[2], _one(t, _without_rounding(diff, force_scale)), AXES, 'force [N]',
           f'{labels[0]} - {labels[1]}: constraint force')
    for ax, scale in zip(axes, (force_scale, moment_scale, force_scale)):
        _zero_floor(ax, scale)
    return fig


def air_figure(run, track):
    """Alpha, beta, Mach, dynamic pressure and coefficients of one body against time."""
    fig = plt.figure(figsize=(10, 11), layout='constrained')
    fig.suptitle(f'{track.name}: the air it saw ({os.path.basename(run.path)})')
    axes = _time_axes(fig, run, 5)
    t, v = track.time, track.values
    _lines(axes[0], _one(t, v['flow'][:, :2]), ('alpha', 'beta'), 'angle [deg]',
           'angle of attack and sideslip')
    _lines(axes[1], _one(t, v['flow'][:, 2:]), ('Mach',), 'Mach [-]', 'Mach number')
    _lines(axes[2], _one(t, v['air'][:, :1] / 1e3), ('q',), 'dynamic pressure [kPa]',
           'dynamic pressure')
    _lines(axes[3], _one(t, v['force_coefficients']), ('CX', 'CY', 'CZ'),
           'coefficient [-]', 'force coefficients, body axes')
    _lines(axes[4], _one(t, v['moment_coefficients']), ('Cl', 'Cm', 'Cn'),
           'coefficient [-]', 'moment coefficients about the actual CG, body axes')
    spans = outside_spans(run.events, track.name, run.duration)
    for ax in axes:
        for k, (start, end) in enumerate(spans):
            ax.axvspan(start, max(end, start + 1e-9 * max(run.duration, 1.0)),
                       color='tab:gray', alpha=0.2,
                       label='outside the tables' if k == 0 and ax is axes[0] else None)
    if spans:
        axes[0].legend(loc='best', fontsize=8)
    return fig


def save(fig, path: str) -> str:
    """Write a figure as PNG and close it; return the path."""
    fig.savefig(path, dpi=DPI)
    plt.close(fig)
    return path


def write_figures(run: Run, directory: str) -> list:
    """Write every figure of a run under directory; return the paths."""
    os.makedirs(directory, exist_ok=True)
    paths = []
    for track in run.moving_bodies():
        paths.append(save(body_figure(run, track.name),
                          os.path.join(directory, f'body_{track.name}.png')))
    for name in run.joints:
        paths.append(save(joint_figure(run, name), os.path.join(directory, f'joint_{name}.png')))
    for key in run.applied:
        paths.append(save(applied_figure(run, key), os.path.join(
            directory, f'applied_{key.replace("/", "_")}.png')))
    from cfem_ros.recording.airtracks import read_air
    for name, track in read_air(run.path, run.namespace, run.start_ns).items():
        paths.append(save(air_figure(run, track), os.path.join(directory, f'aero_{name}.png')))
    paths.append(save(trajectory_figure(run), os.path.join(directory, 'trajectories_3d.png')))
    if run.relative:
        paths.append(save(relative_trajectory_figure(run),
                          os.path.join(directory, 'trajectories_relative.png')))
    return paths


def write_comparison(a: Run, b: Run, directory: str, labels=('A', 'B')) -> list:
    """Write overlay figures of the bodies and joints two runs share; return the paths."""
    os.makedirs(directory, exist_ok=True)
    paths = []
    for track in a.moving_bodies():
        if track.name in b.bodies:
            paths.append(save(compare_body_figure(a, b, track.name, labels),
                              os.path.join(directory, f'compare_body_{track.name}.png')))
    for name in a.joints:
        if name in b.joints:
            paths.append(save(compare_joint_figure(a, b, name, labels),
                              os.path.join(directory, f'compare_joint_{name}.png')))
    return paths


def compare_relative_figure(a: Run, b: Run, name: str, reference: str, labels=('A', 'B')):
    """Overlay a body's pose in a carrier's axes from two runs: x, y, z, roll, pitch, yaw."""
    runs = [(pose_in(a, name, reference), '-', labels[0]),
            (pose_in(b, name, reference), '--', labels[1])]
    fig = plt.figure(figsize=(10, 13), layout='constrained')
    fig.suptitle(f'{name} in {reference} axes: {_which(a, b, labels)}')
    axes = _time_axes(fig, a, 6)
    units = ('x [m]', 'y [m]', 'z [m]', 'roll [deg]', 'pitch [deg]', 'yaw [deg]')
    for k, (ax, unit) in enumerate(zip(axes, units)):
        for (t, position, quat), style, label in runs:
            values = (position[:, k] if k < 3 else
                      euler_continuous(rotations.to_rpy_deg(quat))[:, k - 3])
            ax.plot(t, values, style, color=COLORS[k % 3], label=label)
        ax.set_ylabel(unit)
        ax.legend(loc='best', fontsize=8, ncol=2)
    axes[0].set_title(f'CG and attitude (Z-Y-X) relative to {reference}', fontsize=10,
                      loc='left')
    return fig


def write_relative_comparison(a: Run, b: Run, reference: str, directory: str,
                              labels=('A', 'B')) -> list:
    """Write the six-panel sheet of each body both runs give in reference's axes."""
    os.makedirs(directory, exist_ok=True)
    paths = []
    for name in sorted((set(a.bodies) | set(a.relative)) - {reference}):
        if pose_in(a, name, reference) is not None and pose_in(b, name, reference) is not None:
            paths.append(save(compare_relative_figure(a, b, name, reference, labels),
                              os.path.join(directory, f'compare_{name}_in_{reference}.png')))
    return paths
