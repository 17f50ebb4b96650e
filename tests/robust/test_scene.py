"""Tests of holecli.robust.scene: the scene of a scan (its plane frame, scales and grid) and its
neighbourhood queries."""

from dataclasses import replace

import numpy as np
import pytest
from scipy.spatial import cKDTree

from holecli.robust.candidates import Grid
from holecli.robust.scene import Neighbourhood, build_scene


def _plate(seed=1, radius=3.0, count=12_000):
    """A 20 x 20 mm flat plate randomly sampled (spacing about 0.08 mm), a hole of ``radius`` at the origin."""
    rng = np.random.default_rng(seed)
    xy = rng.uniform(-10.0, 10.0, (count, 2))
    xy = xy[np.hypot(*xy.T) >= radius]
    return np.column_stack([xy, 0.002 * rng.standard_normal(len(xy))])


@pytest.fixture(scope="module")
def scene():
    return build_scene(_plate(), view_dir=(0.0, 0.0, -1.0))


def test_the_scales_are_positive_and_ordered(scene):
    spacing = float(scene.sampling.spacing)
    assert 0.05 < spacing < 0.15  # 12,000 points on 400 mm^2 (less the hole): about 0.08 mm apart
    assert scene.cell > 0 and scene.alpha > 0 and scene.min_radius > 0
    assert spacing < scene.cell < scene.alpha < scene.min_radius < 3.0  # the hole is above the smallest size
    assert len(scene.surface_xy) > 0.99 * len(scene.xy)  # a flat plate: (nearly) every point on the surface


def test_the_scene_is_scale_free(scene):
    """The same plate in micrometres: every length of the scene 1000 times longer."""
    scaled = build_scene(1000.0 * _plate(), view_dir=(0.0, 0.0, -1.0))
    for length in ("cell", "alpha", "min_radius", "gap_scatter"):
        assert getattr(scaled, length) == pytest.approx(1000.0 * getattr(scene, length), rel=1e-9)
    assert scaled.sampling.spacing == pytest.approx(1000.0 * scene.sampling.spacing, rel=1e-9)
    assert scaled.height_noise == pytest.approx(1000.0 * scene.height_noise, rel=1e-6)
    np.testing.assert_allclose(scaled.xy, 1000.0 * scene.xy, rtol=1e-9, atol=1e-9)


def test_the_plane_frame_keeps_the_plate_flat(scene):
    assert abs(scene.plane.normal[2]) == pytest.approx(1.0, abs=1e-4)
    assert np.max(np.abs(scene.heights)) < 0.02
    # the frame is a rotation: in-plane distances are the world's
    np.testing.assert_allclose(scene.rotation @ scene.rotation.T, np.eye(3), atol=1e-12)
    a, b = scene.points[0], scene.points[1]
    assert np.hypot(*(scene.xy[0] - scene.xy[1])) == pytest.approx(np.hypot(*(a - b)[:2]), abs=1e-4)


@pytest.mark.parametrize("indexed", [False, True])
def test_within_and_box_answer_as_a_brute_force_query(scene, indexed):
    """With or without the cell index, the queries give the points a pass over them gives."""
    queried = scene.with_cell_indices() if indexed else scene
    rng = np.random.default_rng(7)
    for xy in (queried.xy, queried.surface_xy, queried.material_xy):
        for _ in range(5):
            center = rng.uniform(-8.0, 8.0, 2)
            inner, outer = sorted(rng.uniform(0.0, 3.0, 2))
            distance = np.hypot(*(xy - center).T)
            expected = np.flatnonzero((distance >= inner) & (distance < outer))
            np.testing.assert_array_equal(np.sort(queried.within(xy, center, inner, outer)), expected)
            low, high = center - outer, center + 0.5 * outer
            in_box = np.flatnonzero(np.all((xy >= low) & (xy <= high), axis=1))
            np.testing.assert_array_equal(np.sort(queried.box(xy, low, high)), in_box)
            assert queried.count_in_disk(xy, center, outer) == np.count_nonzero(distance < outer)


