"""The rim of one hole from a local Delaunay triangulation: an alpha-shape boundary.

A Delaunay triangle's circumcircle holds no point, so a triangle whose circumradius exceeds ``alpha``
marks an empty disk larger than any natural gap of the sampling: a piece of a hole. The hole region is
the set of such triangles connected to the seed positions, together with any islands it surrounds
(reflections or debris inside the hole); the rim is the set of points on the edges between that region
and the surrounding material. Unlike the paper's convex hull of the candidates, this serves holes of
any number, next to ragged borders, and with points inside.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import QhullError

from holecli.geometry.kernels import circumradii, triangulate, wobble_frame


# A circle of hole_rim_within's check is widened by this much of the points' extent: far above the
# round-off of a circumcircle and the 1e-9 wobble of the triangulated points.
_CIRCLE_TOLERANCE = 1e-6


@dataclass(frozen=True, eq=False)
class Rim:
    """Rim points of a hole region.

    Attributes
    ----------
    index : (m,) int
        Indices (into the local points) of the rim points.
    open : bool
        True when the hole region reaches the outer boundary of the local points (a hole cut by the
        scan border, or a region that leaks out of the window).
    """

    index: np.ndarray
    open: bool


def _components(neighbors, keep):
    """Connected components of the triangles ``keep`` through shared edges (labels; -1 elsewhere).

    The graph is built as compressed rows straight from ``neighbors`` (three entries per triangle; a
    missing neighbour or one outside ``keep`` points the entry back at its own triangle). Delaunay
    neighbours are mutual, so the graph is symmetric and its strongly connected components are the
    undirected ones; scipy finds them in one pass, without the transpose the undirected search
    builds.
    """
    count = len(neighbors)
    rows = np.repeat(np.arange(count, dtype=np.int32), 3)
    cols = neighbors.ravel()
    linked = (cols >= 0) & keep[rows] & keep[np.maximum(cols, 0)]
    graph = csr_matrix((np.ones(3 * count), np.where(linked, cols, rows).astype(np.int32),
                        np.arange(0, 3 * count + 1, 3, dtype=np.int32)), shape=(count, count))
    _, labels = connected_components(graph, directed=True, connection="strong")
    labels = labels.astype(np.int64)
    labels[~keep] = -1
    return labels


def hole_rim(xy, in_hole, alpha, cut=None, window=None):
    """Rim of the hole that holds the positions ``in_hole`` marks.

    Parameters
    ----------
    xy : (n, 2) float
        Local surface points around the hole, projected onto the plane.
    in_hole : callable
        ``in_hole(positions) -> (k,) bool`` for (k, 2) positions: True where a position lies in the
        hole's empty region as the caller knows it (a void of the occupancy grid, a synthetic disk).
        Hole triangles whose circumcenter it marks seed the hole region.
    alpha : float
        Empty-circle radius above which a triangle belongs to a hole.
    cut : (n,) bool, optional
        Points within ``2 alpha`` of the line along which the local points were cut out of the scan:
        triangles touching them are material (the cut, not a hole, leaves gaps there).
    window : ((n,) bool, callable), optional
        With ``cut``: ``(near, encloses)``, a narrower window triangulated first, the rim kept where
        it provably is the same (:func:`hole_rim_within`).

    Returns
    -------
    Rim or None
        None when no hole triangle has its circumcenter in the marked region (the void is a natural
        gap smaller than alpha).
    """
    if window is not None and cut is not None:
        return hole_rim_within(xy, in_hole, alpha, cut, *window)
    return _hole_rim(xy, in_hole, alpha, cut)[0]


def _hole_rim(xy, in_hole, alpha, cut, frame=None):
    """:func:`hole_rim`, and what :func:`hole_rim_within` checks of it: ``(rim, triangulation,
    region, hull)`` -- the triangulation (None when there is none: too few points or a Qhull error),
    the hole region's triangles (bool per triangle; None without seeds) and the vertices on the
    triangulation's outer boundary (indices). ``frame``: :func:`triangulate`'s."""
    if len(xy) < 4:
        return None, None, None, None
    try:
        triangulation = triangulate(xy, frame)
    except QhullError:
        return None, None, None, None
    simplices = triangulation.simplices
    neighbors = triangulation.neighbors
    radius, centers = circumradii(xy, simplices)
    big = radius > alpha
    # On the outer boundary a circumcircle reaches beyond the points, where nothing was scanned: a
    # large circle there shows the end of the scan, not a hole, unless the boundary edge itself is
    # wider than an alpha disk (the mouth of a hole cut by the border).
    t, k = np.nonzero(neighbors < 0)
    ends = simplices[t][np.arange(3)[None, :] != k[:, None]].reshape(-1, 2)
    if len(t):
        narrow = np.hypot(*(xy[ends[:, 0]] - xy[ends[:, 1]]).T) < 2.0 * alpha
        big[t[narrow]] = False
    if cut is not None:
        big[np.any(cut[simplices], axis=1)] = False
    seed_triangles = np.flatnonzero(big)
    seed_triangles = seed_triangles[in_hole(centers[seed_triangles])]
    if len(seed_triangles) == 0:
        return None, triangulation, None, ends.ravel()
    big_labels = _components(neighbors, big)
    region = np.isin(big_labels, np.unique(big_labels[seed_triangles]))
    # Everything not in the region, grouped; the groups that reach the triangulation's boundary are
    # the surrounding material, the others are islands the region encloses.
    other_labels = _components(neighbors, ~region)
    on_boundary = np.any(neighbors < 0, axis=1)
    outer_groups = np.unique(other_labels[on_boundary & ~region])
    outside = np.isin(other_labels, outer_groups) & ~region
    hole = ~outside
    # Rim edges: a hole triangle next to an outside triangle; neighbour k is opposite vertex k.
    t, k = np.nonzero(hole[:, None] & (neighbors >= 0) & outside[np.maximum(neighbors, 0)])
    keep = np.ones((len(t), 3), dtype=bool)
    keep[np.arange(len(t)), k] = False
    index = np.unique(simplices[t][keep])
    is_open = bool(np.any(region & on_boundary))
    return Rim(index=index, open=is_open), triangulation, region, ends.ravel()


def hole_rim_within(xy, in_hole, alpha, cut, near, encloses):
    """:func:`hole_rim` of ``xy``, from the triangulation of the points ``near`` alone where that
    provably gives the same rim.

    The points left out must all be ``cut`` (the outer part of the cut zone), and ``encloses`` must
    say which disks hold none of them. Among the points ``near``, the hole region is the full set's
    when (1) every vertex on the outer boundary of their triangulation is cut and (2) every
    triangle of their hole region has its circumcircle within a disk ``encloses`` accepts. Proof
    sketch (Delaunay triangles by their empty circles): a triangle without cut vertices of the full
    triangulation has its vertices among the points near and is a triangle of theirs, by (1) not on
    its outer boundary nor on the full one's, so the full hole region lies in theirs; by (2) each
    triangle of theirs has an empty circle in the full set too, so the regions are the same. By (1)
    the region keeps off both outer boundaries: the islands it encloses, the material outside it
    and so the rim are the same, and neither rim is open. Otherwise (a border, a slot or another void
    reaching the left-out points) the full set is triangulated.

    Parameters
    ----------
    xy, in_hole, alpha, cut
        As :func:`hole_rim` (``cut`` required).
    near : (n,) bool
        The points triangulated first.
    encloses : callable
        ``encloses(centers, radii) -> (k,) bool`` for (k, 2) centers and (k,) radii: True where the
        disk holds none of the points not ``near``.

    Returns
    -------
    Rim or None
        :func:`hole_rim` ``(xy, in_hole, alpha, cut)``.
    """
    if np.all(near) or not np.all(cut[~near]):
        return _hole_rim(xy, in_hole, alpha, cut)[0]
    frame = wobble_frame(xy)
    chosen = np.flatnonzero(near)
    rim, triangulation, region, hull = _hole_rim(xy[chosen], in_hole, alpha, cut[chosen], frame)
    if triangulation is None or not np.all(cut[chosen[hull]]):
        return _hole_rim(xy, in_hole, alpha, cut)[0]
    if rim is None:
        return None
    # The circles of the wobbled points the triangulation is of, a tolerance above their round-off.
    radius, centers = circumradii(triangulation.points, triangulation.simplices[region])
    if not np.all(encloses(centers, radius + _CIRCLE_TOLERANCE * frame[1])):
        return _hole_rim(xy, in_hole, alpha, cut)[0]
    return Rim(index=chosen[rim.index], open=rim.open)


def outer_envelope(rim_xy, center, depth, sectors):
    """Rim points within ``depth`` of the outermost rim point of their angular sector.

    Points inside a hole that lie closer than alpha to its edge join the material in the
    triangulation; they sit deeper in the hole than the true rim points of the same direction and
    are dropped here.

    Parameters
    ----------
    rim_xy : (m, 2) float
    center : (2,) float
        Current estimate of the hole's center.
    depth : float
        Depth below its sector's outermost point at which a rim point is dropped.
    sectors : int
        Number of equal angular sectors around ``center``.

    Returns
    -------
    (m,) bool
        True for the points kept.
    """
    offset = rim_xy - center
    radius = np.hypot(offset[:, 0], offset[:, 1])
    sector = ((np.arctan2(offset[:, 1], offset[:, 0]) + np.pi) / (2 * np.pi) * sectors).astype(np.int64)
    sector = np.clip(sector, 0, sectors - 1)
    outermost = np.full(sectors, -np.inf)
    np.maximum.at(outermost, sector, radius)
    return radius >= outermost[sector] - depth


def near_box_edge(xy, low, high, distance):
    """Points within ``distance`` of the sides of the box ``(low, high)`` (a ``cut`` for hole_rim).

    Parameters
    ----------
    xy : (n, 2) float
        Points inside the box.
    low, high : (2,) float
        The box's corners.
    distance : float

    Returns
    -------
    (n,) bool ndarray
    """
    clearance = np.minimum(np.min(xy - low, axis=1), np.min(high - xy, axis=1))
    return clearance < distance
