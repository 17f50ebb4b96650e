"""Plane fits: the paper's SVD fit of all points, and a robust fit of the dominant surface."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from holecli.errors import PointsError


@dataclass(frozen=True, eq=False)
class PlaneFit:
    """A fitted plane.

    Attributes
    ----------
    point : (3,) float
        Centroid of the points fitted (a point on the plane).
    normal : (3,) float
        Unit normal, oriented by :func:`orient_normal`.
    rms : float
        Root mean square of the fitted points' distances to the plane.
    inliers : (n,) bool or None
        Which points the plane was fitted to (None: all of them).
    """

    point: np.ndarray
    normal: np.ndarray
    rms: float
    inliers: np.ndarray | None = None

    @property
    def inlier_count(self) -> int:
        return -1 if self.inliers is None else int(self.inliers.sum())


def orient_normal(normal):
    """Flip ``normal`` so that its z component is positive (ties: y, then x).

    This is holecli's sign convention for every normal it reports.
    """
    normal = np.asarray(normal, dtype=np.float64)
    for component in (2, 1, 0):
        if abs(normal[component]) > 1e-12:
            return normal if normal[component] > 0 else -normal
    return normal


def fit_plane_svd(points):
    """Least-squares plane through ``points`` by the SVD of the centred coordinates (paper, sec. 2.2).

    Parameters
    ----------
    points : (n, 3) float
        At least three points, not all on one line.

    Returns
    -------
    PlaneFit
        Centroid, unit normal (right-singular vector of the smallest singular value, oriented by
        :func:`orient_normal`) and rms distance.
    """
    points = np.asarray(points, dtype=np.float64)
    if points.ndim != 2 or points.shape[1] != 3 or len(points) < 3:
        raise PointsError(f"a plane needs an (n >= 3, 3) array, got shape {points.shape}")
    centroid = points.mean(axis=0)
    centred = points - centroid
    # Never form the n x n U of the paper's Eq. (5): the 3 x 3 right factor is all that is needed.
    _, singular, vt = np.linalg.svd(centred, full_matrices=False)
    if singular[1] <= 1e-12 * max(singular[0], 1e-300):
        raise PointsError("the points are collinear (or coincide): no plane is defined")
    normal = orient_normal(vt[2])
    rms = float(singular[2] / np.sqrt(len(points)))
    return PlaneFit(point=centroid, normal=normal, rms=rms)
