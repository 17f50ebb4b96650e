"""Tests of holecli.robust.boundary: the alpha-shape rim of a hole, its outer envelope and the window cut."""

import numpy as np

from holecli.geometry.kernels import largest_angular_gap
from holecli.robust import boundary
from holecli.robust.boundary import Rim, hole_rim, near_box_edge, outer_envelope

H = 0.1
ALPHA = 2.5 * H / np.sqrt(2)  # the pipeline's alpha on a grid: 2.5 gaps, a gap being 0.71 h
CENTER = np.array([0.237, -0.111])
RADIUS = 1.2


def grid(xmin=-3.0, xmax=3.0, ymin=-3.0, ymax=3.0, angle_deg=13.0):
    x, y = np.meshgrid(np.arange(xmin, xmax + 1e-9, H), np.arange(ymin, ymax + 1e-9, H))
    angle = np.radians(angle_deg)
    c, s = np.cos(angle), np.sin(angle)
    u, v = x.ravel(), y.ravel()
    return np.column_stack([c * u - s * v, s * u + c * v])


def holed(xy, center=CENTER, radius=RADIUS):
    return xy[np.hypot(*(xy - center).T) >= radius]


def in_disk(center=CENTER, radius=RADIUS):
    return lambda positions: np.hypot(*(positions - center).T) < radius


def test_rim_of_a_grid_hole_hugs_the_edge():
    xy = holed(grid())
    rim = hole_rim(xy, in_disk(), ALPHA)
    assert isinstance(rim, Rim) and not rim.open
    distance = np.hypot(*(xy[rim.index] - CENTER).T)
    # Material points, all outside the edge and within about alpha of it.
    assert distance.min() >= RADIUS
    assert distance.max() < RADIUS + ALPHA
    # The rim goes all the way round, with no gap wider than a few spacings.
    assert largest_angular_gap(xy[rim.index], CENTER) * RADIUS < 4 * H  # measured 3 h
    # The material point nearest the edge is on it (others as close as 0.46 h can hide behind a
    # rim edge between two nearer points).
    assert np.argmin(np.hypot(*(xy - CENTER).T)) in set(rim.index)


def test_rim_does_not_depend_on_the_point_order(rng):
    xy = holed(grid())
    order = rng.permutation(len(xy))
    reference = hole_rim(xy, in_disk(), ALPHA)
    permuted = hole_rim(xy[order], in_disk(), ALPHA)
    np.testing.assert_array_equal(np.sort(order[permuted.index]), np.sort(reference.index))


def test_a_hole_cut_by_the_border_is_open():
    center = np.array([2.0, 3.0])  # on the top border of the patch
    xy = holed(grid(angle_deg=0.0), center=center)
    rim = hole_rim(xy, in_disk(center=center), ALPHA)
    assert rim.open
    distance = np.hypot(*(xy[rim.index] - center).T)
    assert distance.min() >= RADIUS and np.percentile(distance, 90) < RADIUS + ALPHA


def test_islands_inside_the_hole_are_not_rim():
    xy = holed(grid())
    # A 3 x 3 block of reflections near the middle of the hole, and a single stray point.
    block = CENTER + 0.3 + H * np.stack(np.meshgrid(np.arange(3), np.arange(3)), axis=-1).reshape(-1, 2)
    stray = CENTER + np.array([[-0.5, 0.2]])
    points = np.concatenate([xy, block, stray])
    rim = hole_rim(points, in_disk(), ALPHA)
    assert rim is not None and not rim.open
    assert not np.any(rim.index >= len(xy))
    assert np.hypot(*(points[rim.index] - CENTER).T).min() >= RADIUS


def test_no_hole_no_rim():
    xy = grid()
    assert hole_rim(xy, in_disk(), ALPHA) is None
    # A void smaller than alpha is a natural gap, not a hole.
    small = holed(xy, radius=0.12)
    assert hole_rim(small, in_disk(radius=0.12), ALPHA) is None
    assert hole_rim(xy[:3], in_disk(), ALPHA) is None


def test_the_window_cut_keeps_the_rim_on_the_hole():
    """A box of points cut out around the hole: triangles along the cut are material, not hole."""
    xy = holed(grid(-6.0, 6.0, -6.0, 6.0))
    low, high = CENTER - 2.0, CENTER + 2.0
    local = xy[np.all((xy >= low) & (xy <= high), axis=1)]
    cut = near_box_edge(local, low, high, 2.0 * ALPHA)
    rim = hole_rim(local, in_disk(), ALPHA, cut=cut)
    assert not rim.open
    distance = np.hypot(*(local[rim.index] - CENTER).T)
    assert distance.min() >= RADIUS and distance.max() < RADIUS + ALPHA
    assert not np.any(cut[rim.index])


