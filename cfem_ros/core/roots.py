# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Brent's root finder, as scipy.optimize.brentq computes it, without importing scipy.

A run locates release conditions with it; importing scipy.optimize would
cost a run's start-up more than the run. The iteration is scipy's C code
(Charles Harris's ``brentq.c``) transcribed operation for operation, so
that it returns the same bits (``test/core/test_roots.py`` checks it
against scipy).
"""

from __future__ import annotations

import math


def brentq(f, a: float, b: float, xtol: float = 2e-12, rtol: float = 8.881784197001252e-16,
           maxiter: int = 100) -> float:
    """
    Find a root of f in [a, b], where f(a) and f(b) differ in sign.

    Parameters
    ----------
    f : callable
        float -> float; NaN is refused.
    a, b : float
        The bracket.
    xtol, rtol : float
        The root is found to within xtol + rtol |x|.
    maxiter : int
        Iterations before giving up.

    Raises
    ------
    ValueError
        If f(a) and f(b) have the same sign, or f returns NaN.
    RuntimeError
        If it does not converge in maxiter iterations.

    """
    def call(x):
        value = float(f(x))
        if math.isnan(value):
            raise ValueError('The function value at x=%f is NaN; solver cannot continue.' % x)
        return value

    xpre, xcur = float(a), float(b)
    xblk = fblk = spre = scur = 0.0
    fpre = call(xpre)
    fcur = call(xcur)
    if fpre * fcur > 0:
        raise ValueError('f(a) and f(b) must have different signs')
    if fpre == 0:
        return xpre
    if fcur == 0:
        return xcur
    for _ in range(maxiter):
        if fpre * fcur < 0:
            xblk, fblk = xpre, fpre
            spre = scur = xcur - xpre
        if abs(fblk) < abs(fcur):
            xpre, xcur, xblk = xcur, xblk, xcur
            fpre, fcur, fblk = fcur, fblk, fcur
        delta = (xtol + rtol * abs(xcur)) / 2
        sbis = (xblk - xcur) / 2
        if fcur == 0 or abs(sbis) < delta:
            return xcur
        if abs(spre) > delta and abs(fcur) < abs(fpre):
            if xpre == xblk:
                stry = -fcur * (xcur - xpre) / (fcur - fpre)          # interpolate
            else:
                dpre = (fpre - fcur) / (xpre - xcur)                  # extrapolate
                dblk = (fblk - fcur) / (xblk - xcur)
                stry = -fcur * (fblk * dblk - fpre * dpre) / (dblk * dpre * (fblk - fpre))
            if 2 * abs(stry) < min(abs(spre), 3 * abs(sbis) - delta):
                spre, scur = scur, stry                               # good short step
            else:
                spre = scur = sbis                                    # bisect
        else:
            spre = scur = sbis                                        # bisect
        xpre, fpre = xcur, fcur
        if abs(scur) > delta:
            xcur += scur
        else:
            xcur += delta if sbis > 0 else -delta
        fcur = call(xcur)
    raise RuntimeError('Failed to converge after %d iterations, value is %f' % (maxiter, xcur))
