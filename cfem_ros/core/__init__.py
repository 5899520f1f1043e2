# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The numerical core: bodies, joints and their releases, simulated exactly.

Modules: ``model`` (bodies, joints, the joint table), ``scenario`` (scenario
files to a model), ``rotations``, ``kernel`` (the compiled solve and step
loop, C++ in ``cpp/``), ``bodies`` (the initial state and the mass table), ``topology`` (the
rows of the active joints and their solve plan), ``dynamics`` (the equations
of motion: derivative, RK4 step, velocity projection), ``releases`` (release
triggers, the active joints and the release events), ``carrier`` (kinematic
bodies and their odometry), ``engine`` (``Simulator``: time and the step
loop), ``sampling`` (what a sample shows), ``inputs`` (inputs and the queue of
those held for later) and ``session`` (a run fed with inputs on a sample
grid), ``batch`` (many copies at once), ``errors``.

This layer imports nothing from the recording, study or ros layers, nor the
faces (``cli``, ``plots``), and never rclpy.
"""
