"""Small vectorised geometric kernels shared by the pipeline steps, and named helpers for idioms that
recur across holecli: the robust standard deviation, box queries, the largest angular gap and the
sign convention of normals."""

from __future__ import annotations

import math
import threading

import numpy as np
from scipy.spatial import Delaunay

# Relative size of the wobble that breaks the ties of a regular grid before triangulating it.
_WOBBLE = 1e-9
# Consistency constant of the median absolute deviation: 1 / Phi^-1(3/4), so that 1.4826 * median(|x|)
# is the standard deviation of normally distributed x of mean zero.
MAD_TO_SIGMA = 1.4826
# Below this magnitude a normal's component counts as zero for the sign convention.
_ZERO_COMPONENT = 1e-12
# Share of a scan's points above which a CellIndex query is a pass over them (box_indices): gathering
# and sorting a box's points from the cells costs about 30-70 ns per point, the pass 1-2 ns per point
# of the scan; the two cross at a share of 0.03-0.05 (random sampling, 10^5 to 2*10^6 points).
PASS_SHARE = 1.0 / 30.0


def robust_sigma(x):
    """Robust standard deviation of values about zero: ``1.4826 * median(|x|)``.

    Parameters
    ----------
    x : array_like of float
        Residuals (about zero: the median is of their magnitudes, not of their deviations from
        their own median).

    Returns
    -------
    float
        The scale, NaN for an empty ``x``.
    """
    return MAD_TO_SIGMA * float(np.median(np.abs(x)))


def box_indices(xy, low, high):
    """Indices of the points of ``xy`` inside the closed box ``[low, high]``.

    Parameters
    ----------
    xy : (n, 2) float
        Points; a Fortran-ordered array reads its columns contiguously.
    low, high : (2,) float
        Lower and upper corners of the box; a point on a side counts as inside.

    Returns
    -------
    (k,) int ndarray
        Rows of ``xy`` in the box, in increasing order.
    """
    # x first, then y over those points only: a box a few holes wide holds a small share of a scan's
    # x range, and the second pass reads that share instead of every point.
    index = np.flatnonzero((xy[:, 0] >= low[0]) & (xy[:, 0] <= high[0]))
    y = xy[index, 1]
    return index[(y >= low[1]) & (y <= high[1])]


def largest_angular_gap(xy, center):
    """Largest angle, seen from ``center``, between two angularly neighbouring points of ``xy``.

    Parameters
    ----------
    xy : (n, 2) float
        At least one point.
    center : (2,) float

    Returns
    -------
    float
        The gap in radians, in [0, 2 pi] (2 pi for a single point), the wrap-around from the last to
        the first angle included.
    """
    angles = np.sort(np.arctan2(xy[:, 1] - center[1], xy[:, 0] - center[0]))
    return float(np.max(np.diff(np.concatenate([angles, [angles[0] + 2 * np.pi]]))))


def orient_normal(normal):
    """Flip ``normal`` so that its z component is positive (ties: y, then x).

    This is holecli's sign convention for every normal it reports and for the truth of its
    simulations. A component of magnitude at most 1e-12 counts as zero (a wall given as a 90 degree
    rotation, cos 90 deg = 6e-17, is oriented by y); a vector with all three components that small
    is returned as it is.

    Parameters
    ----------
    normal : (3,) array_like of float

    Returns
    -------
    (3,) float ndarray
        ``normal`` or ``-normal``.
    """
    normal = np.asarray(normal, dtype=np.float64)
    for component in (2, 1, 0):
        if abs(normal[component]) > _ZERO_COMPONENT:
            return normal if normal[component] > 0 else -normal
    return normal


def wobble_frame(xy):
    """The origin (lowest coordinates) and extent (largest side, 1 when none) of ``xy`` (n, 2) that
    :func:`triangulate` wobbles its points in."""
    scale = float(np.max(np.ptp(xy, axis=0))) if len(xy) else 1.0
    scale = scale if scale > 0 else 1.0
    return (xy.min(axis=0) if len(xy) else np.zeros(2)), scale


