# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The separation figures in a carrier's axes (``cfem-sim plot RUN --relative-to BODY``).

``trajectory_sheet``: six panels, x, y, z (m) and roll, pitch, yaw (deg,
Z-Y-X) of each free body relative to BODY, in BODY's axes, against time
from the first release, every release marked. ``snapshots_figure``: the
bodies' outlines (``outlines``) in side, top and front views of BODY's
axes at the release and at chosen times after it. Everything is composed
from the recorded poses (``recording.relative``).
"""

from __future__ import annotations

import os

from cfem_ros.core.errors import CfemError
from cfem_ros.plots import _z_down, release_groups, save
from cfem_ros.recording.relative import relative_track, release_time
from cfem_ros.separation import outlines
import matplotlib
matplotlib.use('Agg')
import matplotlib.pyplot as plt  # noqa: E402, I100 - after choosing the backend
import numpy as np  # noqa: E402, I100

#: A body that moves less than this relative to BODY (m, and deg) is not drawn as free.
STILL = 1e-6
#: Least span of a position panel (m) and an angle panel (deg): rounding is not motion.
LEAST_SPAN = {'m': 0.01, 'deg': 0.1}
QUANTITIES = (('x', 'm'), ('roll', 'deg'), ('y', 'm'), ('pitch', 'deg'), ('z', 'm'),
              ('yaw', 'deg'))
VIEW_TITLES = {'side': 'side view (x-z)', 'top': 'top view (x-y)', 'front': 'front view (y-z)'}
AXIS_NAMES = 'xyz'


def free_bodies(run, reference: str) -> list:
    """Return the relative tracks of the bodies that move relative to reference."""
    out = []
    for name in run.bodies:
        if name == reference:
            continue
        track = relative_track(run, name, reference)
        if not len(track.time):
            continue
        moved = np.ptp(track.position, axis=0).max(initial=0.0)
        turned = np.ptp(track.euler_deg, axis=0).max(initial=0.0)
        if moved > STILL or turned > STILL:
            out.append(track)
    return out


def _origin(run) -> tuple:
    """Return (time origin, axis label): the first release, or the run's start."""
    released = release_time(run)
    if np.isnan(released):
        return 0.0, 'time [s] (nothing released: from the start)'
    return released, 'time from release [s]'


def trajectory_sheet(run, reference: str):
    """Draw x, y, z, roll, pitch, yaw of each free body in reference's axes against time."""
    tracks = free_bodies(run, reference)
    origin, xlabel = _origin(run)
    fig, axes = plt.subplots(3, 2, figsize=(11, 9), sharex=True, layout='constrained')
    fig.suptitle(f'separation trajectory relative to {reference}, {reference} axes '
                 f'({os.path.basename(run.path)})')
    for k, track in enumerate(tracks):
        values = np.column_stack([track.position, track.euler_deg])
        for ax, column in zip(axes.ravel(), (0, 3, 1, 4, 2, 5)):
            ax.plot(track.time - origin, values[:, column], color=f'C{k}', label=track.name)
    down = _z_down(run)
    for ax, (name, unit) in zip(axes.ravel(), QUANTITIES):
        ax.set_ylabel(f'{name} [{unit}]')
        ax.grid(True, alpha=0.3)
        for t, joints, cause in release_groups(run):
            ax.axvline(t - origin, color='tab:red', linestyle='--', linewidth=1.0)
        low, high = ax.get_ylim()
        if high - low < LEAST_SPAN[unit]:
            middle = (low + high) / 2
            ax.set_ylim(middle - LEAST_SPAN[unit] / 2, middle + LEAST_SPAN[unit] / 2)
        if name == 'z' and down:
            ax.invert_yaxis()
            ax.set_ylabel('z [m] (down)')
    for t, joints, cause in release_groups(run):
        axes[0, 0].plot([], [], color='tab:red', linestyle='--',
                        label=f'{joints} released ({cause}), t = {t:.4f} s')
    for ax in axes[-1]:
        ax.set_xlabel(xlabel)
    if not tracks:
        axes[0, 0].text(0.5, 0.5, f'no body moves relative to {reference}',
                        transform=axes[0, 0].transAxes, ha='center')
    axes[0, 0].legend(fontsize=8, loc='best')
    return fig


