# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""Separation studies: metrics over many runs (sweeps) and over recorded logs."""
