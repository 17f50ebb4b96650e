"""Small vectorised geometric kernels shared by the pipeline steps."""

from __future__ import annotations

import numpy as np


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
    a = xy[simplices[:, 0]]
    b = xy[simplices[:, 1]] - a
    c = xy[simplices[:, 2]] - a
    d = 2.0 * (b[:, 0] * c[:, 1] - b[:, 1] * c[:, 0])
    b2 = np.sum(b * b, axis=1)
    c2 = np.sum(c * c, axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        ux = (c[:, 1] * b2 - b[:, 1] * c2) / d
        uy = (b[:, 0] * c2 - c[:, 0] * b2) / d
    radius = np.hypot(ux, uy)
    center = a + np.column_stack([ux, uy])
    degenerate = ~np.isfinite(radius)
    if np.any(degenerate):
        # A collinear triangle's circle is unbounded; its centroid stands in for the center.
        radius[degenerate] = np.inf
        center[degenerate] = (a[degenerate] + xy[simplices[degenerate, 1]] + xy[simplices[degenerate, 2]]) / 3.0
    return radius, center
