# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Scenario files to a validated model: the checker and the section parsers.

Modules: ``parse`` (``load_scenario``, ``parse_scenario``, ``reparse``: a
scenario's document, section by section, to a ``Model``), ``aeroparse``
(the ``aero`` section: tables, air, atmosphere, proximity grids) and
``cgoffset`` (a body's CG away from its nominal place).
"""