def _shapes(run) -> dict:
    """Return each body's convex parts (body axes) from the recording's scenario."""
    from cfem_ros.core.model.shapes import default_shape
    from cfem_ros.core.scenario.parse import load_scenario
    path = run.metadata.get('scenario')
    if not path or not os.path.isfile(path):
        return {}
    try:
        model = load_scenario(path)
    except CfemError:
        return {}
    out = {}
    for body in model.bodies:
        shape = body.shape or default_shape(not body.dynamic, body.mass, body.inertia)
        out[body.name] = outlines.shape_parts(shape)
    return out


def _nearest(track, t: float) -> int:
    return int(np.argmin(np.abs(track.time - t)))


def snapshots_figure(run, reference: str, after=(0.1, 0.2, 0.3), title: str = ''):
    """
    Draw the bodies' outlines in side, top and front views of reference's axes.

    At the first release and ``after`` s after it (the nearest samples):
    each free body once per time, in colours from dark to light; the
    bodies that do not move relative to reference once, in grey. Without
    shapes (the scenario file is gone) each body is its CG.
    """
    shapes = _shapes(run)
    origin, _ = _origin(run)
    times = [0.0] + [float(s) for s in after]
    fig, axes = plt.subplots(1, 3, figsize=(15, 5.2), layout='constrained')
    fig.suptitle(f'{title + ": " if title else ""}outline snapshots in {reference} axes, s '
                 f'after {"release" if origin else "the start"} ({os.path.basename(run.path)})')
    free = {track.name: track for track in free_bodies(run, reference)}
    colors = plt.get_cmap('viridis')(np.linspace(0.0, 0.85, len(times)))
    extent = {view: [] for view in outlines.VIEWS}
    for ax, view in zip(axes, outlines.VIEWS):
        i, j = outlines.VIEWS[view]
        for name in run.bodies:
            if name in free:
                continue
            track = relative_track(run, name, reference)
            if not len(track.time):
                continue
            k = _nearest(track, origin)
            for ring in outlines.placed_outlines(shapes.get(name, []), track.position[k],
                                                 track.quaternion[k], view):
                ax.fill(ring[:, 0], ring[:, 1], facecolor=(0.6, 0.6, 0.6, 0.35),
                        edgecolor='0.3', linewidth=0.8)
        for name, track in free.items():
            for color, dt in zip(colors, times):
                k = _nearest(track, origin + dt)
                rings = outlines.placed_outlines(shapes.get(name, []), track.position[k],
                                                 track.quaternion[k], view)
                for ring in rings:
                    ax.plot(ring[:, 0], ring[:, 1], color=color, linewidth=1.4)
                    extent[view].append(ring)
                ax.plot(track.position[k, i], track.position[k, j], '+', color=color)
                extent[view].append(track.position[k:k + 1, [i, j]])
        ax.set_xlabel(f'{AXIS_NAMES[i]} [m]')
        ax.set_ylabel(f'{AXIS_NAMES[j]} [m]')
        ax.set_title(VIEW_TITLES[view], fontsize=10, loc='left')
        ax.set_aspect('equal', adjustable='box')
        ax.grid(True, alpha=0.3)
    _focus(axes, extent)
    if _z_down(run):
        axes[0].invert_yaxis()
        axes[2].invert_yaxis()
    for color, dt in zip(colors, times):
        axes[0].plot([], [], color=color, label=f't = {dt:g} s (t = {origin + dt:.4f} s)')
    axes[0].plot([], [], color='0.75', linewidth=6,
                 label=f'{reference} and the bodies still relative to it')
    fig.legend(*axes[0].get_legend_handles_labels(), loc='outside lower center', fontsize=8,
               ncol=len(times) + 1)
    return fig


def _focus(axes, extent: dict):
    """Centre each view on the free bodies (the carrier may be metres wide), with a margin."""
    for ax, view in zip(axes, outlines.VIEWS):
        if not extent[view]:
            continue
        every = np.vstack(extent[view])
        low, high = every.min(axis=0), every.max(axis=0)
        margin = max(0.25 * float(np.max(high - low)), 0.2)
        ax.set_xlim(low[0] - margin, high[0] + margin)
        ax.set_ylim(low[1] - margin, high[1] + margin)


def write_relative_figures(run, reference: str, directory: str, after=(0.1, 0.2, 0.3)) -> list:
    """Write the trajectory sheet and the snapshots under directory; return the paths."""
    os.makedirs(directory, exist_ok=True)
    return [save(trajectory_sheet(run, reference),
                 os.path.join(directory, f'separation_{reference}.png')),
            save(snapshots_figure(run, reference, after),
                 os.path.join(directory, f'snapshots_{reference}.png'))]
