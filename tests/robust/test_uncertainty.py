"""Per-hole uncertainty (issue 14): holecli.robust.uncertainty and its use by the robust method."""

import math
import sys
from pathlib import Path

import numpy as np
import pytest

from holecli import detect
from holecli.robust import uncertainty
from holecli.robust.estimators import EMPTY_CIRCLE, LATTICE, METHOD_TERMS, RIM_FIT, SyntheticErrors
from holecli.robust.uncertainty import (circle_fit_covariance, edge_uncertainty, plane_uncertainty,
                                        small_sample_factor, synthetic_reflections)

REPO = Path(__file__).resolve().parents[2]


def test_small_sample_factor_is_students_t_over_the_normal_quantile():
    # t_0.975 as printed in the tables (NIST/SEMATECH e-Handbook 1.3.6.7.2), over z_0.975 = 1.960
    for dof, t in ((1, 12.706), (3, 3.182), (7, 2.365), (10, 2.228), (20, 2.086), (30, 2.042), (100, 1.984)):
        assert small_sample_factor(dof) == pytest.approx(t / 1.960, abs=0.0006), dof
    assert small_sample_factor(10 ** 6) == pytest.approx(1.0, abs=1e-5)
    with pytest.raises(ValueError):
        small_sample_factor(0)


def test_the_circle_fit_covariance_is_sigma_squared_over_n_for_a_full_rim():
    rng = np.random.default_rng(1)
    angle = rng.uniform(0, 2 * np.pi, 2000)
    sigma, radius = 0.01, 2.0
    xy = (radius + rng.normal(0, sigma, angle.size))[:, None] * np.column_stack([np.cos(angle), np.sin(angle)])
    covariance = circle_fit_covariance(xy, (0.0, 0.0), radius)
    assert math.sqrt(covariance[2, 2]) == pytest.approx(sigma / math.sqrt(angle.size), rel=0.1)
    # the center: twice the variance of the radius (each coordinate sees half the points' weight)
    assert math.sqrt(covariance[0, 0]) == pytest.approx(sigma * math.sqrt(2.0 / angle.size), rel=0.1)
    assert circle_fit_covariance(xy[:3], (0.0, 0.0), radius) is None


def _errors(radial, center):
    return SyntheticErrors(radial=np.asarray(radial, float), center=np.asarray(center, float).reshape(-1, 2))


def test_a_corrected_estimator_takes_the_spread_and_the_lattice_the_root_mean_square():
    # the same synthetic errors: a constant excess of 5 with a spread of 1
    errors = _errors([4.0, 5.0, 6.0, 5.0], [[0.0, 0.0]] * 4)
    rim = np.column_stack([np.cos(np.linspace(0, 6, 50)), np.sin(np.linspace(0, 6, 50))])
    _, empty = edge_uncertainty(EMPTY_CIRCLE, errors, rim, (0.0, 0.0), 1.0, spacing=0.0, height_noise=0.0)
    _, lattice = edge_uncertainty(LATTICE, errors, rim, (0.0, 0.0), 1.0, spacing=0.0, height_noise=0.0)
    spread = np.std([4.0, 5.0, 6.0, 5.0], ddof=1) * math.sqrt(1.25) * small_sample_factor(3)
    assert empty == pytest.approx(2.0 * spread)  # corrected by the mean: the spread remains
    rms = math.sqrt(np.mean(np.square([4.0, 5.0, 6.0, 5.0]))) * small_sample_factor(4)
    assert lattice == pytest.approx(2.0 * rms)  # not corrected: the excess itself is error


def test_the_rim_fit_is_at_least_its_least_squares_covariance():
    # synthetic holes that all came out exact: the real rim's own scatter still counts
    errors = _errors([0.0] * 4, [[0.0, 0.0]] * 4)
    rng = np.random.default_rng(2)
    angle = rng.uniform(0, 2 * np.pi, 200)
    rim = (1.0 + rng.normal(0, 0.01, 200))[:, None] * np.column_stack([np.cos(angle), np.sin(angle)])
    center, diameter = edge_uncertainty(RIM_FIT, errors, rim, (0.0, 0.0), 1.0, spacing=0.0, height_noise=0.0)
    covariance = circle_fit_covariance(rim, (0.0, 0.0), 1.0)
    assert diameter == pytest.approx(2.0 * math.sqrt(covariance[2, 2]))
    assert center > 0


def test_the_method_terms_add_in_quadrature():
    errors = _errors([0.0] * 4, [[0.0, 0.0]] * 4)
    rim = np.column_stack([np.cos(np.linspace(0, 6, 50)), np.sin(np.linspace(0, 6, 50))])
    center, diameter = edge_uncertainty(LATTICE, errors, rim, (0.0, 0.0), 1.0, spacing=0.1, height_noise=0.01)
    (ca, cb), (da, db) = METHOD_TERMS["lattice"]["center"], METHOD_TERMS["lattice"]["diameter"]
    assert center == pytest.approx(math.hypot(ca * 0.1, cb * 0.01))
    assert diameter == pytest.approx(math.hypot(da * 0.1, db * 0.01))



