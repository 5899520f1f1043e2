# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Numerical faults are detected and reported, never recorded as plausible numbers.

Each case fails with ``status = 'failed'`` and a message with the time and
the reason, returns and records no non-finite number, and ``cfem-sim run``
exits 1 leaving a recording that both MCAP readers read back.
"""

import dataclasses
import json
import math

from cfem_ros import cli, parse_scenario, Simulator
from cfem_ros.cli.common import EXIT_BAD_INPUT, EXIT_FAILED
from cfem_ros.core._kernel import testing
from cfem_ros.core.engine import sampling
from cfem_ros.core.engine.kernelcalls import DIVERGENCE_VIOLATION, kernel_error
from cfem_ros.core.errors import CfemError, InputError, ScenarioError
from cfem_ros.core.native import kernel
from cfem_ros.core.run.inputs import apply_input, validate_input, wrench_input
from cfem_ros.core.run.session import Session
from cfem_ros.recording.container import Recorder
from cfem_ros.recording.msgdefs import DEFINITIONS
from cfem_ros.recording.recorder import StateRecorder
from cfem_ros.recording.replay import read_inputs
from mcap.writer import Writer
import numpy as np
import pytest
from recordings import fields, read_checked
import yaml


def fixed_beam(mass):
    return {'name': 'beam', 'duration': 0.05, 'bodies': {
        'wall': {'fixed': True},
        'beam': {'mass': mass, 'inertia': [0.5, 16.9, 16.9], 'position': [1, 0, 0]}},
        'joints': {'weld': {'type': 'fixed', 'parent': 'wall', 'child': 'beam',
                            'anchor': [0, 0, 0]}}}


def pendulum(axis=(0, 1, 0), mass=3.0):
    return {'name': 'pendulum', 'duration': 0.05, 'bodies': {
        'ground': {'fixed': True},
        'bar': {'mass': mass, 'inertia': [0.36, 0.36, 0.005], 'position': [0.6, 0, 0]}},
        'joints': {'pivot': {'type': 'hinge', 'parent': 'ground', 'child': 'bar',
                             'anchor': [0, 0, 0], 'axis': list(axis)}}}


def chain(m1, m2, dt=0.001):
    return {'name': 'chain', 'duration': 1.0, 'dt': dt, 'bodies': {
        'ground': {'fixed': True},
        'a': {'mass': m1, 'inertia': [0.1 * m1] * 3, 'position': [0.5, 0, 0]},
        'b': {'mass': m2, 'inertia': [0.1 * m2] * 3, 'position': [1.5, 0, 0]}},
        'joints': {
            'j1': {'type': 'hinge', 'parent': 'ground', 'child': 'a', 'anchor': [0, 0, 0],
                   'axis': [0, 1, 0]},
            'j2': {'type': 'hinge', 'parent': 'a', 'child': 'b', 'anchor': [1, 0, 0],
                   'axis': [0, 1, 0]}}}


def free_body(name='store'):
    return {'name': 'free', 'duration': 3.0, 'bodies': {
        name: {'mass': 1.0, 'inertia': [1, 1, 1]}}}


def assert_finite_recording(path):
    """Read a recording with both readers; assert every number in it is finite."""
    _, _, messages = read_checked(str(path))
    for topic, _, _, message in messages:
        numbers = [v for v in fields(message) if isinstance(v, float)]
        assert all(math.isfinite(v) for v in numbers), (topic, numbers)
    return messages


def cli_run(tmp_path, capsys, doc, *options):
    """Run ``cfem-sim run`` in-process; return (status, stderr, recording path)."""
    scenario = tmp_path / 'scenario.yaml'
    scenario.write_text(yaml.safe_dump(doc))
    out = tmp_path / 'run.mcap'
    status = cli.main(['run', str(scenario), '-o', str(out), *options])
    return status, capsys.readouterr().err, out


def session_run(path, doc, duration=None, rate_hz=100.0):
    """Run a scenario through Session, recorded to path; return the simulator."""
    sim = Simulator(parse_scenario(doc))
    with Recorder(str(path)) as recorder:
        session = Session(sim, rate_hz=rate_hz, duration=duration or sim.model.duration,
                          outputs=[StateRecorder(recorder, sim)])
        session.run()
    assert_finite_recording(path)
    return sim


# --------------------------------------------------- failures at the first sample

FIRST_SAMPLE = {
    'mass 1e308 on a fixed joint: weld load overflows': (
        fixed_beam(1e308), 'joint loads are not finite'),
    'mass 1e308 on a hinge': (pendulum(mass=1e308), ''),
}


@pytest.mark.parametrize('case', FIRST_SAMPLE)
def test_a_fault_at_the_first_sample_fails_cleanly(case, tmp_path, capsys):
    doc, reason = FIRST_SAMPLE[case]
    try:
        sim = session_run(tmp_path / 'session.mcap', doc)
    except ScenarioError:
        # a loader that refuses the scenario is as clean: one line, exit 2, nothing run
        status, err, out = cli_run(tmp_path, capsys, doc)
        assert status == EXIT_BAD_INPUT and err.count('\n') == 1 and not out.exists()
        return
    assert sim.status == 'failed'
    assert sim.message.startswith('at t = 0 s: ') and reason in sim.message
    with pytest.raises(sampling.NumericalFailure) as failure:
        sim.outputs()
    assert isinstance(failure.value, CfemError)   # the root of every error cfem_ros raises
    status, err, out = cli_run(tmp_path, capsys, doc)
    assert status == EXIT_FAILED
    assert 'Traceback' not in err and 'the run failed at t = 0 s' in err
    assert_finite_recording(out)


def with_mass(doc, body, mass):
    """Parse a scenario, then give one body a mass (and inertia) the loader would refuse."""
    model = parse_scenario(doc)
    bodies = list(model.bodies)
    i = model.body_index(body)
    scale = mass / bodies[i].mass
    bodies[i] = dataclasses.replace(bodies[i], mass=mass, inertia=bodies[i].inertia * scale)
    return dataclasses.replace(model, bodies=tuple(bodies))


def test_a_huge_axis_is_normalised_and_runs():
    sim = Simulator(parse_scenario(pendulum(axis=(0, 1e200, 0))))
    reference = Simulator(parse_scenario(pendulum(axis=(0, 1, 0))))
    assert sim.advance_to(0.5) and reference.advance_to(0.5)
    np.testing.assert_array_equal(sim.y, reference.y)


def test_non_finite_loads_are_caught_inside_the_kernel_sample_path():
    # a sample's joint loads overflow while the state is finite (the body is welded);
    # the loader refuses such a mass, the engine must still not record the overflow
    with pytest.raises(ScenarioError, match='expected a mass from'):
        parse_scenario(fixed_beam(1e308))
    sim = Simulator(with_mass(fixed_beam(1.0), 'beam', 1e308))
    assert np.isfinite(sim.y).all()
    grid = sampling.SampleGrid(100.0)
    rows = np.full((8, sim.sampling.outputs_size()), 7.0)
    grid.reset(0, rows)
    assert sim.advance_to(0.05, samples=grid) is False
    assert grid.taken == 0 and sim.t == 0.0
    assert sim.reason == sampling.LOADS_NOT_FINITE
    # a model check cannot analyse (issue 46.4): ended at its start, its message is check's
    assert sim.message == sim.refusal == (
        "scenario 'beam': the joints cannot be analysed at t = 0 (LinAlgError: Eigenvalues "
        'did not converge); expected a regular configuration')
    with pytest.raises(sampling.NumericalFailure, match='not finite'):
        sim.joint_wrenches()


def test_a_mass_whose_inverse_overflows_is_refused():
    with pytest.raises(ScenarioError, match=r'bodies\.beam\.mass: is .*e-321 kg; expected a mass'):
        parse_scenario(fixed_beam(1e-320))
    with pytest.raises(ScenarioError, match=r'bodies\.beam\.mass: is .*e-32\d kg, whose inverse'):
        Simulator(with_mass(fixed_beam(1.0), 'beam', 1e-320))


# ------------------------------------------------------ failures during the run

def test_a_step_too_large_for_the_chain_fails_with_the_violation(tmp_path, capsys):
    # the loader accepts dt = 0.2 s (baumgarte scaled to it); the swing diverges
    # (samples at 5 Hz, so that they do not cut the steps)
    sim = session_run(tmp_path / 'session.mcap', chain(1.0, 1.0, dt=0.2), duration=3.0,
                      rate_hz=5.0)
    assert sim.status == 'failed'
    assert sim.message.startswith(f'at t = {sim.t:.9g} s: constraint violation')
    assert f'exceeds {DIVERGENCE_VIOLATION:g}' in sim.message
    assert sim.t > 0 and sim.max_violation <= DIVERGENCE_VIOLATION
    status, err, out = cli_run(tmp_path, capsys, chain(1.0, 1.0), '--dt', '0.2',
                               '--duration', '3', '--rate', '5')
    assert status == EXIT_FAILED and 'constraint violation' in err
    messages = assert_finite_recording(out)
    stamps = [log_time for topic, log_time, _, _ in messages if topic.endswith('a/pose')]
    assert len(stamps) > 1 and max(stamps) - min(stamps) <= sim.t * 1e9 + 1
    (error,) = [json.loads(m.data) for topic, _, _, m in messages if topic.endswith('/events')]
    assert error['event'] == 'error' and 'constraint violation' in error['message']
    assert error['time'] == pytest.approx(sim.t)


def test_a_huge_input_sends_a_body_to_infinity_and_fails(tmp_path):
    # 2e307 N on 1 kg: RK4's sum of six stage velocities overflows at v = 3e307 m/s, t = 1.5 s
    # (held through the API: an input message beyond 1e9 N is not applied, issue 41.4)
    push = wrench_input('store', [2e307, 0, 0], [0, 0, 0], 'world', time=0.0)
    sim = Simulator(parse_scenario(free_body()))
    with pytest.raises(ValueError, match='at most 1e\\+09'):
        validate_input(sim, push)
    sim.set_wrench('store', [2e307, 0, 0], [0, 0, 0])
    out = tmp_path / 'run.mcap'
    with Recorder(str(out)) as recorder:
        session = Session(sim, rate_hz=100.0, duration=3.0,
                          outputs=[StateRecorder(recorder, sim)])
        session.run()
    assert sim.status == 'failed'
    assert 1.45 < sim.t < 1.55
    assert sim.message == (f'at t = {sim.t:.9g} s: the state is no longer finite '
                           '(the system diverged)')
    assert np.isfinite(sim.y).all()
    messages = assert_finite_recording(out)
    assert len([m for m in messages if m[0].endswith('store/pose')]) == session.samples > 145


@pytest.mark.parametrize('value', [math.nan, math.inf])
def test_a_non_finite_number_anywhere_in_the_state_fails_the_step(value):
    # two free bodies: 26 numbers, checked four at a time and the last two one by one
    bodies = {name: {'mass': 1.0, 'inertia': [1, 1, 1], 'position': [x, 0, 0]}
              for name, x in (('a', 1.0), ('b', 3.0))}
    model = parse_scenario({'name': 'two', 'duration': 0.01, 'bodies': bodies, 'joints': {}})
    for k in range(26):
        sim = Simulator(model)
        sim.y[k] = value
        assert not sim.advance_to(0.01)
        assert sim.message == 'at t = 0 s: the state is no longer finite (the system diverged)', k


def test_a_universal_joint_at_parallel_axes_is_reported():
    # the joint keeps its axes perpendicular, so only drift takes them parallel:
    # put the bar there (turned 90 deg about z, its y axis along the cross's x)
    doc = {'name': 'hooke', 'duration': 1.0, 'bodies': {
        'ground': {'fixed': True},
        'bar': {'mass': 3.0, 'inertia': [0.3625, 0.3625, 0.005], 'position': [0, 0, -0.6]}},
        'joints': {'hooke': {'type': 'universal', 'parent': 'ground', 'child': 'bar',
                             'anchor': [0, 0, 0], 'axis': [1, 0, 0], 'axis2': [0, 1, 0]}}}
    for angle in (90.0, 89.99):
        sim = Simulator(parse_scenario(doc))
        half = math.radians(angle) / 2
        sim.y[8:12] = [0.0, 0.0, math.sin(half), math.cos(half)]
        assert sim.advance_to(0.01) is False
        assert sim.status == 'failed' and sim.message.startswith(f'at t = {sim.t:.9g} s: ')
        assert 'singular' in sim.message or 'constraint violation' in sim.message
        assert sim.t < 0.01 and np.isfinite(sim.y).all()


def test_a_light_and_a_heavy_body_on_one_chain_stay_exact():
    # 1e-9 and 1e9 kg: the loader refuses the light one (below 1e-6 kg); given to the
    # engine anyway, the articulated recursion stays accurate (no false alarm),
    # checked on the joints and on the energy, which only gravity works on
    with pytest.raises(ScenarioError, match='bodies.a.mass'):
        parse_scenario(chain(1e-9, 1e9))
    sim = Simulator(with_mass(chain(1e-6, 1e9), 'a', 1e-9))

    def energy():
        e = 0.0
        for i, body in enumerate(sim.model.bodies):
            if not body.fixed:
                e += 0.5 * body.mass * sim.velocity[i] @ sim.velocity[i]
                e += 0.5 * sim.rates[i] @ body.inertia @ sim.rates[i]
                e -= body.mass * sim.gravity @ sim.position[i]
        return e

    start = energy()
    assert sim.advance_to(1.0) and sim.status == 'running'
    assert sim.max_violation < 1e-8
    assert abs(energy() - start) < 1e-8 * 1e9 * 9.81 * 1.5
    force, moment = sim.joint_wrenches()
    assert np.isfinite(force).all() and np.isfinite(moment).all()


def test_an_ill_conditioned_pivot_is_singular():
    # a 2x2 free-motion block with det / (a00 a11) = 1e-14: refused; 1e-6: solved
    out = np.empty((3, 3))
    for ratio, ok in ((1e-14, False), (1e-6, True)):
        a = np.array([[1.0, 0, 0], [math.sqrt(1 - ratio), 1.0, 0], [0, 0, 0]])
        assert testing.inverse(a, 2, out) is ok
    full = np.empty((6, 6))
    m = np.eye(6)
    m[0, 1] = m[1, 0] = 1 - 1e-15
    assert not testing.cholesky(m, 6, full)
    assert testing.cholesky(np.diag([1e-9, 1e-9, 1e-9, 1e9, 1e9, 1e9]), 6, full)


# --------------------------------------------------------------- the Python API

def test_advance_to_refuses_an_earlier_or_non_finite_target():
    sim = Simulator(parse_scenario(pendulum()))
    assert sim.advance_to(0.02)
    for bad in (0.01, math.inf, math.nan, -math.inf):
        with pytest.raises(ValueError, match='t_target'):
            sim.advance_to(bad)
    with pytest.raises(ValueError, match='limit'):
        sim.advance_to(0.03, limit=math.nan)
    assert sim.t == 0.02 and sim.status == 'running'
    assert sim.advance_to(0.02) and sim.advance_to(0.03, limit=math.inf) and sim.t == 0.03


def test_a_body_named_as_the_world_frame_is_loaded_in_world_axes():
    model = parse_scenario(free_body())
    body = dataclasses.replace(model.bodies[0], name=model.frame_id,
                               orientation_xyzw=np.array([0.0, 0.0, math.sqrt(0.5),
                                                          math.sqrt(0.5)]))
    sim = Simulator(dataclasses.replace(model, bodies=(body,)))
    apply_input(sim, wrench_input(model.frame_id, [2.0, 0, 0], [0, 0, 0], model.frame_id))
    sim.advance_to(0.5)
    # world x, not the body's x (world y after the 90 deg yaw)
    assert sim.velocity[0] == pytest.approx([1.0, 0, -9.80665 * 0.5], abs=1e-12)


# ------------------------------------------------------------------ input logs

def truncated_wrench_log(path):
    with open(path, 'wb') as stream:
        writer = Writer(stream)
        writer.start('ros2', 'cfem_ros test')
        schema = writer.register_schema(
            'geometry_msgs/msg/WrenchStamped', 'ros2msg',
            DEFINITIONS['geometry_msgs/msg/WrenchStamped'].encode())
        channel = writer.register_channel('/cfem/bodies/store/wrench', 'cdr', schema)
        # CDR header, a stamp and the frame_id's length, then nothing
        writer.add_message(channel, log_time=1000, publish_time=1000,
                           data=b'\x00\x01\x00\x00' + b'\x00' * 8 + b'\x06\x00\x00\x00')
        writer.finish()


def test_a_truncated_payload_in_an_input_log_is_an_input_error(tmp_path, capsys):
    log = tmp_path / 'inputs.mcap'
    truncated_wrench_log(log)
    with pytest.raises(InputError, match='a message cannot be decoded'):
        read_inputs(str(log))
    status, err, out = cli_run(tmp_path, capsys, free_body(), '--inputs', str(log))
    assert status == EXIT_BAD_INPUT
    assert err.startswith(f'ERROR: {log}: a message cannot be decoded') and err.count('\n') == 1
    assert not out.exists()


def test_a_run_never_ends_on_a_state_beyond_the_tolerance():
    # the kernel checks the violation at each step's start; the state a call ends on
    # is checked too, so a run that stops right where the swing diverges fails there
    diverging = Simulator(parse_scenario(chain(1.0, 1.0, dt=0.2)))
    assert not diverging.advance_to(3.0)
    stop = diverging.t          # the last state whose step started within the tolerance
    sim = Simulator(parse_scenario(chain(1.0, 1.0, dt=0.2)))
    assert sim.advance_to(stop - 0.2)
    assert sim.constraint_violation() <= DIVERGENCE_VIOLATION
    ok = sim.advance_to(stop)
    assert sim.t == stop
    assert not ok and sim.status == 'failed', sim.constraint_violation()
    assert 'constraint violation' in sim.message


def test_every_failure_code_of_the_kernel_is_a_cfem_error_in_our_words():
    # the codes of cpp/common.hpp, 0 to 9: three end a call normally, the rest fail the run
    normal = {kernel.REACHED, kernel.CONDITION, kernel.ROWS_FULL}
    failing = {kernel.NOT_FINITE, kernel.VIOLATION, kernel.SINGULAR, kernel.LOADS_NOT_FINITE,
               kernel.NAN_VALUE, kernel.SAME_SIGNS, kernel.NO_CONVERGENCE}
    assert normal | failing == set(range(10)) and not normal & failing
    assert all(kernel_error(code, 0.0) is None for code in normal)
    messages = {}
    for code in failing:
        failure = kernel_error(code, 2.5e-4)
        assert isinstance(failure, sampling.NumericalFailure) and isinstance(failure, CfemError)
        messages[code] = str(failure)
    assert len(set(messages.values())) == len(failing)   # each code says what it means
    # the value is where the search stopped (s into the step), or the violation
    assert '0.00025 s into the step' in messages[kernel.NAN_VALUE]
    assert messages[kernel.NO_CONVERGENCE].startswith(
        'the crossing of a release condition or stroke was not found in '
        f'{kernel.CROSSING_MAXITER} iterations (stopped at 0.00025 s into the step)')
    assert messages[kernel.VIOLATION].startswith(
        f'constraint violation 0.00025 exceeds {DIVERGENCE_VIOLATION:g}')
    # scipy's brentq's own words ("f(a) and f(b) must have different signs", "Failed to
    # converge after ...") are not passed through
    assert not [m for m in messages.values() if 'f(a)' in m or 'converge after' in m]
