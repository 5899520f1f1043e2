# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The model a scenario describes: bodies, joints, releases, loads and shapes, as plain data.

Modules: ``model`` (``Model``, ``Contact``, gravity and the Baumgarte gain),
``bodies`` (``Body``, ``Motion``), ``joints`` (the joint table, ``Joint``,
``Release``, ``ReleaseGroup``), ``loads`` (``Wrench``, ``Aero``,
``Proximity``, ``SwayBrace``) and ``shapes`` (what a body looks like, for
markers and contacts).
Nothing here runs anything: the engine reads these.
"""
