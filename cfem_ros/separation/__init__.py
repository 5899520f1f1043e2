# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The separation outputs (SPEC section 12): figures and commands in a carrier's axes.

``figures``: the trajectory sheet and outline snapshots of a run;
``outlines``: shapes as 2D outlines; ``envelopes``: a sweep's envelope and
the report's separation figures; ``commands``: ``cfem-sim export`` and the
``--relative-to`` options of ``cfem-sim plot``. The tables themselves are
``recording.export``; the composition of poses ``recording.relative``.
"""
