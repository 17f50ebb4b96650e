"""Tests of holecli.paper.rim: triangle areas, the paper's confidence bound and its rim rule."""

import numpy as np
import pytest
from scipy.spatial import ConvexHull, Delaunay

from holecli.errors import PointsError
from holecli.paper.rim import CONFIDENCE_Z, area_bound, paper_rim, triangle_areas

H = 0.0908  # the paper's grid spacing
HOLE_CENTER = np.array([1.0, 1.0])
HOLE_RADIUS = 1.5


def _grid(step=H, lo=-33, hi=56):
    i = np.arange(lo, hi) * step
    x, y = np.meshgrid(i, i)
    return np.column_stack([x.ravel(), y.ravel()])


def _grid_with_hole(center=HOLE_CENTER, radius=HOLE_RADIUS, step=H):
    xy = _grid(step)
    return xy[np.hypot(*(xy - center).T) > radius]


def _largest_angular_gap_deg(points, center):
    angles = np.sort(np.degrees(np.arctan2(points[:, 1] - center[1], points[:, 0] - center[0])))
    return float(np.max(np.diff(np.r_[angles, angles[0] + 360.0])))


def test_triangle_areas_known_values():
    xy = np.array([[0.0, 0.0], [2.0, 0.0], [0.0, 3.0], [2.0, 3.0], [1.0, 1.0]])
    simplices = np.array([[0, 1, 2], [2, 1, 0], [1, 3, 2], [0, 1, 4], [0, 4, 3]])
    # Either orientation gives a positive area; (0, 0), (1, 1), (2, 3) has 0.5 * |1 * 3 - 1 * 2|.
    np.testing.assert_allclose(triangle_areas(xy, simplices), [3.0, 3.0, 3.0, 1.0, 0.5])


def test_triangle_areas_of_a_degenerate_triangle_is_zero():
    xy = np.array([[0.0, 0.0], [1.0, 1.0], [3.0, 3.0]])
    assert triangle_areas(xy, np.array([[0, 1, 2]]))[0] == 0.0


def test_triangle_areas_sum_to_the_hull_area(rng):
    xy = rng.uniform(-2, 3, size=(300, 2))
    areas = triangle_areas(xy, Delaunay(xy).simplices)
    assert np.all(areas > 0)
    # In 2D ConvexHull.volume is the area.
    assert areas.sum() == pytest.approx(ConvexHull(xy).volume, rel=1e-12)


def test_area_bound_known_value():
    areas = np.array([1.0, 2.0, 3.0, 4.0])
    # mean 2.5, sample sd sqrt(5/3), n = 4
    assert area_bound(areas) == pytest.approx(2.5 + 1.96 * np.sqrt(5.0 / 3.0) / 2.0, rel=1e-12)
    assert CONFIDENCE_Z == 1.96


def test_area_bound_is_mean_plus_z_sd_over_sqrt_n(rng):
    areas = rng.exponential(0.004, size=1000)
    expected = areas.mean() + 1.96 * areas.std(ddof=1) / np.sqrt(len(areas))
    assert area_bound(areas) == pytest.approx(expected, rel=1e-12)
    assert area_bound(areas, z=3.0) == pytest.approx(areas.mean() + 3.0 * areas.std(ddof=1) / np.sqrt(1000), rel=1e-12)
    assert type(area_bound(areas)) is float


def test_area_bound_of_equal_areas_is_their_value():
    assert area_bound(np.full(50, 0.125)) == 0.125


def test_paper_rim_on_a_clean_grid_hugs_the_hole_edge():
    xy = _grid_with_hole()
    rim = paper_rim(xy)
    assert rim.dtype.kind == "i"
    assert len(rim) >= 12
    assert len(np.unique(rim)) == len(rim)
    distances = np.hypot(*(xy[rim] - HOLE_CENTER).T)
    # Rim points are material points: outside the edge, within 1.5 grid steps of it.
    assert np.all(distances > HOLE_RADIUS)
    assert np.all(distances < HOLE_RADIUS + 1.5 * H)
    # and they go all the way round the hole
    assert _largest_angular_gap_deg(xy[rim], HOLE_CENTER) < 45.0


def test_paper_rim_is_a_convex_polygon_around_the_hole():
    xy = _grid_with_hole()
    rim = paper_rim(xy)
    hull = ConvexHull(xy[rim])
    assert len(hull.vertices) == len(rim)
    # Its area is that of the hole disk, a little more (the rim lies outside the edge).
    assert np.pi * HOLE_RADIUS**2 < hull.volume < np.pi * (HOLE_RADIUS + H) ** 2


def test_paper_rim_drops_points_inside_the_hole(rng):
    # The convex hull of the candidates leaves out reflections inside the hole (paper, sec. 2.5).
    angles = rng.uniform(0, 2 * np.pi, 5)
    inside = HOLE_CENTER + 0.5 * HOLE_RADIUS * np.column_stack([np.cos(angles), np.sin(angles)])
    clean = _grid_with_hole()
    xy = np.concatenate([clean, inside])
    rim = paper_rim(xy)
    assert len(rim) >= 12
    assert np.all(rim < len(clean))
    assert np.all(np.hypot(*(xy[rim] - HOLE_CENTER).T) > HOLE_RADIUS)


def test_paper_rim_is_empty_when_no_triangle_exceeds_the_bound():
    # On an exactly regular grid (integers: no round-off) every triangle has the same area, so none
    # is above mean + 1.96 sd / sqrt(n) = mean, and the documented result is an empty rim.
    xy = _grid(step=1.0, lo=0, hi=30)
    rim = paper_rim(xy)
    assert rim.shape == (0,)
    assert rim.dtype.kind == "i"


def test_paper_rim_of_a_square_is_empty():
    # Two congruent triangles: neither exceeds the bound.
    assert len(paper_rim(np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]]))) == 0


@pytest.mark.parametrize(
    "xy",
    [
        np.column_stack([np.arange(10.0), np.arange(10.0)]),  # collinear
        np.zeros((2, 2)),  # too few
    ],
)
def test_paper_rim_refuses_points_without_a_triangulation(xy):
    with pytest.raises(PointsError, match="Delaunay triangulation failed"):
        paper_rim(xy)
