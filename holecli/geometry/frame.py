"""Rotation of a cloud into the frame of its plane, and back.

The paper's Eq. (9)/(10) is not a rotation matrix as printed (METHOD.md, errata); this module uses the
standard Rodrigues formula ``R = I + sin(t) K + (1 - cos(t)) K^2``, with ``K`` the cross-product matrix of
the unit axis, and treats the two degenerate normals (+z and -z) explicitly.
"""

from __future__ import annotations

import numpy as np

from holecli.errors import PointsError
from holecli.settings import DEFAULT_SETTINGS

_Z = np.array([0.0, 0.0, 1.0])
# Below this sine the axis n x z is numerically undefined and n is taken as +z or -z.
_PARALLEL_SINE = 1e-12


def _unit(vector, name):
    vector = np.asarray(vector, dtype=np.float64).reshape(-1)
    if vector.shape != (3,) or not np.all(np.isfinite(vector)):
        raise PointsError(f"{name} must be a finite 3-vector, got {vector!r}")
    norm = np.linalg.norm(vector)
    if norm == 0.0:
        raise PointsError(f"{name} must not be the zero vector")
    return vector / norm


def cross_matrix(axis):
    """The matrix ``K`` with ``K @ v == np.cross(axis, v)``.

    Parameters
    ----------
    axis : (3,) float

    Returns
    -------
    (3, 3) float ndarray
        The skew-symmetric cross-product matrix of ``axis``.
    """
    x, y, z = axis
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


def rotation_to_z(normal):
    """Rotation matrix that turns ``normal`` onto the z axis.

    Parameters
    ----------
    normal : (3,) float
        Direction to rotate; need not be unit length.

    Returns
    -------
    (3, 3) float ndarray
        Proper rotation ``R`` (``R @ R.T == I``, ``det R == 1``) with ``R @ n == (0, 0, 1)`` for the
        unit vector ``n`` along ``normal``. For ``n == +z`` it is the identity; for ``n == -z`` it is the
        half turn about the x axis.
    """
    n = _unit(normal, "normal")
    axis = np.cross(n, _Z)
    sine = np.linalg.norm(axis)
    cosine = float(np.dot(n, _Z))
    if sine < _PARALLEL_SINE:
        if cosine > 0:
            return np.eye(3)
        return np.diag([1.0, -1.0, -1.0])
    k = cross_matrix(axis / sine)
    return np.eye(3) + sine * k + (1.0 - cosine) * (k @ k)


def to_plane_frame(points, origin, rotation):
    """Coordinates of ``points`` in the frame centred on ``origin`` and rotated by ``rotation``.

    Parameters
    ----------
    points : (n, 3) float
        World coordinates.
    origin : (3,) float
        The frame's origin, world coordinates.
    rotation : (3, 3) float
        Rows: the frame's axes in world coordinates (as :func:`rotation_to_z` returns).

    Returns
    -------
    (n, 3) float ndarray
        ``(points - origin) @ rotation.T``.
    """
    return (np.asarray(points, dtype=np.float64) - origin) @ rotation.T


def from_plane_frame(local, origin, rotation):
    """Inverse of :func:`to_plane_frame`.

    Parameters
    ----------
    local : (n, 3) or (3,) float
        Plane-frame coordinates.
    origin : (3,) float
    rotation : (3, 3) float
        As for :func:`to_plane_frame`.

    Returns
    -------
    (n, 3) or (3,) float ndarray
        World coordinates ``local @ rotation + origin``.
    """
    return np.asarray(local, dtype=np.float64) @ rotation + origin


def check_view_angle(direction, min_sine=None, *, settings=DEFAULT_SETTINGS.plane):
    """Refuse a viewing direction that grazes the plane: a sensor looking along it cannot have seen
    the surface found (most likely a wall or a side, not the face it scanned).

    Parameters
    ----------
    direction : (3,) float
        The view in the plane frame (the plane's normal is z); need not be unit length.
    min_sine : float, optional
        Smallest sine of the angle between ``direction`` and the plane (default: ``settings.view_min_sine``).
    settings : holecli.settings.PlaneSettings or RobustSettings
        Source of ``min_sine`` when not given.

    Raises
    ------
    PointsError
        When ``direction`` is zero or within ``asin(min_sine)`` of the plane.
    """
    direction = _unit(direction, "view direction")
    min_sine = settings.view_min_sine if min_sine is None else min_sine
    if abs(direction[2]) < min_sine:
        raise PointsError(
            f"view direction {np.round(direction, 4).tolist()} is within "
            f"{np.degrees(np.arcsin(min(min_sine, 1.0))):.0f} degrees of the surface plane found; "
            "a sensor looking along it cannot have seen that surface"
        )


def canonical_rotation(points, plane):
    """Rotation into a frame that moves with the points: rows (major, minor, normal).

    ``plane`` is a :class:`holecli.geometry.plane.PlaneFit` of ``points`` with ``inliers`` and ``major`` (the
    in-plane direction of largest spread of its points). The major axis is turned so that the inliers'
    third moment along it is not negative, and ``minor = normal x major``. Coordinates in this frame
    (about the plane's centroid) do not change under a rigid motion of the cloud, so grids and windows
    laid out in them do not depend on how the part sat in the world (when the two in-plane spreads are
    exactly equal the axes are arbitrary).

    Parameters
    ----------
    points : (n, 3) float
        The cloud, world coordinates.
    plane : PlaneFit
        Its plane, with ``inliers`` and ``major`` set (:func:`holecli.geometry.plane.fit_plane_robust`).

    Returns
    -------
    (3, 3) float ndarray
        Rows (major, minor, normal): a proper rotation into the plane's frame.
    """
    normal = np.asarray(plane.normal, dtype=np.float64)
    major = np.asarray(plane.major, dtype=np.float64)
    along = points @ major - float(plane.point @ major)
    if _negative_sum_of_cubes(along[plane.inliers]):
        major = -major
    return np.vstack([major, np.cross(normal, major), normal])


def _negative_sum_of_cubes(values):
    """Whether ``np.sum(values ** 3) < 0``, without the power where the sign does not need it.

    ``x * x * x`` is some fifty times cheaper than ``x ** 3`` (a call of ``pow`` per value) and
    differs from it by a few units in the last place; the two sums differ by less than 256 machine
    epsilons of the sum of the magnitudes (the summation's own round-off, ``log2(n) + 16`` units
    for numpy's pairwise sum, included). A sum of products farther from zero than that has the sign
    of the sum of powers; nearer (a symmetric surface), the powers decide, as they always did.
    """
    cubes = values * values * values
    total = float(np.sum(cubes))
    if abs(total) > 256.0 * np.finfo(np.float64).eps * float(np.sum(np.abs(cubes))):
        return total < 0.0
    return float(np.sum(values ** 3)) < 0.0
