"""Tests of holecli.robust.candidate: a candidate void before any stage, and where it is placed."""

from dataclasses import replace

import numpy as np
import pytest

from holecli.geometry.circle import CircleFit
from holecli.robust.candidate import Candidate
from holecli.robust.candidates import find_voids, occupancy_grid
from holecli.settings import DEFAULT_SETTINGS

CELL = 0.1


@pytest.fixture(scope="module")
def voids():
    """A 10 x 10 mm grid of points 0.05 mm apart, with a 2 mm hole at (5, 5) and a 1 mm bay cut into
    its left border at (0, 5)."""
    ticks = np.arange(0.0, 10.0 + 1e-9, 0.05)
    xy = np.column_stack([axis.ravel() for axis in np.meshgrid(ticks, ticks)])
    xy = xy[(np.hypot(*(xy - [5.0, 5.0]).T) >= 1.0) & (np.hypot(*(xy - [0.0, 5.0]).T) >= 1.0)]
    grid = occupancy_grid(xy, CELL)
    return grid, find_voids(grid)


def test_a_candidate_starts_at_its_void(voids):
    grid, found = voids
    hole = next(void for void in found if void.enclosed)
    candidate = Candidate.of(hole, grid, DEFAULT_SETTINGS)
    np.testing.assert_allclose(candidate.void_center, [5.0, 5.0], atol=CELL)
    # the void's radius reaches its farthest cell's far side: about the hole's
    assert candidate.void_radius == pytest.approx(1.0, abs=2 * CELL)
    assert candidate.fewest == DEFAULT_SETTINGS.min_rim_points
    assert all(value is None for value in (candidate.rim_xy, candidate.fit, candidate.partial))
    center, radius = candidate.place
    np.testing.assert_array_equal(center, candidate.void_center)
    assert radius == candidate.void_radius


def test_a_bay_needs_the_rim_points_of_a_partial_hole(voids):
    grid, found = voids
    bay = next(void for void in found if not void.enclosed)
    candidate = Candidate.of(bay, grid, DEFAULT_SETTINGS)
    assert candidate.fewest == DEFAULT_SETTINGS.min_partial_rim_points > DEFAULT_SETTINGS.min_rim_points


def test_once_fitted_a_candidate_is_placed_at_its_circle(voids):
    grid, found = voids
    candidate = Candidate.of(next(void for void in found if void.enclosed), grid, DEFAULT_SETTINGS)
    fit = CircleFit(center=np.array([5.01, 4.99]), radius=np.float64(1.02), residuals=np.zeros(3),
                    kept=np.ones(3, dtype=bool))
    center, radius = replace(candidate, fit=fit).place
    np.testing.assert_array_equal(center, [5.01, 4.99])
    assert radius == 1.02 and type(radius) is float
