"""Tests of holecli.geometry.kernels' named helpers: robust sigma, box query, angular gap, normal sign."""

import numpy as np
import pytest

from holecli.geometry import plane
from holecli.geometry.kernels import (box_indices, largest_angular_gap, orient_normal, robust_sigma, triangulate,
                                     wobble_frame)


def test_robust_sigma_is_the_scaled_median_absolute_value(rng):
    x = rng.normal(0.0, 2.0, 200_000)
    assert robust_sigma(x) == 1.4826 * float(np.median(np.abs(x)))
    assert robust_sigma(x) == pytest.approx(2.0, rel=0.01)
    # One wild value in a hundred moves it by about a percent, not by the value.
    x[::100] = 1e9
    assert robust_sigma(x) == pytest.approx(2.0, rel=0.03)


def test_box_indices_are_the_points_in_the_closed_box():
    xy = np.array([[0.0, 0.0], [1.0, 1.0], [2.0, 0.5], [0.5, -0.1], [1.0, 0.0]])
    np.testing.assert_array_equal(box_indices(xy, np.array([0.0, 0.0]), np.array([1.0, 1.0])), [0, 1, 4])
    assert box_indices(xy, np.array([5.0, 5.0]), np.array([6.0, 6.0])).size == 0
    # The same on a column-major copy (the pipeline's layout).
    np.testing.assert_array_equal(box_indices(np.asfortranarray(xy), np.array([0.0, 0.0]), np.array([1.0, 1.0])),
                                  [0, 1, 4])


def test_largest_angular_gap_includes_the_wrap_around():
    center = np.array([1.0, -2.0])
    angles = np.radians([10.0, 100.0, 200.0, 300.0])
    xy = center + np.column_stack([np.cos(angles), np.sin(angles)])
    assert largest_angular_gap(xy, center) == pytest.approx(np.radians(100.0))
    # From 300 back round to 10 degrees: 70; a quarter circle left empty is the gap.
    xy = center + 3.0 * np.column_stack([np.cos(np.radians([0.0, 30.0, 60.0, 90.0, 180.0, 270.0])),
                                         np.sin(np.radians([0.0, 30.0, 60.0, 90.0, 180.0, 270.0]))])
    assert largest_angular_gap(xy, center) == pytest.approx(np.pi / 2)
    assert largest_angular_gap(xy[:1], center) == pytest.approx(2 * np.pi)


def test_orient_normal_is_the_library_convention_everywhere():
    # holecli.geometry.plane re-exports the kernel's convention (the robust method imports it there).
    assert plane.orient_normal is orient_normal
    np.testing.assert_array_equal(orient_normal([0.0, -1.0, 1e-13]), [0.0, 1.0, -1e-13])
    # A vector with no component above the tolerance is left as it is.
    np.testing.assert_array_equal(orient_normal([-1e-13, 0.0, 0.0]), [-1e-13, 0.0, 0.0])


@pytest.mark.parametrize("pass_share", [None, 2.0, 0.0])
def test_cell_index_answers_box_queries_as_a_pass_over_the_points(pass_share):
    """Random clouds (empty, far from the origin, with a stray point 1e9 away), random cells and boxes
    (reversed, beyond the points, covering everything): the same indices, in the same order, whether
    the index reads its cells for every box (pass_share 2), for none (0) or for the narrow ones."""
    from holecli.geometry.kernels import CellIndex, box_indices

    rng = np.random.default_rng(0)
    for trial in range(150):
        n = int(rng.integers(0, 2000))
        xy = rng.uniform(-5, 5, (n, 2)) * rng.uniform(0.001, 100) + rng.uniform(-1e6, 1e6, 2)
        if n and rng.random() < 0.2:
            xy[0] = [1e9, -1e9]
        xy = np.asfortranarray(xy)
        index = CellIndex(xy, rng.uniform(0.01, 2.0), pass_share=pass_share)
        for _ in range(20):
            center = xy[rng.integers(n)] if n else np.zeros(2)
            half = rng.uniform(0, 30, 2)
            low, high = center - half, center + half * rng.uniform(-0.5, 2.0)
            np.testing.assert_array_equal(index.box(low, high), box_indices(xy, low, high), err_msg=str(trial))
        # sides at infinity (everything on that side) and NaN (nothing)
        for low, high in (([-np.inf, -np.inf], [np.inf, np.inf]), ([np.nan, 0.0], [1.0, 1.0]),
                          ([-np.inf, 0.0], [0.0, np.inf]), (xy[0] if n else [0.0, 0.0], [np.inf, np.inf])):
            low, high = np.asarray(low, dtype=float), np.asarray(high, dtype=float)
            np.testing.assert_array_equal(index.box(low, high), box_indices(xy, low, high), err_msg=str(trial))


def test_circumradii_of_a_right_triangle_and_a_degenerate_one():
    from holecli.geometry.kernels import circumradii

    points = np.array([[0.0, 0.0], [2.0, 0.0], [0.0, 2.0], [1.0, 0.0], [3.0, 0.0]])
    radii, centers = circumradii(points, np.array([[0, 1, 2], [0, 3, 4]]))
    np.testing.assert_allclose(centers[0], [1.0, 1.0])
    assert radii[0] == pytest.approx(np.sqrt(2.0))
    # collinear: no circle; the radius is infinite and the centroid stands in for the center
    assert radii[1] == np.inf
    np.testing.assert_allclose(centers[1], [4.0 / 3.0, 0.0])


def test_cell_index_sorts_only_when_a_narrow_box_is_asked():
    """A box holding most of the points is a pass over them: the cells are not sorted for it."""
    from holecli.geometry.kernels import PASS_SHARE, CellIndex, box_indices

    xy = np.asfortranarray(np.random.default_rng(1).uniform(0.0, 10.0, (5000, 2)))
    index = CellIndex(xy, 0.1)
    wide = (np.array([1.0, 1.0]), np.array([9.0, 9.0]))
    np.testing.assert_array_equal(index.box(*wide), box_indices(xy, *wide))
    assert index._sorted is None
    narrow = (np.array([4.0, 4.0]), np.array([4.0, 4.0]) + 10.0 * np.sqrt(PASS_SHARE) / 2)
    np.testing.assert_array_equal(index.box(*narrow), box_indices(xy, *narrow))
    assert index._sorted is not None


def test_a_subset_triangulated_in_the_whole_set_s_frame_keeps_its_wobble(rng):
    """triangulate wobbles each point as a function of its coordinates in a frame; given the whole
    set's frame, a subset's points are wobbled exactly as in the whole set."""
    xy = rng.uniform(-3.0, 5.0, size=(200, 2))
    subset = np.flatnonzero(np.hypot(*xy.T) < 3.0)
    whole = triangulate(xy).points
    np.testing.assert_array_equal(triangulate(xy[subset], frame=wobble_frame(xy)).points, whole[subset])
    assert not np.array_equal(triangulate(xy[subset]).points, whole[subset])
