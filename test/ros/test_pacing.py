# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""The node's pacing: simulated time against the wall clock, mid-run factor changes."""

import math

from cfem_ros.ros.pacing import WallPace


def test_a_new_factor_goes_on_from_where_the_clock_was():
    pace = WallPace(1.0)
    pace.start(100.0)
    assert pace.target(102.0) == 2.0
    pace.retime(102.0, sim_t=1.5, factor=0.5)   # the clock's 2 s, not the lagging sim's
    assert pace.target(106.0) == 4.0
    pace.retime(106.0, sim_t=3.0, factor=0.0)
    assert math.isinf(pace.target(200.0))


def test_pacing_again_starts_from_where_the_unpaced_run_is():
    pace = WallPace(0.0)
    pace.start(10.0)
    pace.retime(20.0, sim_t=7.25, factor=2.0)
    assert pace.target(21.0) == 9.25
