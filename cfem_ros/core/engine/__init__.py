# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The engine: a model in time, in RK4 steps of the compiled core, with its releases.

Modules: ``simulator`` (``Simulator``: time and the step loop), the face of
the compiled core ``cfem_ros.core._kernel`` (``kernel``, and ``kernelcalls``
for the simulator's two calls), ``bodies`` (the initial state and the mass
table), ``topology`` (the rows of the active joints and their solve plan),
``dynamics`` (the equations of motion), ``releases`` and ``groups`` (release
triggers, groups and events), ``loads``, ``ties``, ``strokes``, ``aeropack``
and ``contacts`` (applied loads, ejectors, aero tables and shapes packed for
the kernel), ``braces`` (sway braces), ``aero`` and ``atmosphere`` (the air
each body sees, the events of leaving a table, the ISA as the kernel computes
it), ``motion`` and ``carrier`` (kinematic bodies), ``sampling`` (what a
sample shows) and ``roots`` (Brent's method).
"""