def test_the_empty_circles_correction_adds_a_rectangular_type_b_term():
    # the empty circle's correction is uncertain by itself: its synthetic holes do not see the
    # reflections deep inside the real hole (seeds 0-199: 77 % diameter coverage without this term)
    errors = _errors([0.0] * 4, [[0.0, 0.0]] * 4)
    rim = np.column_stack([np.cos(np.linspace(0, 6, 50)), np.sin(np.linspace(0, 6, 50))])
    plain = edge_uncertainty(EMPTY_CIRCLE, errors, rim, (0.0, 0.0), 1.0, spacing=0.1, height_noise=0.01)
    corrected = edge_uncertainty(EMPTY_CIRCLE, errors, rim, (0.0, 0.0), 1.0, spacing=0.1, height_noise=0.01,
                                 diameter_correction=-0.3)
    assert corrected[0] == plain[0]
    assert corrected[1] == pytest.approx(math.hypot(plain[1], 0.3 / math.sqrt(3.0)))
    lattice = edge_uncertainty(LATTICE, errors, rim, (0.0, 0.0), 1.0, spacing=0.1, height_noise=0.01,
                               diameter_correction=-0.3)
    assert lattice == edge_uncertainty(LATTICE, errors, rim, (0.0, 0.0), 1.0, spacing=0.1, height_noise=0.01)


def test_synthetic_reflections_follow_the_real_density_in_the_band():
    assert synthetic_reflections(0, 1.0, (0, 0), [2.0], 0.1) is None
    points = synthetic_reflections(400, 1.0, (0.5, -0.5), [2.0, 2.2], 0.1)
    assert len(points) == 2
    density = 400 / math.pi
    expected = density * math.pi * (2.0 ** 2 - 1.9 ** 2)
    assert abs(len(points[0]) - expected) < 4 * math.sqrt(expected)
    distance = np.hypot(*(points[0] - (0.5, -0.5)).T)
    assert np.all((distance >= 1.9) & (distance <= 2.0))
    again = synthetic_reflections(400, 1.0, (0.5, -0.5), [2.0, 2.2], 0.1)
    assert np.array_equal(points[1], again[1])  # fixed seeds


def test_the_plane_uncertainty_is_the_least_squares_one():
    from holecli.geometry.plane import fit_plane_scatter

    rng = np.random.default_rng(3)
    xy = rng.uniform(-1, 1, (5000, 2))
    sigma = 0.001
    points = np.column_stack([xy, rng.normal(0, sigma, len(xy))])
    plane = fit_plane_scatter(points)
    height, normal = plane_uncertainty(points, plane, np.zeros(3))
    assert height == pytest.approx(sigma / math.sqrt(len(xy)), rel=0.1)
    # slope variance sigma^2 / sum x^2, sum x^2 = n / 3 on [-1, 1]
    assert normal == pytest.approx(sigma / math.sqrt(len(xy) / 3.0), rel=0.1)


def test_every_robust_hole_has_an_uncertainty_and_the_paper_method_none():
    from holecli.simulation.synth import table1_scene, make_scan

    scan = make_scan(table1_scene(0.1), 0)
    hole = detect(scan.points).holes[0]
    u = hole.uncertainty
    assert u is not None and u.estimator in METHOD_TERMS
    assert u.diameter > 0 and u.center_in_plane > 0 and u.center_along_normal > 0 and u.normal_deg > 0
    assert detect(scan.points, method="paper").holes[0].uncertainty is None


def test_the_exact_table1_grid_diameter_is_within_two_u():
    # the H9 example of issue 14: 2.9969 measured on a 3.000 hole; 2u must reach the truth
    from holecli.io import load_points

    points = load_points(REPO / "sample_clouds" / "table1.ply")
    hole = detect(points).holes[0]
    assert abs(hole.diameter - 3.0) <= 2.0 * hole.uncertainty.diameter
    assert abs(hole.diameter - 3.0) > 0.5 * hole.uncertainty.diameter  # and not absurdly wide


def test_the_reflections_given_to_the_synthetic_holes_are_needed(monkeypatch):
    """100 reflections inside the Table I hole: the synthetic holes must see reflections near their
    edge too, else the bias correction leaves the edge pulled in (by 15 um)."""
    from holecli.io import load_points
    from holecli.robust.estimators import harness

    points = load_points(REPO / "sample_clouds" / "table1_inside100.csv")
    hole = detect(points).holes[0]
    assert abs(hole.diameter - 3.0) <= 2.0 * hole.uncertainty.diameter
    with_reflections = abs(hole.diameter - 3.0)
    monkeypatch.setattr(harness, "reflections", lambda *args: None)
    without = detect(points).holes[0]
    assert abs(without.diameter - 3.0) > 2.0 * with_reflections


def test_the_coverage_on_fresh_scenes_is_bounded():
    """value +- 2u holds the truth in most of 16 scenes of two classes the method terms were not
    calibrated on (seeds 500 on): a bound of the failure rate, not the benchmark's 93-98 % band."""
    sys.path.insert(0, str(REPO / "benchmarks"))
    try:
        import uncertainty as bench  # benchmarks/uncertainty.py
    finally:
        sys.path.pop(0)
    rows = [bench.measure((kind, seed)) for kind in ("synth_random", "synth_stripes") for seed in range(500, 508)]
    rows = [row for row in rows if row is not None]
    assert len(rows) >= 14
    center, diameter, _, _ = bench.summary(rows)
    assert center[0] >= 0.8 and diameter[0] >= 0.8
    assert center[1] > 0.05 and diameter[1] > 0.05  # median |error| / u: not uselessly wide


def test_uncertainty_module_is_pure():
    text = Path(uncertainty.__file__).read_text(encoding="utf-8")
    assert "import holecli.robust.method" not in text and "print(" not in text
