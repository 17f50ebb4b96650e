"""Tests of holecli.robust.candidates: the occupancy grid, speck removal, enclosed voids and bays."""

import numpy as np
import pytest

from holecli.robust.candidates import Grid, Void, distance_to_outside, find_voids, occupancy_grid
from holecli.settings import DEFAULT_SETTINGS

H = 0.1
CELL = 0.15  # about two gaps of a grid of spacing h (the pipeline's cell)


def patch(xmin=-3.0, xmax=3.0, ymin=-3.0, ymax=3.0, step=H):
    x, y = np.meshgrid(np.arange(xmin, xmax + 1e-9, step), np.arange(ymin, ymax + 1e-9, step))
    return np.column_stack([x.ravel(), y.ravel()]) + 0.0123


def outside_disk(xy, center, radius):
    return xy[np.hypot(*(xy - center).T) >= radius]


def void_centers(grid, void):
    return grid.center_of(void.cells)


def test_grid_bookkeeping():
    xy = patch()
    grid = occupancy_grid(xy, CELL)
    assert isinstance(grid, Grid) and grid.cell == CELL
    # Empty padding on every side (the docstring says two cells; on the low side round-off in
    # floor((min - (min - 2 cell)) / cell) can leave one), so the outside is one connected region.
    assert not grid.material[0].any() and not grid.material[-2:].any()
    assert not grid.material[:, 0].any() and not grid.material[:, -2:].any()
    # Every point falls in a material cell, and its cell's center is within half a cell diagonal.
    assert grid.lookup(grid.material, xy).all()
    centers = grid.center_of(grid.cell_of(xy))
    assert np.all(np.abs(centers - xy) <= 0.5 * CELL + 1e-12)
    # Outside the grid the lookup is False, not an index error.
    assert not grid.lookup(grid.material, np.array([[1e3, 1e3], [-1e3, 0.0]])).any()


def test_no_hole_no_void():
    assert find_voids(occupancy_grid(patch(), CELL)) == []


def test_an_enclosed_void():
    center, radius = np.array([0.31, -0.17]), 1.0
    grid = occupancy_grid(outside_disk(patch(), center, radius), CELL)
    voids = find_voids(grid)
    assert len(voids) == 1
    void = voids[0]
    assert isinstance(void, Void) and void.enclosed
    distance = np.hypot(*(void_centers(grid, void) - center).T)
    # Only cells that reach into the hole, and every cell that lies entirely inside it.
    assert distance.max() < radius + CELL * np.sqrt(2) / 2
    whole = np.argwhere(np.ones_like(grid.material))
    inside = np.hypot(*(grid.center_of(whole) - center).T) < radius - CELL * np.sqrt(2) / 2
    assert {tuple(c) for c in whole[inside]} <= {tuple(c) for c in void.cells}
    assert np.all(void.lower <= void.cells) and np.all(void.cells <= void.upper)


def test_a_bay_is_a_hole_cut_by_the_border():
    xy = outside_disk(patch(), np.array([3.0, 0.4]), 1.0)
    voids = find_voids(occupancy_grid(xy, CELL))
    assert [void.enclosed for void in voids] == [False]
    grid = occupancy_grid(xy, CELL)
    distance = np.hypot(*(void_centers(grid, voids[0]) - [3.0, 0.4]).T)
    assert distance.max() < 1.0 + CELL * np.sqrt(2) / 2


def test_two_holes_two_voids():
    xy = outside_disk(outside_disk(patch(), np.array([-1.5, 0.0]), 0.8), np.array([1.5, 0.5]), 1.1)
    voids = find_voids(occupancy_grid(xy, CELL))
    assert len(voids) == 2 and all(void.enclosed for void in voids)


def test_specks_inside_a_hole_are_removed():
    center, radius = np.array([0.0, 0.0]), 1.5
    material = outside_disk(patch(), center, radius)
    # A few reflections scattered inside the hole, well apart from each other and from the edge.
    angles = np.linspace(0.0, 2 * np.pi, 6, endpoint=False)
    specks = center + 0.7 * np.column_stack([np.cos(angles), np.sin(angles)])
    specks = np.concatenate([specks, specks + [0.03, 0.02]])  # pairs: still far below a 3 x 3 block
    grid = occupancy_grid(np.concatenate([material, specks]), CELL)
    assert not grid.lookup(grid.material, specks).any()
    assert grid.lookup(grid.material, material).all()
    voids = find_voids(grid)
    assert len(voids) == 1 and voids[0].enclosed
    speck_cells = {tuple(c) for c in grid.cell_of(specks)}
    assert speck_cells <= {tuple(c) for c in voids[0].cells}


def test_a_large_island_inside_a_hole_is_material():
    """A cluster of more than max_speck_cells cells (a boss, debris) stays: the void becomes a ring."""
    center = np.array([0.0, 0.0])
    material = outside_disk(patch(), center, 2.0)
    island = patch(-0.5, 0.5, -0.5, 0.5)
    grid = occupancy_grid(np.concatenate([material, island]), CELL)
    assert np.count_nonzero(grid.lookup(grid.material, island)) == len(island)
    assert len(np.unique(grid.cell_of(island), axis=0)) > DEFAULT_SETTINGS.max_speck_cells
    voids = find_voids(grid)
    assert len(voids) == 1
    distance = np.hypot(*(void_centers(grid, voids[0]) - center).T)
    assert distance.min() > 0.5


