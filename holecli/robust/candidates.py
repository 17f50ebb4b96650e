"""Hole candidates in linear time: empty regions of an occupancy grid of the surface points.

The cell is a few gaps wide (see :mod:`holecli.settings`), so the material leaves at most isolated
empty cells, never a chain of them, whatever the sampling pattern. Two kinds of void come out:

* enclosed voids: empty regions not connected to the outside of the scan (a hole, or a natural gap);
* bays: empty regions inside the convex hull of the scan but open to its outside (a hole cut by the
  border, or a dent of a ragged border).

Both are only candidates: the local rim analysis (:mod:`holecli.robust.boundary`) decides.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage
from scipy.spatial import ConvexHull, QhullError

from holecli.settings import DEFAULT_SETTINGS

_CROSS = ndimage.generate_binary_structure(2, 1)
_SQUARE = np.ones((3, 3), dtype=bool)


@dataclass(frozen=True, eq=False)
class Grid:
    """An occupancy grid: cell (i, j) spans ``origin + (i, j) * cell`` to ``+ cell``."""

    origin: np.ndarray
    cell: float
    material: np.ndarray  # (nx, ny) bool, after removing specks smaller than 3 x 3 cells
    solid: np.ndarray     # the material with isolated empty cells (natural gaps of random sampling) filled

    def cell_of(self, xy):
        """Integer (i, j) cell indices of 2D points (may fall outside the grid).

        Parameters
        ----------
        xy : (n, 2) float

        Returns
        -------
        (n, 2) int64 ndarray
        """
        return np.floor((xy - self.origin) / self.cell).astype(np.int64)

    def center_of(self, ij):
        """Centers of the cells ``ij``.

        Parameters
        ----------
        ij : (k, 2) int

        Returns
        -------
        (k, 2) float ndarray
        """
        return self.origin + (np.asarray(ij) + 0.5) * self.cell

    def lookup(self, mask, xy):
        """Value of the (nx, ny) bool ``mask`` at each point (False outside the grid).

        Parameters
        ----------
        mask : (nx, ny) bool
            A mask of the grid's cells (``material``, ``solid``, a void).
        xy : (n, 2) float

        Returns
        -------
        (n,) bool ndarray
        """
        # Per column, as cell_of computes them (the same cells), and one flat index into the mask:
        # no (n, 2) temporaries on a million points.
        xy = np.asarray(xy, dtype=np.float64)
        i = np.floor((xy[:, 0] - self.origin[0]) / self.cell).astype(np.int64)
        j = np.floor((xy[:, 1] - self.origin[1]) / self.cell).astype(np.int64)
        inside = np.flatnonzero((i >= 0) & (j >= 0) & (i < mask.shape[0]) & (j < mask.shape[1]))
        out = np.zeros(len(xy), dtype=bool)
        out[inside] = np.ravel(mask)[i[inside] * mask.shape[1] + j[inside]]
        return out


@dataclass(frozen=True, eq=False)
class Void:
    """A candidate hole region of the grid.

    Attributes
    ----------
    cells : (k, 2) int
        Its empty cells.
    enclosed : bool
        True for an enclosed void, False for a bay open to the outside of the scan.
    """

    cells: np.ndarray
    enclosed: bool

    @property
    def lower(self):
        """(2,) int: the smallest cell indices of the void."""
        return self.cells.min(axis=0)

    @property
    def upper(self):
        """(2,) int: the largest cell indices of the void."""
        return self.cells.max(axis=0)


def occupancy_grid(xy, cell, max_speck_cells=None, *, settings=DEFAULT_SETTINGS.candidates):
    """The occupancy grid of ``xy`` at ``cell``, padded by at least two empty cells on every side.

    Specks (small clusters of occupied cells that hold no 3 x 3 block and touch no material: random
    reflections inside a hole) are removed by a morphological opening; they cannot be the edge of a
    hole.

    Parameters
    ----------
    xy : (n, 2) float
        Surface points in the plane frame.
    cell : float
        The cell's side, file units (``cell_gaps`` gaps in the pipeline).
    max_speck_cells : int, optional
        Largest cluster of occupied cells that can be a speck (default: ``settings.max_speck_cells``).
    settings : holecli.settings.CandidateSettings or RobustSettings
        Source of ``max_speck_cells`` when not given.

    Returns
    -------
    Grid
    """
    max_speck_cells = settings.max_speck_cells if max_speck_cells is None else max_speck_cells
    # Cell boundaries at whole multiples of the cell from the frame's origin (the points' centroid in
    # the pipeline), so that the grid is the same after a half turn of the frame.
    origin = (np.floor(xy.min(axis=0) / cell) - 2.0) * cell
    shape = tuple(np.floor((xy.max(axis=0) - origin) / cell).astype(int) + 3)
    ij = np.floor((xy - origin) / cell).astype(np.int64)
    occupied = np.zeros(shape, dtype=bool)
    occupied[ij[:, 0], ij[:, 1]] = True
    opened = ndimage.binary_opening(occupied, structure=_SQUARE)
    # The opening also thins a narrow strip of real material (between a hole and the scan's edge).
    # Specks are small clusters that touch neither the material nor the scan's exterior; anything
    # else the opening removed (cells of a jagged rim, a narrow strip) is given back.
    removed, count = ndimage.label(occupied & ~opened, structure=_SQUARE)
    if count:
        sizes = np.bincount(removed.ravel())
        empty_labels, _ = ndimage.label(~occupied, structure=_CROSS)
        exterior = empty_labels == empty_labels[0, 0]
        keep = sizes > max_speck_cells
        for neighbour in (opened, exterior):
            touching = ndimage.binary_dilation(neighbour, structure=_SQUARE) & (removed > 0)
            keep[np.unique(removed[touching])] = True
        keep[0] = False
        opened |= keep[removed]
    solid = ndimage.binary_closing(opened, structure=_SQUARE) | opened
    return Grid(origin=origin, cell=float(cell), material=opened, solid=solid)


def _hull_mask(material):
    """Cells whose centers lie inside the convex hull of the material cells' centers."""
    mask = np.zeros_like(material)
    edge = material & ~ndimage.binary_erosion(material, structure=_CROSS)
    points = np.argwhere(edge).astype(np.float64)
    if len(points) < 3:
        return mask
    try:
        hull = ConvexHull(points)
    except QhullError:
        return mask
    # Half-planes a.x <= b of the hull, tested on every cell center row by row (vectorised per row).
    normals = hull.equations[:, :2]
    offsets = -hull.equations[:, 2]
    i_values = np.arange(material.shape[0], dtype=np.float64)
    j_values = np.arange(material.shape[1], dtype=np.float64)
    tolerance = 1e-9
    # For each row i, the admissible j interval is the intersection of the half-plane intervals.
    low = np.full(material.shape[0], -np.inf)
    high = np.full(material.shape[0], np.inf)
    for (a, b), c in zip(normals, offsets):
        rhs = c - a * i_values + tolerance
        if abs(b) < 1e-12:
            blocked = rhs < 0
            low[blocked], high[blocked] = np.inf, -np.inf
        elif b > 0:
            high = np.minimum(high, rhs / b)
        else:
            low = np.maximum(low, rhs / b)
    inside = (j_values[None, :] >= low[:, None]) & (j_values[None, :] <= high[:, None])
    return inside


