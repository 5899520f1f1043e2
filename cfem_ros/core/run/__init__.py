# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Running a simulator: sessions fed with inputs on a sample grid, batches, start checks.

Modules: ``session`` (one run on its sample grid, paced by anyone),
``inputs`` (inputs and the queue of those held for later), ``batch``
(many copies of one model at once) and ``startcheck`` (what ``cfem-sim
check`` tells before a run).
"""
