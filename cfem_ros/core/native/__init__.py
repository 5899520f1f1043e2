# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The compiled kernel's face and the computations built on it alone.

``kernel`` is the one module that imports the extension
``cfem_ros.core._kernel``; ``atmosphere`` (the ISA), ``motion`` (prescribed
trajectories) and ``contacts`` (shapes and their distances) compute with it.
They sit below the scenario checker and the engine, which both use them, and
import nothing of the core but its own modules and the model's data.
"""