def test_material_and_surface_share_their_index_when_no_speck_was_removed(scene):
    """material_xy equal to surface_xy: one index for both; a point fewer: an index of its own, whose
    queries are material_xy's."""
    same = replace(scene, material_xy=scene.surface_xy.copy()).with_cell_indices()
    assert same.material_cells is same.surface_cells
    fewer = replace(scene, material_xy=np.asfortranarray(scene.surface_xy[1:])).with_cell_indices()
    assert fewer.material_cells is not fewer.surface_cells
    for queried in (same, fewer):
        xy = queried.material_xy
        center = xy[0]
        expected = np.flatnonzero(np.hypot(*(xy - center).T) < 0.5)
        np.testing.assert_array_equal(queried.within(xy, center, 0.0, 0.5), expected)


def test_the_hole_is_scanned_all_round(scene):
    # the 3 mm hole in the plate's middle: wholly inside the scan, and no material just outside it lacks
    assert scene.scanned_fraction(np.zeros(2), 3.0) == pytest.approx(1.0)
    assert scene.material_arc(np.zeros(2), 3.0) == pytest.approx(360.0)
    # a disk centred on the plate's corner: about a quarter of it is scanned
    corner = (scene.rotation @ (np.array([10.0, 10.0, 0.0]) - scene.origin))[:2]
    assert scene.scanned_fraction(corner, 3.0) == pytest.approx(0.25, abs=0.1)


class _Counted:
    """A scene's arrays and queries, counting the passes over its points (box and within)."""

    def __init__(self, scene):
        self.scene, self.passes = scene, 0
        for name in Neighbourhood.ARRAYS:
            setattr(self, name, getattr(scene, name))

    def box(self, xy, low, high):
        self.passes += 1
        return self.scene.box(xy, low, high)

    def within(self, xy, center, inner, outer):
        self.passes += 1
        return self.scene.within(xy, center, inner, outer)


def _queries(rng, center, count):
    """Rings about centers near ``center``: inner 0 or not, some of them through a point of the plate."""
    for k in range(count):
        near = center + rng.uniform(-0.3, 0.3, 2)
        inner, outer = sorted(rng.uniform(0.0, 4.0, 2))
        yield near, (0.0 if k % 3 == 0 else inner), outer


@pytest.mark.parametrize("indexed", [False, True])
def test_a_neighbourhood_answers_as_its_scene_to_the_last_index(scene, indexed):
    """The same indices in the same order as the scene's own queries, for rings about centers
    near the hole's, on circles through points (the boundary cases) and beyond what was gathered."""
    queried = scene.with_cell_indices() if indexed else scene
    center = np.array([0.1, -0.2])
    around = Neighbourhood(queried, center, {"xy": 4.5, "surface_xy": 3.0})
    rng = np.random.default_rng(3)
    for xy in (queried.xy, queried.surface_xy, queried.material_xy, queried.above_xy):
        for near, inner, outer in _queries(rng, center, 30):
            np.testing.assert_array_equal(around.within(xy, near, inner, outer), queried.within(xy, near, inner, outer))
            assert around.count_in_disk(xy, near, outer) == queried.count_in_disk(xy, near, outer)
        # circles through points: a point at exactly the inner or the outer radius
        rows = np.flatnonzero(np.hypot(*(xy - center).T) < 3.5)
        for row in rng.choice(rows, min(20, len(rows)), replace=False):
            distance = float(np.hypot(*(xy[row] - center)))
            for inner, outer in ((distance, distance + 0.5), (0.0, distance), (distance / 2.0, distance)):
                np.testing.assert_array_equal(around.within(xy, center, inner, outer),
                                              queried.within(xy, center, inner, outer))
        # boxes inside what was gathered and beyond it (then the scene's)
        for low, high in ((center - 1.0, center + 0.5), (center - 6.0, center + 6.0)):
            np.testing.assert_array_equal(around.box(xy, low, high), queried.box(xy, low, high))
        # a disk reaching beyond what was gathered
        np.testing.assert_array_equal(around.within(xy, center, 1.0, 9.0), queried.within(xy, center, 1.0, 9.0))


