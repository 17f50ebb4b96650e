"""Tests of holecli.geometry.circle: algebraic, geometric and robust circle fits, and the fit quality measures."""

import numpy as np
import pytest

from holecli.errors import PointsError
from holecli.geometry.circle import CircleFit, fit_circle_algebraic, fit_circle_geometric, fit_circle_robust

CENTER = np.array([12.3, -4.5])
RADIUS = 1.7


def _circle(angles, center=CENTER, radius=RADIUS):
    return np.asarray(center) + radius * np.column_stack([np.cos(angles), np.sin(angles)])


def _noisy_circle(rng, count, sigma, span=2 * np.pi, center=CENTER, radius=RADIUS):
    """Points at random angles over ``span`` with Gaussian radial noise ``sigma``."""
    angles = rng.uniform(0.0, span, count)
    radii = radius + rng.normal(0.0, sigma, count)
    return np.asarray(center) + radii[:, None] * np.column_stack([np.cos(angles), np.sin(angles)])


def _center_radius(fit):
    if isinstance(fit, CircleFit):
        return fit.center, fit.radius
    return fit


def _standard_errors(xy, center, radius, sigma):
    """Standard errors of (cx, cy, r) of the geometric fit, from the Jacobian at the truth."""
    d = xy - center
    dist = np.hypot(d[:, 0], d[:, 1])
    jacobian = np.column_stack([-d[:, 0] / dist, -d[:, 1] / dist, -np.ones(len(xy))])
    return sigma * np.sqrt(np.diag(np.linalg.inv(jacobian.T @ jacobian)))


FITS = [fit_circle_algebraic, fit_circle_geometric, fit_circle_robust]


@pytest.mark.parametrize("fit", FITS)
@pytest.mark.parametrize(
    "center, radius",
    [((12.3, -4.5), 1.7), ((0.0, 0.0), 1e-3), ((769.0, -83.6), 4.15), ((0.0, 0.0), 250.0)],
)
def test_exact_on_exact_full_circle(rng, fit, center, radius):
    xy = _circle(rng.uniform(0, 2 * np.pi, 40), center, radius)
    got_center, got_radius = _center_radius(fit(xy))
    np.testing.assert_allclose(got_center, center, rtol=0, atol=1e-9 * radius)
    assert got_radius == pytest.approx(radius, rel=1e-9)


@pytest.mark.parametrize("fit", FITS)
def test_exact_on_exact_half_arc(rng, fit):
    xy = _circle(rng.uniform(0.0, np.pi, 30) + 0.4)
    got_center, got_radius = _center_radius(fit(xy))
    np.testing.assert_allclose(got_center, CENTER, rtol=0, atol=1e-9 * RADIUS)
    assert got_radius == pytest.approx(RADIUS, rel=1e-9)


def test_geometric_exact_on_three_points():
    xy = _circle(np.array([0.1, 2.0, 4.0]))
    fit = fit_circle_geometric(xy)
    np.testing.assert_allclose(fit.center, CENTER, atol=1e-9)
    assert fit.radius == pytest.approx(RADIUS, rel=1e-9)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_geometric_on_noisy_half_arc_within_its_standard_errors(seed):
    rng = np.random.default_rng(seed)
    sigma, count = 0.01, 60
    xy = _noisy_circle(rng, count, sigma, span=np.pi)
    fit = fit_circle_geometric(xy)
    errors = np.abs(np.r_[fit.center - CENTER, fit.radius - RADIUS])
    se = _standard_errors(xy, CENTER, RADIUS, sigma)
    # A half arc leaves the center about three times less certain than sigma / sqrt(n) says.
    assert np.all(se < 4 * sigma / np.sqrt(count))
    assert np.all(errors < 4 * se), (errors, se)


@pytest.mark.parametrize("fit", FITS)
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_noisy_full_circle_within_tolerance(fit, seed):
    rng = np.random.default_rng(seed)
    sigma, count = 0.01, 200
    xy = _noisy_circle(rng, count, sigma)
    center, radius = _center_radius(fit(xy))
    # Standard errors of a full circle: sqrt(2 / n) sigma for each center coordinate, sigma / sqrt(n)
    # for the radius; the bias of a geometric fit is of order sigma^2 / r, far below.
    center_se = np.sqrt(2.0 / count) * sigma
    assert np.all(np.abs(center - CENTER) < 4 * center_se)
    assert abs(radius - RADIUS) < 4 * sigma / np.sqrt(count) + sigma**2 / RADIUS


def test_geometric_fit_is_unbiased_on_average():
    rng = np.random.default_rng(7)
    sigma, count, trials = 0.02, 50, 200
    radius_errors, center_errors = [], []
    for _ in range(trials):
        fit = fit_circle_geometric(_noisy_circle(rng, count, sigma))
        radius_errors.append(fit.radius - RADIUS)
        center_errors.append(fit.center - CENTER)
    standard_error_of_mean = sigma / np.sqrt(count * trials)
    # sigma^2 / (2 r) is the known second-order bias of the geometric radius (1.2e-4 here, 1 se).
    assert abs(np.mean(radius_errors)) < 4 * standard_error_of_mean + sigma**2 / (2 * RADIUS)
    assert np.all(np.abs(np.mean(center_errors, axis=0)) < 4 * np.sqrt(2) * standard_error_of_mean)
    # and the scatter is the expected one, not much larger
    assert np.std(radius_errors) < 1.5 * sigma / np.sqrt(count)


