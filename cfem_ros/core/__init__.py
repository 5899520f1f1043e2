# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The numerical core: bodies, joints and their releases, simulated exactly.

Modules: ``model`` (bodies, joints, the joint table), ``scenario`` (scenario
files to a model), ``rotations``, ``kernel`` (the compiled solve and step
loop, C++ in ``cpp/``), ``topology`` (the rows of the active joints and their solve plan),
``releases`` (release triggers and their location in a step), ``engine``
(``Simulator``: the state and its stepping), ``sampling`` (what a sample
shows), ``inputs`` and ``session`` (a run fed with inputs on a sample grid),
``batch`` (many copies at once), ``errors``.

This layer imports nothing from the recording, study or ros layers, nor the
faces (``cli``, ``plots``), and never rclpy.
"""
