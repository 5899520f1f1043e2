# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The input queue: inputs held for later come out in time order, ties in the order held.

And only when their time has come; an odometry message held for later is
made known to the carriers at once (for the cubic up to it) only with
interpolation on, and only if it could apply.
"""

import pathlib

from cfem_ros import load_scenario, Simulator
from cfem_ros.core.run.inputs import InputQueue, odometry_input, release_input, wrench_input

CONFIG = pathlib.Path(__file__).resolve().parents[2] / 'config'


def _store():
    return Simulator(load_scenario(str(CONFIG / 'store_separation.yaml')))


def test_inputs_come_out_in_time_order_ties_in_the_order_held():
    queue = InputQueue(_store())
    held = [wrench_input('store', [0, 0, 1.0], [0, 0, 0], 'world', time=0.3),
            release_input('pivot', time=0.1),
            wrench_input('store', [0, 0, 2.0], [0, 0, 0], 'world', time=0.3),
            wrench_input('store', [0, 0, 3.0], [0, 0, 0], 'world', time=0.2)]
    assert queue.next_time is None
    for item in held:
        queue.hold(item, item.time)
    assert queue.next_time == 0.1
    assert list(queue.due(0.05)) == []   # nothing before its time
    assert list(queue.due(0.2)) == [held[1], held[3]]
    assert queue.next_time == 0.3
    assert list(queue.due(0.3)) == [held[0], held[2]]   # same time: as held
    assert queue.next_time is None


def _carrier():
    return Simulator(load_scenario(str(CONFIG / 'store_release_from_pullup.yaml')))


def _odometry(sim, t, frame_id=None):
    return odometry_input('aircraft', [250.0 * t, 0, 0], [0, 0, 0, 1], [250.0, 0, 0],
                          [0, 0, 0], frame_id or sim.model.frame_id, time=t)


def test_odometry_held_for_later_is_known_to_the_carriers_only_when_interpolating():
    for interpolate in (True, False):
        sim = _carrier()
        queue = InputQueue(sim, interpolate_odometry=interpolate)
        queue.hold(_odometry(sim, 0.05), 0.05)
        assert (sim.carriers.known() != {}) == interpolate
    sim = _carrier()
    queue = InputQueue(sim)
    queue.hold(_odometry(sim, 0.05, frame_id='elsewhere'), 0.05)   # refused at its time
    assert sim.carriers.known() == {}
