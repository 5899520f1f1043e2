# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""Fitting a scenario's parameters to a measured trajectory (SPEC section 13)."""

#: Draws of the fitted parameters a prediction makes by default, and at most (every draw's
#: poses are kept); here, so that the command line shows them without importing a fit.
DRAWS = 200
MOST_DRAWS = 100_000
