"""The largest empty circle and its overshoot on synthetic holes (holecli.robust.estimators.empty_circle)."""

import numpy as np
import pytest

from holecli.robust.estimators.empty_circle import empty_circle_bias, largest_empty_circle

H = 0.1
RADIUS = 1.5


def poisson_ring(rng, center=(0.0, 0.0), radius=RADIUS, outer=3.0, spacing=H):
    """Uniform random points (density 1/spacing^2) in the annulus from ``radius`` to ``outer``."""
    count = rng.poisson(np.pi * (outer ** 2 - radius ** 2) / spacing ** 2)
    rho = np.sqrt(rng.uniform(radius ** 2, outer ** 2, count))
    theta = rng.uniform(0.0, 2 * np.pi, count)
    return np.column_stack([rho * np.cos(theta), rho * np.sin(theta)]) + center


def test_points_on_a_circle_give_that_circle():
    theta = np.linspace(0.0, 2 * np.pi, 90, endpoint=False)
    ring = np.column_stack([np.cos(theta), np.sin(theta)]) * RADIUS + [0.3, -0.2]
    outside = poisson_ring(np.random.default_rng(0), center=(0.3, -0.2), radius=RADIUS + 0.05)
    center, radius = largest_empty_circle(np.concatenate([ring, outside]), (0.32, -0.21), RADIUS - 0.02, 0.2)
    np.testing.assert_allclose(center, [0.3, -0.2], atol=1e-12)
    assert radius == pytest.approx(RADIUS, abs=1e-12)


@pytest.mark.parametrize("offset, unit", [((1e6, -2e6), 1.0), ((1500.0, 800.0), 1e-3)])
def test_far_from_the_origin_and_in_metres(offset, unit):
    """Coordinates 10^6 from the origin, or in metres: the same circle, to round-off."""
    xy = poisson_ring(np.random.default_rng(1))
    center, radius = largest_empty_circle(xy, (0.0, 0.0), RADIUS, 0.3)
    moved_center, moved_radius = largest_empty_circle(xy * unit + offset, np.array(offset), RADIUS * unit, 0.3 * unit)
    np.testing.assert_allclose((moved_center - offset) / unit, center, atol=1e-6)
    assert moved_radius / unit == pytest.approx(radius, abs=1e-6)


def test_an_open_region_has_no_empty_circle():
    """Points on one side only (a hole cut by the scan's border): no circle near the center is bounded."""
    xy = poisson_ring(np.random.default_rng(2))
    assert largest_empty_circle(xy[xy[:, 0] > 0.0], (0.0, 0.0), RADIUS, 0.3) is None
    assert largest_empty_circle(xy[:2], (0.0, 0.0), RADIUS, 0.3) is None


@pytest.mark.slow
def test_corrected_empty_circle_is_unbiased_and_tight_over_many_holes():
    """Over 200 random holes in Poisson points, the raw empty circle overshoots (mean about +0.03 h in
    radius), the overshoot measured on synthetic holes removes it (|mean| < 0.01 h), and at most 2 of 200
    are beyond 0.1 h."""
    raw, corrected = [], []
    for seed in range(200):
        rng = np.random.default_rng(seed)
        center = rng.uniform(-0.05, 0.05, 2)
        xy = poisson_ring(rng, center=center, outer=RADIUS + 1.5)
        found_center, found = largest_empty_circle(xy, (0.0, 0.0), RADIUS, 3 * H)
        overshoot = empty_circle_bias(xy, found_center, found, [k * 0.28 for k in (1, 2, 3, 4)], 3 * H)
        raw.append((found - RADIUS) / H)
        corrected.append((found - overshoot - RADIUS) / H)
    raw, corrected = np.asarray(raw), np.asarray(corrected)
    assert 0.015 < raw.mean() < 0.06
    assert abs(corrected.mean()) < 0.01
    assert np.count_nonzero(np.abs(corrected) > 0.1) <= 2


def test_bias_without_material_is_none():
    assert empty_circle_bias(np.zeros((0, 2)), (0.0, 0.0), RADIUS, [H], 0.3) is None
