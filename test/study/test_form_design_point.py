# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""FORM's design point search (``samplers.design_point``) against an independent one."""

from cfem_ros.study import samplers
import numpy as np
import pytest
from scipy import optimize, stats


def _curved(u):
    """Return a limit state curved in both directions, its design point off the axes."""
    u = np.atleast_2d(u)
    return 3.0 - 0.8 * u[:, 0] - 0.6 * u[:, 1] + 0.15 * (u[:, 0] - 0.5 * u[:, 1]) ** 2 \
        - 0.05 * u[:, 1] ** 2 + 0.02 * u[:, 2]


def _counted(function):
    batches = []

    def margins(u):
        batches.append(len(u))
        return function(u)
    return margins, batches


@pytest.mark.parametrize('start', [np.zeros(3), np.array([1.0, -2.0, 0.5])])
def test_the_design_point_is_the_closest_point_of_the_surface(start):
    # the reference: scipy's SLSQP on min |u|^2 subject to G(u) = 0, exact gradients
    reference = optimize.minimize(lambda u: u @ u, np.full(3, 1.0), method='SLSQP',
                                  constraints={'type': 'eq', 'fun': lambda u: _curved(u)[0]},
                                  options={'ftol': 1e-14, 'maxiter': 500})
    assert reference.success
    margins, batches = _counted(_curved)
    star, beta, p_form = samplers.design_point(margins, start, 500)
    np.testing.assert_allclose(star, reference.x, atol=2e-3)
    assert beta == pytest.approx(np.linalg.norm(reference.x), abs=1e-3)
    assert p_form == pytest.approx(stats.norm.sf(beta), rel=1e-12)
    # one batch per iteration (a point and its 6-point stencil), a halving batch at most
    # now and then: a few batches, not one run at a time
    assert len(batches) <= 12 and min(batches) >= 4, batches


def test_a_plane_takes_one_step():
    """A linear limit state: the first HL-RF step is the design point, to rounding."""
    a = np.array([0.6, 0.8])
    margins, batches = _counted(lambda u: 3.5 - np.atleast_2d(u) @ a)
    star, beta, p_form = samplers.design_point(margins, np.zeros(2), 100)
    np.testing.assert_allclose(star, 3.5 * a, atol=1e-9)
    assert p_form == pytest.approx(stats.norm.sf(3.5), rel=1e-8)
    assert batches == [5, 5]   # the origin and its stencil, the step and its stencil


def test_a_median_that_fails_gives_p_above_one_half():
    margins, _ = _counted(lambda u: np.atleast_2d(u)[:, 0] + 1.0 - 2.0)   # fails at u0 < 1
    star, beta, p_form = samplers.design_point(margins, np.zeros(2), 100)
    assert beta == pytest.approx(1.0, abs=1e-6)
    assert p_form == pytest.approx(stats.norm.cdf(1.0), rel=1e-8)


def test_a_limit_state_that_does_not_change_is_refused():
    with pytest.raises(RuntimeError, match='no gradient'):
        samplers.design_point(lambda u: np.ones(len(u)), np.zeros(2), 100)


def test_a_surface_beyond_every_double_is_refused_before_a_run_goes_there():
    """A margin that hardly changes (1e-4 per SD) puts its surface 1e4 SD away: refused."""
    asked = []

    def margins(u):
        asked.append(np.abs(np.atleast_2d(u)).max())
        return 1.0 - 1e-4 * np.atleast_2d(u)[:, 0]

    with pytest.raises(samplers.FlatLimitState, match='1e[+]04 standard deviations'):
        samplers.design_point(margins, np.zeros(2), 100)
    assert max(asked) < 1e-3   # only the origin and its stencil were run
    # a surface within reach, however far in probability, is still found
    star, beta, p_form = samplers.design_point(lambda u: 30.0 - np.atleast_2d(u)[:, 0],
                                               np.zeros(2), 100)
    assert beta == pytest.approx(30.0, rel=1e-9) and 0 < p_form < 1e-190


def test_a_search_past_its_budget_stops():
    margins, batches = _counted(_curved)
    with pytest.raises(RuntimeError, match='maximum calls'):
        samplers.design_point(margins, np.zeros(3), 10)
    assert sum(batches) <= 10 + 7
