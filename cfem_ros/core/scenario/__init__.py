# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Scenario files to a validated model: the checker and the section parsers.

Modules: ``parse`` (``load_scenario``, ``parse_scenario``, ``reparse``: a
scenario's document, section by section, to a ``Model``), ``checker`` (the
typed accessors every section parser reports through, and the limits),
one module per section (``bodies`` with ``motiontable``, ``joints`` with the
release groups, ``wrenches``, ``contacts``, ``braces``, ``aeroparse``: the
aero section's tables, air, atmosphere and proximity grids) and
``cgoffset`` (a body's CG away from its nominal place).
"""
