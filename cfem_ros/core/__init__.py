# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The numerical core: bodies, joints and their releases, simulated exactly.

Its subpackages follow the pipeline from a file to a run:
``fileio`` (files and YAML within bounds), ``native`` (the face of the
compiled core ``_kernel``, C++ in ``cpp/``, and what is computed with it
alone), ``scenario`` (scenario files to a model), ``model`` (the model as
plain data), ``engine`` (``Simulator``: a model in time) and ``run``
(sessions, inputs, batches, start checks); ``errors`` and ``rotations``
serve them all.

This layer imports nothing from the recording, study or ros layers, nor the
faces (``cli``, ``plots``), and never rclpy.
"""
