"""The paper's method (Khazali et al., section 2), with the errata of ``METHOD.md`` corrected: one hole
in a clean scan of a flat surface."""

from __future__ import annotations

import numpy as np

from holecli.errors import PointsError
from holecli.geometry.circle import fit_circle_geometric
from holecli.geometry.frame import from_plane_frame, rotation_to_z, to_plane_frame
from holecli.geometry.plane import fit_plane_svd
from holecli.paper.rim import paper_rim
from holecli.results import Hole, Plane, Scales


def _vector(array):
    return tuple(float(v) for v in array)


def detect_paper(points):
    """The paper's pipeline on checked points: SVD plane, rotation onto z, projection, Delaunay rim
    segmentation (:mod:`holecli.paper.rim`), convex hull, geometric circle fit, back-transform.

    Parameters
    ----------
    points : (n, 3) float64
        Finite points (see :func:`holecli.pipeline.validate_points`).

    Returns
    -------
    plane : Plane
    holes : tuple of Hole
        One hole, or none when the rim has fewer than three points or its circle fit fails.
    scales : Scales
        What the method measures of the sampling: only ``triangle_area_bound``, the Eq. (12) bound.
    """
    plane = fit_plane_svd(points)
    rotation = rotation_to_z(plane.normal)
    xy = to_plane_frame(points, plane.point, rotation)[:, :2]
    rim, bound = paper_rim(xy, return_bound=True)
    holes = ()
    if len(rim) >= 3:
        try:
            fit = fit_circle_geometric(xy[rim])
        except PointsError:
            fit = None
        if fit is not None:
            center = from_plane_frame(np.array([fit.center[0], fit.center[1], 0.0]), plane.point, rotation)
            holes = (
                Hole(
                    index=0,
                    center=_vector(center),
                    diameter=2.0 * fit.radius,
                    normal=_vector(plane.normal),
                    rim_points=int(len(rim)),
                    fit_rms=fit.rms,
                    max_residual=fit.max_residual,
                    roundness=fit.roundness,
                ),
            )
    plane_result = Plane(point=_vector(plane.point), normal=_vector(plane.normal), rms=plane.rms,
                         inliers=len(points))
    return plane_result, holes, Scales(triangle_area_bound=float(bound))
