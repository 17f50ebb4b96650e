"""``detect``: the detection pipeline, composed from the geometric steps. No IO here."""

from __future__ import annotations

import time

import numpy as np

from holecli.circle import fit_circle_geometric
from holecli.errors import PointsError
from holecli.frame import from_plane_frame, rotation_to_z, to_plane_frame
from holecli.plane import fit_plane_svd
from holecli.results import Detection, Hole, Plane
from holecli.rim import paper_rim

METHODS = ("paper", "robust")
# Fewer points than this cannot hold a plane with a hole and a rim around it.
MIN_POINTS = 20


def validate_points(points):
    """Return ``points`` as a C-contiguous (n, 3) float64 array, or raise :class:`PointsError`."""
    array = np.asarray(points)
    if array.ndim != 2 or array.shape[1] != 3:
        raise PointsError(f"points must be an (n, 3) array, got shape {array.shape}")
    try:
        array = np.ascontiguousarray(array, dtype=np.float64)
    except (TypeError, ValueError):
        raise PointsError(f"points must be numeric, got dtype {np.asarray(points).dtype}") from None
    if not np.all(np.isfinite(array)):
        raise PointsError("points must be finite (drop NaN and inf rows first)")
    if len(array) < MIN_POINTS:
        raise PointsError(f"too few points: {len(array)} (the pipeline needs at least {MIN_POINTS})")
    return array


def _vector(array):
    return tuple(float(v) for v in array)


def _detect_paper(points):
    plane = fit_plane_svd(points)
    rotation = rotation_to_z(plane.normal)
    xy = to_plane_frame(points, plane.point, rotation)[:, :2]
    rim = paper_rim(xy)
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
    return plane_result, holes


def detect(points, *, method="paper"):
    """Find the hole(s) in a scan of a nearly flat surface.

    Parameters
    ----------
    points : (n, 3) float
        Finite points in file units (at least ``MIN_POINTS``).
    method : {"paper", "robust"}
        ``"paper"`` reproduces the published method (one hole, clean data).

    Returns
    -------
    Detection
        The holes found (possibly none), the fitted plane and the point count. ``file`` and
        ``dropped_points`` are left for the caller that read the file to fill in.

    Raises
    ------
    PointsError
        When ``points`` is not a usable (n, 3) array or ``method`` is unknown.
    """
    if method not in METHODS:
        raise PointsError(f"method must be one of {', '.join(METHODS)}, got {method!r}")
    started = time.perf_counter()
    points = validate_points(points)
    plane, holes = _detect_paper(points)
    elapsed_ms = (time.perf_counter() - started) * 1000.0
    return Detection(holes=holes, plane=plane, points=len(points), method=method, elapsed_ms=elapsed_ms)
