# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The figure of the air each body saw (SPEC section 10), drawn by ``cfem-sim plot``.

One figure per body with aero tables: angle of attack and sideslip, Mach,
dynamic pressure, and the force and moment coefficients (moments about the
actual CG) against time, the releases marked, and the times the body was
outside its tables' range shaded.
"""

from __future__ import annotations

import os

from cfem_ros.core.aero import outside_spans
from cfem_ros.plots import _lines, _one, _time_axes, plt


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
