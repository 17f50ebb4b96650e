"""The paper's rim segmentation: Delaunay triangle areas against a 95 % confidence bound.

Kept literally for ``--method paper``; METHOD.md explains why it fails on noisy data (for large
triangle counts the bound collapses to the mean area) and on scans with ragged borders or several holes.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import ConvexHull, Delaunay, QhullError

from holecli.errors import PointsError

# The paper's confidence level: mean + 1.96 sd / sqrt(n) bounds the mean area at 95 %.
CONFIDENCE_Z = 1.96


def triangle_areas(xy, simplices):
    """Areas of triangles.

    Parameters
    ----------
    xy : (n, 2) float
        Vertices.
    simplices : (m, 3) int
        Rows of ``xy``, one triangle each.

    Returns
    -------
    (m,) float
        Unsigned areas.
    """
    a = xy[simplices[:, 0]]
    b = xy[simplices[:, 1]]
    c = xy[simplices[:, 2]]
    return 0.5 * np.abs((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]))


def area_bound(areas, z=CONFIDENCE_Z):
    """The paper's Eq. (12): upper confidence bound on the mean triangle area.

    Parameters
    ----------
    areas : (m,) float
        Triangle areas, m >= 2.
    z : float
        Normal quantile of the bound (1.96: 95 %).

    Returns
    -------
    float
        ``mean + z * sd / sqrt(m)``.
    """
    return float(areas.mean() + z * areas.std(ddof=1) / np.sqrt(len(areas)))


def paper_rim(xy, return_bound=False):
    """Indices of the rim points of the single hole in ``xy`` by the paper's rule (sec. 2.4-2.5).

    Triangles whose area exceeds :func:`area_bound` are hole triangles; their vertices are the
    candidates, and the vertices of the candidates' convex hull are the rim.

    Parameters
    ----------
    xy : (n, 2) float
        Points projected onto the plane.
    return_bound : bool
        Also return the bound of :func:`area_bound` the triangles were compared with.

    Returns
    -------
    (m,) int ndarray
        Indices into ``xy`` of the rim points (empty when no triangle exceeds the bound).
    bound : float
        With ``return_bound`` only: the area bound, file units squared.
    """
    try:
        triangulation = Delaunay(xy)
    except QhullError as error:
        raise PointsError(f"Delaunay triangulation failed: {str(error).splitlines()[0]}") from None
    areas = triangle_areas(xy, triangulation.simplices)
    bound = area_bound(areas)
    large = areas > bound
    candidates = np.unique(triangulation.simplices[large])
    rim = np.empty(0, dtype=np.intp)
    if len(candidates) >= 3:
        try:
            rim = candidates[ConvexHull(xy[candidates]).vertices]
        except QhullError:
            pass
    return (rim, bound) if return_bound else rim
