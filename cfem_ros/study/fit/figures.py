# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
A fit's figures: measured against fitted poses, and the residuals, per quantity.

Six panels each (x, y, z in m; roll, pitch, yaw in deg, Z-Y-X, of the
measured body relative to the reference, in its axes) against time from
the release the window names (or time, s, if it names none).
"""

from __future__ import annotations

import numpy as np

#: The panels' margins, fixed: tight_layout measured every label again and doubled a
#: figure's time (a fit's figures were half of a 3-parameter fit's wall time).
MARGINS = {'left': 0.09, 'right': 0.98, 'top': 0.93, 'bottom': 0.07, 'hspace': 0.12,
           'wspace': 0.25}
#: dots per inch, the figures' own from the start: saved at another, a figure is laid out
#: again (a quarter of its time), to the same pixels.
DPI = 110
QUANTITIES = (('x', 'm'), ('y', 'm'), ('z', 'm'), ('roll', 'deg'), ('pitch', 'deg'),
              ('yaw', 'deg'))


def relative_histories(fit, values, *times) -> list:
    """Return the six quantities (m, deg, Z-Y-X) of a flight's run at values, at each times."""
    run = fit.trajectories.run(values)   # one run for every set of times
    out = []
    for at in times:
        position, attitude = run.poses(at)
        out.append(np.hstack([position, attitude.as_euler('ZYX', degrees=True)[:, ::-1]]))
    return out


def _axes_time(window) -> tuple:
    release = window[2]
    if release is None:
        return 0.0, 'time (s)'
    return release, 'time from release (s)'


def _measured(data) -> np.ndarray:
    return np.hstack([data.position, data.attitude.as_euler('ZYX', degrees=True)[:, ::-1]])


def _title(fit) -> str:
    flight = fit.flight
    title = f'{flight.body} relative to {flight.relative_to} ({flight.relative_to} axes)'
    if len(fit.spec.flights) > 1:
        title += f', {flight.key}'
    return title


def _panels():
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    figure, axes = plt.subplots(3, 2, figsize=(11, 9), sharex=True, dpi=DPI)
    return plt, figure, [axes[k % 3, k // 3] for k in range(len(QUANTITIES))], axes[-1]


def _save(plt, figure, axes, bottom, label: str, title: str, path: str):
    for ax in axes:
        ax.grid(True, alpha=0.3)
    for ax in bottom:
        ax.set_xlabel(label)
    axes[0].legend(loc='best', fontsize=8)
    figure.suptitle(title)
    figure.subplots_adjust(**MARGINS)
    figure.savefig(path, dpi=DPI)
    plt.close(figure)


def draw_trajectory(fit, values, path: str):
    """Write a flight's (``FlightFit``) measured, start and fitted poses' figure."""
    data = fit.data
    zero, label = _axes_time(fit.window)
    start, end = fit.window[0], min(fit.window[1], fit.last)   # the runs end there
    dense = np.linspace(start, end, 400)
    (fitted,) = relative_histories(fit, values, dense)
    (before,) = relative_histories(fit, fit.spec.x0, dense)
    measured = _measured(data)
    plt, figure, axes, bottom = _panels()
    for k, (name, unit) in enumerate(QUANTITIES):
        ax = axes[k]
        ax.plot(data.time - zero, measured[:, k], '.', ms=3, color='black', label='measured')
        ax.plot(dense - zero, before[:, k], '--', color='tab:gray', label='start values')
        ax.plot(dense - zero, fitted[:, k], '-', color='tab:blue', label='fitted')
        ax.set_ylabel(f'{name} ({unit})')
    _save(plt, figure, axes, bottom, label, _title(fit), path)


def draw_residuals(fit, values, path: str):
    """Write a flight's (``FlightFit``) residuals' figure (measured - fitted, with ±1 sigma)."""
    data, flight = fit.data, fit.flight
    zero, label = _axes_time(fit.window)
    (fitted,) = relative_histories(fit, values, data.time)
    residual = _measured(data) - fitted
    residual[:, 3:] = (residual[:, 3:] + 180.0) % 360.0 - 180.0
    sigmas = [flight.sigma_position] * 3 + [flight.sigma_attitude_deg] * 3
    plt, figure, axes, bottom = _panels()
    for k, (name, unit) in enumerate(QUANTITIES):
        ax = axes[k]
        ax.axhspan(-sigmas[k], sigmas[k], color='tab:green', alpha=0.15, label='±1 sigma')
        ax.plot(data.time - zero, residual[:, k], '.', ms=3, color='black')
        ax.axhline(0.0, color='tab:blue', lw=0.8)
        ax.set_ylabel(f'measured - fitted {name} ({unit})')
    _save(plt, figure, axes, bottom, label, f'residuals: {_title(fit)}', path)