def test_geometric_fit_minimises_the_radial_residuals(rng):
    xy = _noisy_circle(rng, 80, 0.05, span=4.0)
    fit = fit_circle_geometric(xy)

    def cost(cx, cy, r):
        return np.sum((np.hypot(xy[:, 0] - cx, xy[:, 1] - cy) - r) ** 2)

    best = cost(*fit.center, fit.radius)
    for _ in range(30):
        step = rng.normal(scale=1e-4, size=3)
        assert cost(*(fit.center + step[:2]), fit.radius + step[2]) > best


def test_geometric_fit_from_a_poor_start_converges(rng):
    xy = _noisy_circle(rng, 100, 0.005)
    reference = fit_circle_geometric(xy)
    fit = fit_circle_geometric(xy, start=(CENTER + 0.5, 1.3 * RADIUS))
    np.testing.assert_allclose(fit.center, reference.center, atol=1e-9)
    assert fit.radius == pytest.approx(reference.radius, abs=1e-9)


def test_algebraic_fit_is_biased_on_a_noisy_arc_where_the_geometric_fit_is_not():
    # Why the paper refines the algebraic start geometrically: Kasa's fit shrinks short noisy arcs.
    rng = np.random.default_rng(3)
    xy = _noisy_circle(rng, 400, 0.05, span=np.pi / 2)
    _, algebraic = fit_circle_algebraic(xy)
    geometric = fit_circle_geometric(xy).radius
    assert abs(geometric - RADIUS) < abs(algebraic - RADIUS)


def _with_outliers(rng, count, fraction, outlier_radius, sigma=0.002):
    xy = _noisy_circle(rng, count, sigma)
    bad = np.zeros(count, dtype=bool)
    bad[: int(round(fraction * count))] = True
    xy[bad] = _circle(rng.uniform(0, 2 * np.pi, bad.sum()), CENTER, outlier_radius)
    return xy, bad, sigma


def test_robust_rejects_a_few_gross_outliers(rng):
    xy, bad, sigma = _with_outliers(rng, 200, 0.05, 2.0 * RADIUS)
    fit = fit_circle_robust(xy)
    assert not fit.kept[bad].any()
    assert fit.kept[~bad].mean() > 0.95
    np.testing.assert_allclose(fit.center, CENTER, atol=6 * sigma / np.sqrt(200))
    assert fit.radius == pytest.approx(RADIUS, abs=6 * sigma / np.sqrt(200))
    assert len(fit.residuals) == fit.kept.sum()
    # The plain geometric fit is pulled far away by the same points.
    assert abs(fit_circle_geometric(xy).radius - RADIUS) > 0.05


def test_robust_rejects_20_percent_of_points_at_half_the_radius(rng):
    xy, bad, sigma = _with_outliers(rng, 200, 0.20, 0.5 * RADIUS)
    fit = fit_circle_robust(xy)
    assert not fit.kept[bad].any()
    np.testing.assert_allclose(fit.center, CENTER, atol=6 * sigma / np.sqrt(160))
    assert fit.radius == pytest.approx(RADIUS, abs=6 * sigma / np.sqrt(160))


def test_robust_keeps_every_point_of_clean_noisy_data(rng):
    xy = _noisy_circle(rng, 300, 0.01)
    fit = fit_circle_robust(xy)
    # 3 sigma clipping of Gaussian data drops about 0.3 %.
    assert fit.kept.mean() > 0.98
    reference = fit_circle_geometric(xy)
    np.testing.assert_allclose(fit.center, reference.center, atol=0.01 / np.sqrt(300))


def test_quality_measures_of_a_fit(rng):
    xy = _noisy_circle(rng, 100, 0.03)
    fit = fit_circle_geometric(xy)
    distances = np.hypot(*(xy - fit.center).T)
    np.testing.assert_allclose(fit.residuals, distances - fit.radius, atol=1e-12)
    assert fit.rms == pytest.approx(np.sqrt(np.mean((distances - fit.radius) ** 2)), rel=1e-12)
    assert fit.max_residual == pytest.approx(np.max(np.abs(distances - fit.radius)), rel=1e-12)
    assert fit.roundness == pytest.approx(distances.max() - distances.min(), rel=1e-12)
    assert fit.kept.all() and len(fit.kept) == len(xy)


def test_quality_measures_known_values():
    fit = CircleFit(center=np.zeros(2), radius=1.0, residuals=np.array([0.1, -0.3, 0.2]), kept=np.ones(3, bool))
    assert fit.rms == pytest.approx(np.sqrt((0.01 + 0.09 + 0.04) / 3))
    assert fit.max_residual == pytest.approx(0.3)
    assert fit.roundness == pytest.approx(0.5)
    assert all(type(value) is float for value in (fit.rms, fit.max_residual, fit.roundness))


@pytest.mark.parametrize("fit", FITS)
@pytest.mark.parametrize(
    "xy, match",
    [
        (np.column_stack([np.arange(10.0), 2.0 * np.arange(10.0) + 1.0]), "collinear"),
        (np.column_stack([np.linspace(0.1, 7.3, 25), 0.3 * np.linspace(0.1, 7.3, 25) + 0.7]), "collinear"),
        (np.tile((1.0, 2.0), (6, 1)), "collinear|degenerate"),
        (np.array([[0.0, 0.0], [1.0, 1.0]]), "at least 3 points, got 2"),
        (np.zeros((0, 2)), "at least 3 points, got 0"),
        (np.zeros((5, 3)), r"\(n, 2\) array, got shape \(5, 3\)"),
        (np.zeros(6), r"\(n, 2\) array, got shape \(6,\)"),
    ],
)
def test_degenerate_inputs_raise(fit, xy, match):
    with pytest.raises(PointsError, match=match):
        fit(xy)
