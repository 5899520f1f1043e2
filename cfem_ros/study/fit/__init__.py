# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""Fitting a scenario's parameters to a measured trajectory (SPEC section 13)."""
