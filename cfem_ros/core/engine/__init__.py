# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The engine: a model in time, in RK4 steps of the compiled core, with its releases.

Modules: ``simulator`` (``Simulator``: a run's time and status),
``stepping`` (``Stepper``: the simulator's step loop),
``kernelcalls`` (the simulator's two calls of the compiled core, whose face
is ``cfem_ros.core.native.kernel``), ``bodies`` (the initial state and the
mass table), ``topology`` (the rows of the active joints and their solve
plan), ``dynamics`` (the equations of motion), ``jointset`` (the joints of a
run, which are active), ``releases`` and ``groups`` (release triggers,
groups and events), ``watch`` (braces, contact pairs and aero tables
watched), ``loads``, ``ties``, ``strokes`` and
``aeropack`` (applied loads, ejectors and aero tables packed for the kernel;
shapes are packed by ``cfem_ros.core.native.contacts``), ``braces`` (sway
braces), ``aero`` (the air each body sees, the events of leaving a table),
``carrier`` (kinematic bodies; their trajectories are
``cfem_ros.core.native.motion``), ``sampling`` (what a sample shows),
``startcheck`` (can a run start: what ``cfem-sim check`` refuses, and the
same words for a run that ends within its first step) and
``events`` (statuses, event kinds and failures as enums; an event as a line).
"""
