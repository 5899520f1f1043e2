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


def draw(fit, values, trajectory_path: str, residuals_path: str):
    """Write a flight's (``FlightFit``) trajectory and residual figures."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    data, flight = fit.data, fit.flight
    measured = np.hstack([data.position,
                          data.attitude.as_euler('ZYX', degrees=True)[:, ::-1]])
    zero, label = _axes_time(fit.window)
    start, end = fit.window[0], min(fit.window[1], fit.last)   # the runs end there
    dense = np.linspace(start, end, 400)
    fitted_dense, fitted = relative_histories(fit, values, dense, data.time)
    (before,) = relative_histories(fit, fit.spec.x0, dense)
    title = f'{flight.body} relative to {flight.relative_to} ({flight.relative_to} axes)'
    if len(fit.spec.flights) > 1:
        title += f', {flight.key}'

    figure, axes = plt.subplots(3, 2, figsize=(11, 9), sharex=True)
    for k, (name, unit) in enumerate(QUANTITIES):
        ax = axes[k % 3, k // 3]
        ax.plot(data.time - zero, measured[:, k], '.', ms=3, color='black', label='measured')
        ax.plot(dense - zero, before[:, k], '--', color='tab:gray', label='start values')
        ax.plot(dense - zero, fitted_dense[:, k], '-', color='tab:blue', label='fitted')
        ax.set_ylabel(f'{name} ({unit})')
        ax.grid(True, alpha=0.3)
    for ax in axes[-1]:
        ax.set_xlabel(label)
    axes[0, 0].legend(loc='best', fontsize=8)
    figure.suptitle(title)
    figure.subplots_adjust(**MARGINS)
    figure.savefig(trajectory_path, dpi=110)
    plt.close(figure)

    residual = measured - fitted
    residual[:, 3:] = (residual[:, 3:] + 180.0) % 360.0 - 180.0
    sigmas = [flight.sigma_position] * 3 + [flight.sigma_attitude_deg] * 3
    figure, axes = plt.subplots(3, 2, figsize=(11, 9), sharex=True)
    for k, (name, unit) in enumerate(QUANTITIES):
        ax = axes[k % 3, k // 3]
        ax.axhspan(-sigmas[k], sigmas[k], color='tab:green', alpha=0.15, label='±1 sigma')
        ax.plot(data.time - zero, residual[:, k], '.', ms=3, color='black')
        ax.axhline(0.0, color='tab:blue', lw=0.8)
        ax.set_ylabel(f'measured - fitted {name} ({unit})')
        ax.grid(True, alpha=0.3)
    for ax in axes[-1]:
        ax.set_xlabel(label)
    axes[0, 0].legend(loc='best', fontsize=8)
    figure.suptitle(f'residuals: {title}')
    figure.subplots_adjust(**MARGINS)
    figure.savefig(residuals_path, dpi=110)
    plt.close(figure)