def test_near_box_edge():
    xy = np.array([[0.0, 0.0], [0.95, 0.5], [0.5, 0.05], [0.5, 0.5]])
    np.testing.assert_array_equal(near_box_edge(xy, np.zeros(2), np.ones(2), 0.1), [True, True, True, False])


def test_outer_envelope_drops_points_deeper_in_the_hole():
    angles = np.linspace(0.0, 2 * np.pi, 72, endpoint=False)
    edge = CENTER + RADIUS * np.column_stack([np.cos(angles), np.sin(angles)])
    # Reflections next to the edge join the rim of a triangulation; they lie deeper than the edge.
    deep_angles = angles[::6] + 0.01
    deep = CENTER + (RADIUS - 0.3) * np.column_stack([np.cos(deep_angles), np.sin(deep_angles)])
    rim = np.concatenate([edge, deep])
    keep = outer_envelope(rim, CENTER, depth=0.1, sectors=24)
    assert keep[: len(edge)].all()
    assert not keep[len(edge):].any()
    # A depth larger than the offset keeps everything.
    assert outer_envelope(rim, CENTER, depth=0.5, sectors=24).all()


def test_outer_envelope_keeps_a_noisy_edge():
    for seed in range(200):
        rng = np.random.default_rng(seed)
        angles = rng.uniform(0.0, 2 * np.pi, 200)
        radius = RADIUS + rng.normal(0.0, 0.01, 200)
        rim = CENTER + radius[:, None] * np.column_stack([np.cos(angles), np.sin(angles)])
        assert outer_envelope(rim, CENTER, depth=ALPHA, sectors=len(rim) // 3).all(), seed


def test_components_are_the_groups_a_search_through_shared_edges_finds():
    """Random triangulations and random kept triangles: the same groups (labels are used as sets) as a
    breadth-first search over the kept neighbours, and -1 on the triangles not kept."""
    from scipy.spatial import Delaunay

    from holecli.robust.boundary import _components

    rng = np.random.default_rng(3)
    for trial in range(30):
        neighbors = Delaunay(rng.uniform(0.0, 10.0, (int(rng.integers(4, 400)), 2))).neighbors
        keep = rng.random(len(neighbors)) < rng.uniform(0.1, 0.95)
        expected = np.full(len(neighbors), -1)
        for start in np.flatnonzero(keep):
            if expected[start] >= 0:
                continue
            expected[start], queue = start, [start]
            while queue:
                for other in neighbors[queue.pop()]:
                    if other >= 0 and keep[other] and expected[other] < 0:
                        expected[other] = start
                        queue.append(other)
        labels = _components(neighbors, keep)
        np.testing.assert_array_equal(labels < 0, ~keep, err_msg=str(trial))
        pairs = set(zip(labels[keep], expected[keep]))
        assert len(pairs) == len(set(labels[keep])) == len(set(expected[keep])), trial


def ring_window(xy, center, inner, outer, trim):
    """A ring of ``xy`` cut like a void's neighbourhood (holecli.robust.measure): ``(local, cut, near,
    encloses)`` with a cut zone of two alphas and a window ``trim`` narrower."""
    distance = np.hypot(*(xy - center).T)
    local = xy[(distance >= inner) & (distance < outer)]
    reach = np.hypot(*(local - center).T)

    def encloses(centers, radii):
        return np.hypot(*(centers - center).T) + radii < outer - trim

    return local, reach > outer - 2.0 * ALPHA, reach < outer - trim, encloses


def narrow_and_full(local, cut, near, encloses, in_hole, monkeypatch):
    """The rim from the narrower window (hole_rim_within), whether the whole ring was triangulated
    again, and hole_rim's rim without the window."""
    calls = []
    triangulated = boundary._hole_rim

    def counted(*args, **kwargs):
        calls.append(1)
        return triangulated(*args, **kwargs)

    monkeypatch.setattr(boundary, "_hole_rim", counted)
    narrow = hole_rim(local, in_hole, ALPHA, cut=cut, window=(near, encloses))
    monkeypatch.undo()
    return narrow, len(calls) > 1, hole_rim(local, in_hole, ALPHA, cut=cut)


def same(one, other):
    if one is None or other is None:
        return one is None and other is None
    return np.array_equal(one.index, other.index) and one.open == other.open


def test_a_hole_surrounded_by_material_takes_its_rim_from_the_narrower_ring(monkeypatch, rng):
    """On a grid and on random points the narrower ring passes the checks and gives the full ring's
    rim; so does a hole with no rim (a natural gap)."""
    random = rng.uniform(-3.0, 3.0, size=(3600, 2))
    for xy in (holed(grid()), holed(random), holed(grid(), radius=0.12)):
        outer = RADIUS + 3.0 * ALPHA + 2.0 * H
        local, cut, near, encloses = ring_window(xy, CENTER, 0.5, outer, ALPHA)
        narrow, again, full = narrow_and_full(local, cut, near, encloses, in_disk(), monkeypatch)
        assert same(narrow, full)
        assert not again


def test_a_border_a_slot_or_a_neighbour_across_the_ring_falls_back_to_the_full_ring(monkeypatch):
    """Where the void's region or the end of the scan reaches the left-out points the checks fail
    and the whole ring is triangulated (the scan's border, a wide slot, sparse points around the
    hole); a second hole the region does not reach changes nothing. The rim is hole_rim's."""
    outer = RADIUS + 3.0 * ALPHA + 2.0 * H
    xy = holed(grid())
    border = xy[xy[:, 0] < CENTER[0] + RADIUS + 0.5 * ALPHA]  # the scan ends just past the hole
    slot = xy[~((np.abs(xy[:, 1] - CENTER[1]) < 0.5) & (xy[:, 0] > CENTER[0]))]  # a slot out of the hole
    second = holed(xy, center=CENTER + [RADIUS + 2.2 * ALPHA + 0.3, 0.0], radius=0.3)  # a neighbour
    # Burrs and reflections: sparse points (gaps wider than alpha) from just outside the edge outwards.
    keep = np.random.default_rng(5).uniform(size=len(xy)) < 0.05
    sparse = xy[keep | (np.hypot(*(xy - CENTER).T) < RADIUS + 0.5 * ALPHA)]
    for cloud, falls_back in ((border, True), (slot, True), (second, False), (sparse, True)):
        local, cut, near, encloses = ring_window(cloud, CENTER, 0.5, outer, ALPHA)
        narrow, again, full = narrow_and_full(local, cut, near, encloses, in_disk(), monkeypatch)
        assert full is not None and same(narrow, full)
        assert again == falls_back
    # A partial hole's rim is open: the narrower ring cannot give it.
    partial = xy[xy[:, 0] < CENTER[0] + 0.5 * RADIUS]
    local, cut, near, encloses = ring_window(partial, CENTER, 0.5, outer, ALPHA)
    narrow, again, _ = narrow_and_full(local, cut, near, encloses, in_disk(), monkeypatch)
    assert narrow.open and again


def test_the_narrower_window_must_leave_out_only_cut_points():
    """Points left out that are not cut could end the hole region: the full set is triangulated."""
    xy = holed(grid())
    outer = RADIUS + 3.0 * ALPHA + 2.0 * H
    local, cut, near, encloses = ring_window(xy, CENTER, 0.5, outer, 3.0 * ALPHA)
    assert not np.all(cut[~near])
    assert same(hole_rim(local, in_disk(), ALPHA, cut=cut, window=(near, encloses)),
                hole_rim(local, in_disk(), ALPHA, cut=cut))


def test_a_box_window_takes_its_rim_from_the_narrower_box(monkeypatch):
    """A bay's neighbourhood is a box: its narrower window an alpha inside every side."""
    xy = holed(grid(-6.0, 6.0, -6.0, 6.0))
    low, high = CENTER - 2.0, CENTER + 2.0
    local = xy[np.all((xy >= low) & (xy <= high), axis=1)]
    cut = near_box_edge(local, low, high, 2.0 * ALPHA)
    near = ~near_box_edge(local, low, high, ALPHA)

    def encloses(centers, radii):
        return (np.all(centers - radii[:, None] > low + ALPHA, axis=1)
                & np.all(centers + radii[:, None] < high - ALPHA, axis=1))

    narrow, again, full = narrow_and_full(local, cut, near, encloses, in_disk(), monkeypatch)
    assert full is not None and same(narrow, full) and not again
