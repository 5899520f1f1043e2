# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The compiled aerodynamic-table and shape-distance functions, vectorised (``cpp/aeroshapes.cpp``).

They live in the compiled core, ``cfem_ros.core._kernel``: ``multilinear``,
``isa``, ``aero_wrench`` and ``distance``, each over many states at once
(tests, sweep metrics, recordings); the step calls the same headers
(``cpp/aero.hpp``, ``cpp/distance.hpp``) directly.
"""

from __future__ import annotations


def load():
    """Return the module with ``multilinear``, ``isa``, ``aero_wrench`` and ``distance``."""
    from cfem_ros.core import _kernel
    return _kernel