@pytest.mark.parametrize("strip", [1.5 * CELL, 2.5 * CELL])
def test_a_narrow_strip_of_material_is_kept(strip):
    """A hole whose edge comes within ``strip`` of the scan's edge is still enclosed by that strip."""
    radius = 1.0
    center = np.array([3.0123 - strip - radius, 0.0])
    xy = outside_disk(patch(), center, radius)
    grid = occupancy_grid(xy, CELL)
    near = xy[(xy[:, 0] > center[0] + radius) & (np.abs(xy[:, 1] - center[1]) < 0.3)]
    assert len(near) > 0
    assert grid.lookup(grid.material, near).all()
    voids = find_voids(grid)
    assert [void.enclosed for void in voids] == [True]


def test_min_cells():
    xy = outside_disk(patch(), np.array([0.0, 0.0]), 0.5)
    grid = occupancy_grid(xy, CELL)
    (void,) = find_voids(grid)
    assert find_voids(grid, min_cells=len(void.cells) + 1) == []
    assert len(find_voids(grid, min_cells=len(void.cells))) == 1


def test_a_concave_border_makes_a_bay_not_a_void():
    """An L-shaped patch: the missing quadrant lies in the convex hull but is open to the outside."""
    xy = patch()
    xy = xy[~((xy[:, 0] > 1.0) & (xy[:, 1] > 1.0))]
    voids = find_voids(occupancy_grid(xy, CELL))
    assert voids and not any(void.enclosed for void in voids)


def test_the_cell_index_of_many_candidates_changes_no_result():
    """Random sampling with natural gaps: the same holes, rejections and numbers whether the
    neighbourhood queries go through the cell index or a pass over the points."""
    from dataclasses import replace

    from holecli.pipeline import detect
    from holecli.settings import DEFAULT_SETTINGS
    from holecli.simulation.synth import HoleSpec, SceneSpec, make_scan

    scene = SceneSpec(holes=(HoleSpec(center=(0.3, -0.2), diameter=3.0), HoleSpec(center=(-4.0, 3.0), diameter=2.0)),
                      extent=(-8.0, 8.0, -8.0, 8.0), spacing=0.1, pattern="random")
    points = make_scan(scene, 3).points
    indexed = detect(points, settings=replace(DEFAULT_SETTINGS, cell_index_from_candidates=1), min_diameter=0.05)
    passes = detect(points, settings=replace(DEFAULT_SETTINGS, cell_index_from_candidates=10 ** 12), min_diameter=0.05)
    assert len(indexed.rejected) >= 5  # natural gaps measured (and refused) through the index
    assert indexed.holes == passes.holes
    assert indexed.rejected == passes.rejected


def test_natural_gaps_are_refused_before_their_rim_is_extracted(monkeypatch):
    """Random sampling's natural gaps (no empty disk of the smallest reported radius fits in them) are
    refused as ``below_min_diameter`` without a triangulation: the rim is extracted for the holes and
    a few gaps only, not for each of the hundreds of gaps."""
    import holecli.robust.measure as measure
    from holecli.pipeline import detect
    from holecli.simulation.synth import HoleSpec, SceneSpec, make_scan

    calls = []
    real_hole_rim = measure.hole_rim

    def counting_hole_rim(*args, **kwargs):
        calls.append(1)
        return real_hole_rim(*args, **kwargs)

    monkeypatch.setattr(measure, "hole_rim", counting_hole_rim)
    scene = SceneSpec(holes=(HoleSpec(center=(0.3, -0.2), diameter=3.0),), extent=(-10.0, 10.0, -10.0, 10.0),
                      spacing=0.05, pattern="random")
    detection = detect(make_scan(scene, 1).points)
    assert len(detection.holes) == 1
    early = [r for r in detection.rejected if r.check == "below_min_diameter"]
    assert len(early) > 50
    assert len(calls) < len(detection.rejected) / 4


def test_distance_to_outside_counts_from_the_scan_s_outside_not_from_its_holes():
    grid = occupancy_grid(outside_disk(patch(), np.array([0.0, 0.0]), 1.0), CELL)
    distance = distance_to_outside(grid)
    middle = grid.cell_of(np.array([[1.5, 0.0], [2.9, 0.0], [0.0, 0.0]]))
    near_hole, near_border, in_hole = (float(distance[i, j]) for i, j in middle)
    assert 1.3 < near_hole < 1.7           # 1.5 mm from the patch's edge at x = 3, not 0.5 from the hole
    assert near_border <= 3 * CELL          # 0.1 mm from the edge: the next cell or two
    assert in_hole > 2.5                   # the hole is no outside
    assert float(distance[0, 0]) == 0.0
