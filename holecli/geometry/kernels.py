"""Small vectorised geometric kernels shared by the pipeline steps."""

from __future__ import annotations

import numpy as np
from scipy.spatial import Delaunay

# Relative size of the wobble that breaks the ties of a regular grid before triangulating it.
_WOBBLE = 1e-9


def triangulate(xy):
    """Delaunay triangulation of ``xy`` (n, 2), fast on regular grids as on random points.

    Four points of a square grid lie on one circle, and Qhull spends three times as long on such
    ties. The points are triangulated after a wobble of 1e-9 of their extent, a fixed function of
    each point's coordinates (so the result does not depend on their order); a tie can be broken
    either way without changing any circumradius beyond that size. Callers measure on the original
    coordinates. Raises ``scipy.spatial.QhullError`` like ``Delaunay``.
    """
    scale = float(np.max(np.ptp(xy, axis=0))) if len(xy) else 1.0
    scale = scale if scale > 0 else 1.0
    u = (xy - xy.min(axis=0)) / scale
    wobble = np.column_stack([np.sin(7.3e6 * u[:, 0] + 3.1e6 * u[:, 1]), np.sin(2.9e6 * u[:, 0] - 6.7e6 * u[:, 1])])
    return Delaunay(xy + (_WOBBLE * scale) * wobble)


def circles_through(a, b, c):
    """Circles through the point triples ``a``, ``b``, ``c`` (each (k, 2)).

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