def test_a_neighbourhood_gathers_each_array_once(scene):
    """Every question inside its reach answered from one pass over the array; one beyond, by the scene."""
    counted = _Counted(scene)
    center = np.array([0.1, -0.2])
    around = Neighbourhood(counted, center, {"surface_xy": 3.5})
    rng = np.random.default_rng(4)
    for near, inner, outer in _queries(rng, center, 20):
        around.within(counted.surface_xy, near, inner, min(outer, 3.0))
        around.count_in_disk(counted.surface_xy, near, 0.5 * outer)
    assert counted.passes == 1
    around.within(counted.surface_xy, center, 0.0, 5.0)
    assert counted.passes == 2
    # an array not given a reach: gathered as far as its first question asks
    around.within(counted.xy, center, 1.0, 2.0)
    around.within(counted.xy, center + 0.1, 0.0, 1.5)
    assert counted.passes == 3
    # what is not one of the scene's arrays: the scene's
    np.testing.assert_array_equal(around.within(counted.xy.copy(), center, 0.0, 1.0),
                                  scene.within(scene.xy, center, 0.0, 1.0))
    assert counted.passes == 4


def test_a_neighbourhood_is_its_scene_for_everything_else(scene):
    around = Neighbourhood(scene, np.zeros(2), {})
    assert around.cell == scene.cell and around.sampling is scene.sampling and around.xy is scene.xy
    assert around.scanned_fraction(np.zeros(2), 3.0) == scene.scanned_fraction(np.zeros(2), 3.0)
    with pytest.raises(AttributeError):
        around.not_an_attribute


@pytest.mark.parametrize("min_diameter", [None, 0.1, 0.37, 1.5])
def test_the_clearance_of_the_empty_cells_is_their_nearest_material(min_diameter):
    """Each empty cell's clearance is the distance from its center to the nearest material point of
    the whole scan when that is less than the reach, else inf (the default reach, 2.5 cells, puts
    the farthest cells it can touch exactly half a cell beyond its span)."""
    scene = build_scene(_plate(), view_dir=(0.0, 0.0, -1.0), min_diameter=min_diameter)
    grid, reach = scene.grid, scene.void_reach
    cells = np.argwhere(~grid.material)
    distance, _ = cKDTree(scene.material_xy).query(grid.center_of(cells))
    expected = np.full(grid.material.shape, np.inf)
    near = distance < reach
    expected[cells[near, 0], cells[near, 1]] = distance[near]
    assert np.count_nonzero(np.isfinite(expected)) > 100  # (the gaps of random sampling, and the hole's rim)
    np.testing.assert_array_equal(scene.empty_cell_clearance, expected)


def test_the_clearance_finds_material_at_the_edge_of_its_reach(scene):
    """One empty cell in a grid of material, whose only points stand on a ring just inside the reach
    about its center (in the cells the farthest from it that the reach touches, diagonals included):
    each cell's clearance is the nearest of them, as a brute force gives it."""
    material = np.ones((21, 21), dtype=bool)
    material[10, 10] = False
    grid = Grid(origin=np.zeros(2), cell=1.0, material=material, solid=material)
    angles = np.linspace(0.0, 2.0 * np.pi, 720, endpoint=False)
    for radius in (2.5 - 1e-9, 2.45, 2.2):
        ring = np.array([10.5, 10.5]) + radius * np.column_stack([np.cos(angles), np.sin(angles)])
        made = replace(scene, grid=grid, material_xy=np.asfortranarray(ring), cell=1.0, min_radius=1.5)
        assert made.void_reach == 2.5
        expected, _ = cKDTree(ring).query([[10.5, 10.5]])
        assert made.empty_cell_clearance[10, 10] == expected[0] < 2.5
        assert np.count_nonzero(np.isfinite(made.empty_cell_clearance)) == 1