def triangulate(xy, frame=None):
    """Delaunay triangulation of ``xy`` (n, 2), fast on regular grids as on random points.

    Four points of a square grid lie on one circle, and Qhull spends three times as long on such
    ties. The points are triangulated after a wobble of 1e-9 of their extent, a fixed function of
    each point's coordinates (so the result does not depend on their order); a tie can be broken
    either way without changing any circumradius beyond that size. Callers measure on the original
    coordinates. Raises ``scipy.spatial.QhullError`` like ``Delaunay``.

    Parameters
    ----------
    xy : (n, 2) float
        Points to triangulate.
    frame : ((2,) float, float), optional
        The origin and the extent the wobble is a function of (:func:`wobble_frame`); those of ``xy``
        when None. Points of a subset keep the whole set's wobble when given its frame.

    Returns
    -------
    scipy.spatial.Delaunay
        The triangulation of the wobbled points (its ``simplices`` index ``xy``).
    """
    origin, scale = wobble_frame(xy) if frame is None else frame
    u = (xy - origin) / scale
    wobble = np.column_stack([np.sin(7.3e6 * u[:, 0] + 3.1e6 * u[:, 1]), np.sin(2.9e6 * u[:, 0] - 6.7e6 * u[:, 1])])
    return Delaunay(xy + (_WOBBLE * scale) * wobble)


