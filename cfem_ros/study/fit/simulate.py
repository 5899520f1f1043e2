# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The simulated side of a fit: a scenario's run at given parameter values, as poses.

``Trajectories`` runs the fit's scenario with the parameters set (and the
measured inputs replayed, as ``cfem-sim run --inputs`` does), takes a
sample at every step, and gives the measured body's pose relative to the
reference at any time of the run: the position on a cubic spline through
the step samples, the attitude on scipy's ``RotationSpline`` (both pass
through the samples, so times on the step grid get the step's state).
Runs are independent: several threads may call one ``Trajectories``.
"""

from __future__ import annotations

from dataclasses import dataclass
import logging
import threading

from cfem_ros.core.engine.simulator import Simulator
from cfem_ros.core.run.session import Session
from cfem_ros.core.scenario.parse import parse_scenario
from cfem_ros.study.fit.flights import FitError, Flight
from cfem_ros.study.fit.measured import relative_poses
from cfem_ros.study.fit.spec import FitSpec
from cfem_ros.study.metrics import Collector
import numpy as np
from scipy.interpolate import CubicSpline
from scipy.spatial.transform import RotationSpline

#: The fit's runs log here (a replayed input refused is said once per run otherwise).
LOG = logging.getLogger('cfem_ros.fit.runs')


@dataclass
class Trajectory:
    """One run's relative poses (splines through the step samples) and releases."""

    position: CubicSpline
    attitude: RotationSpline
    end: float
    releases: dict
    status: str

    def poses(self, times: np.ndarray) -> tuple:
        """Return (positions (n, 3), Rotation (n)) at times within the run."""
        return self.position(times), self.attitude(times)


class Trajectories:
    """
    Run one flight's scenario at parameter values.

    Parameters
    ----------
    spec : FitSpec
    flight : Flight
        The flight whose scenario (with its ``set:``) runs, and whose body is read.
    inputs : list of Input
        Replayed in every run (``recording.replay.read_inputs``).
    interpolate_odometry : bool
        As ``cfem-sim run``'s ``--odometry``.
    duration : float
        s simulated per run.

    """

    def __init__(self, spec: FitSpec, flight: Flight, inputs=(),
                 interpolate_odometry: bool = True, duration: float = 0.0):
        self.spec = spec
        self.flight = flight
        self.inputs = list(inputs)
        self.interpolate = interpolate_odometry
        self.duration = duration
        self.runs = 0
        self._lock = threading.Lock()

    def run(self, values) -> Trajectory:
        """
        Run the scenario with the parameters at values.

        Raises
        ------
        FitError
            If the values make an invalid scenario, or the run fails or
            stops before its end (a contact).

        """
        spec, flight = self.spec, self.flight
        with self._lock:
            self.runs += 1
        shown = ', '.join(f'{p.path} = {v:.9g}' for p, v in zip(spec.parameters, values))
        if len(spec.flights) > 1:
            shown += f' ({flight.key})'
        try:
            model = parse_scenario(flight.document_with(spec.parameters, values),
                                   source=flight.scenario, duration=self.duration or None)
        except FitError:
            raise
        except Exception as err:   # noqa: B902 (the scenario's own refusal, with the values)
            raise FitError(spec.path, 'parameters', f'{shown} make the scenario invalid: '
                           f'{err}', 'bounds that keep the scenario valid') from err
        sim = Simulator(model, logger=LOG)
        collector = Collector(sim)
        session = Session(sim, rate_hz=1.0 / model.dt, duration=model.duration,
                          outputs=[collector], warn=LOG.warning,
                          interpolate_odometry=self.interpolate)
        for item in self.inputs:
            if item.time <= model.duration:
                session.submit(item, check=False)
        session.run()
        if sim.refusal:   # cfem-sim check refuses it (asked as its run ended at its start)
            raise FitError(spec.path, 'parameters', f'{shown} make the scenario invalid: '
                           f'{sim.refusal}', 'bounds that keep the scenario valid')
        if session.stopped:   # a failure, or a stop the scenario asks for: no trajectory
            raise FitError(spec.path, 'parameters', f'the run with {shown} failed '
                           f'{sim.message}', 'bounds within which the scenario runs')
        samples = collector.samples()
        times, position, quaternion = samples.bodies[flight.body]
        if flight.relative_to in samples.bodies:
            _, position_ref, quaternion_ref = samples.bodies[flight.relative_to]
            relative, attitude = relative_poses(position, quaternion, position_ref,
                                                quaternion_ref)
        else:   # the world frame
            relative, attitude = relative_poses(position, quaternion, np.zeros_like(position),
                                                np.tile([0.0, 0.0, 0.0, 1.0], (len(times), 1)))
        keep = np.concatenate([[True], np.diff(times) > 0])   # a release adds no sample
        releases = {}
        for t, joint, _ in samples.releases:
            releases.setdefault(joint, float(t))
        return Trajectory(CubicSpline(times[keep], relative[keep]),
                          RotationSpline(times[keep], attitude[keep]), float(times[-1]),
                          releases, sim.status)
