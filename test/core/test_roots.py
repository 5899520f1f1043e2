# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""core.roots.brentq returns scipy's brentq's very bits, and its errors."""

import math

from cfem_ros.core.roots import brentq
import numpy as np
import pytest
from scipy.optimize import brentq as scipy_brentq

RELEASE = {'xtol': 1e-15, 'rtol': 4 * np.finfo(float).eps, 'maxiter': 200}   # as releases.py


def functions(count, seed=4):
    """Bracketed functions like a release condition's excess over a step."""
    rng = np.random.default_rng(seed)
    for n in range(count):
        c = rng.normal(size=4)
        h = rng.uniform(1e-4, 1.0)
        r = rng.uniform(0.05, 0.95) * h
        yield h, [lambda s: (s - r) * (1 + c[0] ** 2) + c[1] * (s - r) ** 2,
                  lambda s: math.sin(3 * (s - r) / h) + 0.1 * c[2] * (s - r) / h,
                  lambda s: math.expm1((s - r) / h) + c[3] * (s - r) ** 3][n % 3]


def outcome(solver, *args, **options):
    """Return the root, or the exception's type."""
    try:
        return solver(*args, **options)
    except (ValueError, RuntimeError) as err:
        return type(err)


@pytest.mark.parametrize('options', [{}, RELEASE])
def test_same_bits_as_scipy(options):
    roots = 0
    for h, f in functions(1500):
        ours = outcome(brentq, f, 0.0, h, **options)
        assert ours == outcome(scipy_brentq, f, 0.0, h, **options)
        roots += isinstance(ours, float)
    assert roots > 1000


def test_same_errors_as_scipy():
    with pytest.raises(ValueError, match='different signs'):
        brentq(lambda s: s + 1.0, 0.0, 1.0)
    with pytest.raises(ValueError, match='NaN'):
        brentq(lambda s: math.nan if s > 0.5 else s - 0.7, 0.0, 1.0)
    with pytest.raises(RuntimeError, match='converge'):
        brentq(lambda s: math.atan(1e3 * (s - 0.3)), 0.0, 1.0, maxiter=2)
    assert brentq(lambda s: s, 0.0, 1.0) == 0.0