def circles_through(a, b, c):
    """Circles through the point triples ``a``, ``b``, ``c``.

    Parameters
    ----------
    a, b, c : (k, 2) float
        The three points of each triple.

    Returns
    -------
    center : (k, 2) float
    radius : (k,) float
        NaN or inf for a collinear triple.
    """
    b = b - a
    c = c - a
    d = 2.0 * (b[:, 0] * c[:, 1] - b[:, 1] * c[:, 0])
    b2 = np.sum(b * b, axis=1)
    c2 = np.sum(c * c, axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        ux = (c[:, 1] * b2 - b[:, 1] * c2) / d
        uy = (b[:, 0] * c2 - c[:, 0] * b2) / d
    return a + np.column_stack([ux, uy]), np.hypot(ux, uy)


def circumradii(xy, simplices):
    """Circumradius and circumcenter of each triangle.

    Parameters
    ----------
    xy : (n, 2) float
    simplices : (m, 3) int

    Returns
    -------
    radius : (m,) float
        ``inf`` for a degenerate (collinear) triangle.
    center : (m, 2) float
        The circumcenter (the centroid for a degenerate triangle).
    """
    a, b, c = xy[simplices[:, 0]], xy[simplices[:, 1]], xy[simplices[:, 2]]
    center, radius = circles_through(a, b, c)
    degenerate = ~np.isfinite(radius)
    if np.any(degenerate):
        # A collinear triangle's circle is unbounded; its centroid stands in for the center.
        radius[degenerate] = np.inf
        center[degenerate] = (a[degenerate] + b[degenerate] + c[degenerate]) / 3.0
    return radius, center


class CellIndex:
    """Points sorted by the square cell they fall in: a box query reads only the cells it covers.

    :func:`box_indices` reads every point, which is what a query costs once; a scan with many
    candidate holes (random sampling has natural gaps in proportion to its points) asks hundreds of
    them, and the work grows as points times candidates. The index costs one sort, and two integers
    per point, paid at the first query that reads the cells: an array only ever asked wide boxes is
    never sorted. A box expected to hold more than ``pass_share`` of the points is answered by
    :func:`box_indices`, which is then cheaper than gathering and sorting that many points from the
    cells.

    Parameters
    ----------
    xy : (n, 2) float
    cell : float
        Side of the cells, > 0. Made coarser when the points span more than 2^30 cells along an axis
        (a stray point far away), so that cell keys fit 64 bits.
    pass_share : float, optional
        Share of the points, estimated from the box's part of the points' bounding box, above which a
        query is a pass over the points (default :data:`PASS_SHARE`; above 1, every query reads the
        cells, but one across more columns of cells than there are points).
    """

    def __init__(self, xy, cell, pass_share=None):
        self.xy = xy
        self.pass_share = PASS_SHARE if pass_share is None else float(pass_share)
        self.cell = float(cell)
        self._sorted = None
        self._lock = threading.Lock()
        if len(xy) == 0:
            self.low, self.rows, self.columns = np.zeros(2), 1, 1
            self._bounds = (0.0, 0.0, 0.0, 0.0)
            return
        self.low, high = xy.min(axis=0), xy.max(axis=0)
        self.cell = max(self.cell, float(np.max(high - self.low)) / 2.0**30)
        # the last cell's column and row (a point's cell is floor((xy - low) / cell))
        self.columns, self.rows = (int(c) + 1 for c in np.floor((high - self.low) / self.cell))
        self._bounds = (float(self.low[0]), float(self.low[1]), float(high[0]), float(high[1]))

    def _keys_and_order(self):
        """The points' cell keys in increasing order and the rows of ``xy`` in that order, sorted at
        the first call (candidates may be measured in threads: one sort, under a lock)."""
        if self._sorted is None:
            with self._lock:
                if self._sorted is None:
                    cells = np.floor((self.xy - self.low) / self.cell).astype(np.int64)
                    keys = cells[:, 0] * self.rows + cells[:, 1]
                    # Not a stable sort (5x slower): the points of a cell come out in any order, and
                    # box() sorts what it returns.
                    order = np.argsort(keys).astype(np.int32 if len(keys) < 2**31 else np.int64)
                    self._sorted = (keys[order], order)
        return self._sorted

    def _share(self, x0, y0, x1, y1):
        """The part of the points' bounding box (area) that the box ``[x0, x1] x [y0, y1]`` covers:
        the share of the points it holds on a uniformly covered scan."""
        left, bottom, right, top = self._bounds
        width, height = min(x1, right) - max(x0, left), min(y1, top) - max(y0, bottom)
        if width < 0 or height < 0:
            return 0.0
        return (width / (right - left) if right > left else 1.0) * (height / (top - bottom) if top > bottom else 1.0)

    def _cell_range(self, start, stop, origin, count):
        """First and last cell (along one axis, ``count`` cells from ``origin``) of ``[start, stop]``,
        clipped to the points' cells; None when the span misses them."""
        # clipped before the floor, so that an infinite side is a finite cell
        first = math.floor(min(max((start - origin) / self.cell, -1.0), float(count)))
        last = math.floor(min(max((stop - origin) / self.cell, -1.0), float(count)))
        if last < 0 or first > count - 1:
            return None
        return max(first, 0), min(last, count - 1)

    def box(self, low, high):
        """Indices of the points inside the closed box ``[low, high]``, ascending (as
        :func:`box_indices` gives them).

        Parameters
        ----------
        low, high : (2,) float

        Returns
        -------
        (k,) int64
        """
        x0, y0, x1, y1 = float(low[0]), float(low[1]), float(high[0]), float(high[1])
        if len(self.xy) == 0 or not (x0 <= x1 and y0 <= y1):  # (also a NaN side)
            return np.zeros(0, dtype=np.int64)
        across = self._cell_range(x0, x1, self._bounds[0], self.columns)
        along = self._cell_range(y0, y1, self._bounds[1], self.rows)
        if across is None or along is None:
            return np.zeros(0, dtype=np.int64)
        # a search per column of cells: more columns than points (a stray point far away makes up to
        # 2^30 of them) cost more than the pass
        if self._share(x0, y0, x1, y1) > self.pass_share or across[1] - across[0] >= len(self.xy):
            return box_indices(self.xy, low, high)
        keys, order = self._keys_and_order()
        column_keys = np.arange(across[0], across[1] + 1, dtype=np.int64) * self.rows
        starts = np.searchsorted(keys, column_keys + along[0], side="left")
        ends = np.searchsorted(keys, column_keys + along[1], side="right")
        lengths = ends - starts
        total = int(lengths.sum())
        if total == 0:
            return np.zeros(0, dtype=np.int64)
        # positions starts[c] .. ends[c] - 1 of every column c, in one vector
        offsets = np.repeat(starts - (np.cumsum(lengths) - lengths), lengths)
        candidates = order[offsets + np.arange(total)]
        x, y = self.xy[candidates, 0], self.xy[candidates, 1]
        inside = (x >= x0) & (x <= x1) & (y >= y0) & (y <= y1)
        return np.sort(candidates[inside]).astype(np.int64)
