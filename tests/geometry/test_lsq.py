"""Tests of holecli.geometry.lsq: the one Levenberg-Marquardt, the Gauss-Newton refit, the trimmed refit and
the least-squares covariance the geometric fits share."""

import numpy as np
import pytest

from holecli.geometry.lsq import covariance, forward_difference, gauss_newton, levenberg_marquardt, trimmed_refit


def exponential(t, values):
    """Residuals of ``a exp(b t)`` against ``values`` and their analytic Jacobian."""
    def residuals(p):
        return p[0] * np.exp(p[1] * t) - values

    def jacobian(p, f):
        return np.column_stack([np.exp(p[1] * t), p[0] * t * np.exp(p[1] * t)])

    return residuals, jacobian


T = np.linspace(0.0, 1.0, 25)
TRUE = np.array([2.0, -1.5])


@pytest.mark.parametrize("stop", ["step", "decrease"])
def test_levenberg_marquardt_finds_the_minimum_from_far(stop):
    residuals, jacobian = exponential(T, TRUE[0] * np.exp(TRUE[1] * T))
    found = levenberg_marquardt(residuals, [0.5, 1.0], jacobian, stop=stop)
    np.testing.assert_allclose(found, TRUE, rtol=1e-6)


def test_forward_differences_match_the_analytic_jacobian():
    residuals, jacobian = exponential(T, np.zeros_like(T))
    p = np.array([1.3, 0.7])
    np.testing.assert_allclose(forward_difference(residuals, (1e-7, 1e-7))(p, residuals(p)),
                               jacobian(p, residuals(p)), rtol=1e-5, atol=1e-6)


def test_gauss_newton_and_levenberg_marquardt_agree_near_the_minimum():
    rng = np.random.default_rng(3)
    values = TRUE[0] * np.exp(TRUE[1] * T) + 0.01 * rng.standard_normal(len(T))
    residuals, jacobian = exponential(T, values)
    np.testing.assert_allclose(gauss_newton(residuals, TRUE, jacobian),
                               levenberg_marquardt(residuals, TRUE, jacobian), rtol=1e-9)


def test_gauss_newton_stops_where_its_convergence_test_says():
    """``converged(p, step)`` is asked after each step, with the parameters the step was taken from."""
    residuals, jacobian = exponential(T, TRUE[0] * np.exp(TRUE[1] * T))
    asked = []

    def converged(p, step):
        asked.append(np.array(p))
        return len(asked) == 2

    found = gauss_newton(residuals, [1.8, -1.3], jacobian, converged=converged)
    assert len(asked) == 2 and np.array_equal(asked[0], [1.8, -1.3])
    one = gauss_newton(residuals, [1.8, -1.3], jacobian, iterations=1)
    np.testing.assert_array_equal(asked[1], one)
    np.testing.assert_array_equal(found, gauss_newton(residuals, [1.8, -1.3], jacobian, iterations=2))
    # a relative test lets a fit run to convergence
    relative = gauss_newton(residuals, [1.8, -1.3], jacobian,
                            converged=lambda p, step: np.hypot(*step) <= 1e-15 * np.hypot(*p))
    np.testing.assert_allclose(relative, TRUE, rtol=1e-12)


def test_an_unknown_stop_rule_is_refused():
    residuals, jacobian = exponential(T, np.zeros_like(T))
    with pytest.raises(ValueError, match="stop must be"):
        levenberg_marquardt(residuals, TRUE, jacobian, stop="cost")


def test_trimmed_refit_drops_the_outliers_and_stops():
    """A constant fitted to noisy values with three far outliers: the mean of the rest."""
    rng = np.random.default_rng(0)
    values = 5.0 + 0.1 * rng.standard_normal(200)
    values[:3] = 50.0
    rounds = []

    def fit(p, kept):
        rounds.append(int(np.count_nonzero(kept)))
        return np.array([values[kept].mean()])

    p, kept = trimmed_refit(fit, lambda p: values - p[0], [np.median(values)], clip=4.0, floor=0.0, rounds=10,
                            minimum=2)
    assert not kept[:3].any() and kept[3:].sum() >= 195
    assert p[0] == pytest.approx(values[kept].mean())
    assert len(rounds) <= 3  # the kept set settles at once


def test_trimmed_refit_keeps_everything_when_too_few_would_stay():
    values = np.array([0.0, 0.0, 0.0, 10.0])
    _, kept = trimmed_refit(lambda p, kept: p, lambda p: values - p[0], [0.0], clip=3.0, floor=0.0, rounds=2,
                            minimum=5)
    assert kept.all()


@pytest.mark.parametrize("rounds, start, fits", [
    (10, 5.05, 1),  # the start leaves the outliers out, the first fit keeps that set: it is the last set's fit
    (1, 5.6, 2),    # the start keeps every value, the first fit leaves the outliers out, the rounds run out:
                    # that set is fitted once more
    (0, 5.05, 1),   # no round: the start's kept set is fitted
])
def test_trimmed_refit_refits_the_last_set_only_when_it_was_not_fitted(rounds, start, fits):
    values = np.concatenate([5.0 + 0.1 * np.random.default_rng(0).standard_normal(200), np.full(10, 6.0)])
    fitted = []

    def fit(p, kept):
        fitted.append(kept.copy())
        return np.array([values[kept].mean()])

    p, kept = trimmed_refit(fit, lambda p: values - p[0], [start], clip=3.0, floor=0.0, rounds=rounds,
                            minimum=2, refit_last=True)
    assert len(fitted) == fits
    np.testing.assert_array_equal(fitted[-1], kept)
    assert not kept[200:].any() and kept[:200].all()
    assert p[0] == values[kept].mean()


def test_the_covariance_of_a_straight_line_is_the_textbook_one():
    rng = np.random.default_rng(1)
    x = np.linspace(0.0, 10.0, 50)
    y = 1.0 + 2.0 * x + 0.3 * rng.standard_normal(len(x))
    design = np.column_stack([np.ones_like(x), x])
    coefficients, *_ = np.linalg.lstsq(design, y, rcond=None)
    residuals = design @ coefficients - y
    s2 = float(residuals @ residuals) / (len(x) - 2)
    np.testing.assert_allclose(covariance(design, residuals), s2 * np.linalg.inv(design.T @ design), rtol=1e-12)
    # Scaled residuals (a fit of r / scale, as scipy's least_squares of method.py): the same covariance.
    np.testing.assert_allclose(covariance(design / 0.3, residuals / 0.3), covariance(design, residuals), rtol=1e-12)


def test_no_covariance_without_spare_points_or_when_singular():
    assert covariance(np.ones((2, 2)), np.zeros(2)) is None
    assert covariance(np.ones((5, 2)), np.ones(5)) is None
