# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The numerical core: bodies, joints and their releases, simulated exactly.

Modules: ``model`` (bodies, joints, the joint table), ``scenario`` (scenario
files to a model), ``rotations``, ``kernel`` (the compiled solve and step
loop), ``topology`` (the rows of the active joints and their solve plan),
``releases`` (release triggers and their location in a step), ``engine``
(``Simulator``: the state and its stepping), ``sampling`` (what a sample
shows), ``inputs`` and ``session`` (a run fed with inputs on a sample grid),
``batch`` (many copies at once), ``errors``.

This layer imports nothing from the recording, study or ros layers, nor the
faces (``cli``, ``plots``), and never rclpy.
"""

import sys


class _KernelFinder:
    """Import ``cfem_ros.core.kernel`` from its compiled extension when current (``aot``)."""

    def find_spec(self, fullname, path, target=None):
        """Return the extension-backed kernel's spec, or None to import kernel.py (the JIT)."""
        if fullname != 'cfem_ros.core.kernel':
            return None
        from cfem_ros.core import aot
        return aot.kernel_spec()


if not any(type(finder).__name__ == '_KernelFinder' for finder in sys.meta_path):
    sys.meta_path.insert(0, _KernelFinder())
