# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Running a simulator: sessions fed with inputs on a sample grid, batches.

Modules: ``session`` (one run on its sample grid, paced by anyone),
``inputs`` (inputs and the queue of those held for later) and ``batch``
(many copies of one model at once). What ``cfem-sim check`` tells before a
run is the engine's (``cfem_ros.core.engine.startcheck``).
"""