def find_voids(grid, min_cells=1):
    """Enclosed voids and bays of ``grid``.

    Parameters
    ----------
    grid : Grid
    min_cells : int
        Fewest cells of a void reported (a bay needs at least two).

    Returns
    -------
    list of Void
        Enclosed voids first, then bays, each list in grid order.
    """
    labels, count, outside = _empty_regions(grid)
    voids = []
    if count:
        objects = ndimage.find_objects(labels)
        for label, box in enumerate(objects, start=1):
            if label == outside or box is None:
                continue
            cells = np.argwhere(labels[box] == label) + [box[0].start, box[1].start]
            if len(cells) >= min_cells:
                voids.append(Void(cells=cells, enclosed=True))
    bays = (labels == outside) & _hull_mask(grid.material)
    bay_labels, bay_count = ndimage.label(bays, structure=_CROSS)
    for label, box in enumerate(ndimage.find_objects(bay_labels), start=1):
        if box is None:
            continue
        cells = np.argwhere(bay_labels[box] == label) + [box[0].start, box[1].start]
        if len(cells) >= max(min_cells, 2):
            voids.append(Void(cells=cells, enclosed=False))
    return voids


def distance_to_outside(grid):
    """Per cell of ``grid``, the distance (scan units) from its center to the nearest cell of the
    scan's outside: the empty cells connected to the grid's padding (what :func:`find_voids` calls
    outside, and measures bays in).

    Parameters
    ----------
    grid : Grid

    Returns
    -------
    (nx, ny) float ndarray
    """
    labels, _, outside = _empty_regions(grid)
    return ndimage.distance_transform_edt(labels != outside) * grid.cell


def scanned_hull(grid):
    """The cells of ``grid`` inside the convex hull of its material: the scan's extent, holes and bays
    (what :func:`find_voids` measures bays in) included, what lies beyond the scan's border not.

    Parameters
    ----------
    grid : Grid

    Returns
    -------
    (nx, ny) bool ndarray
    """
    return _hull_mask(grid.material)


def _empty_regions(grid):
    """The connected regions of the grid's empty cells (4-connected), their count and the label of
    the outside (the region of the padding corner)."""
    labels, count = ndimage.label(~grid.material, structure=_CROSS)
    return labels, count, labels[0, 0]
