"""Circle fits to 2D points: algebraic start, geometric least squares, and a robust clipped fit.

The geometric fit minimises ``sum (|p_i - c| - r)^2`` (Gander, Golub and Strebel 1994), the fit the
paper uses. Every fit centres and scales the points before solving and returns its quality.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from holecli.errors import PointsError
from holecli.geometry.kernels import circles_through
from holecli.geometry.lsq import gauss_newton, levenberg_marquardt, trimmed_refit
from holecli.settings import DEFAULT_SETTINGS


@dataclass(frozen=True, eq=False)
class CircleFit:
    """A fitted circle.

    Attributes
    ----------
    center : (2,) float
    radius : float
    residuals : (m,) float
        Signed radial residuals ``|p_i - c| - r`` of the points kept.
    kept : (n,) bool
        Which of the input points the final fit used.
    """

    center: np.ndarray
    radius: float
    residuals: np.ndarray
    kept: np.ndarray

    @property
    def rms(self) -> float:
        """Root mean square of the residuals."""
        return float(np.sqrt(np.mean(self.residuals**2)))

    @property
    def max_residual(self) -> float:
        """Largest absolute residual."""
        return float(np.max(np.abs(self.residuals)))

    @property
    def roundness(self) -> float:
        """Maximum minus minimum radial distance of the kept points from the center."""
        return float(np.ptp(self.residuals))


def _check(xy, minimum=3):
    xy = np.asarray(xy, dtype=np.float64)
    if xy.ndim != 2 or xy.shape[1] != 2:
        raise PointsError(f"circle fit needs an (n, 2) array, got shape {xy.shape}")
    if len(xy) < minimum:
        raise PointsError(f"circle fit needs at least {minimum} points, got {len(xy)}")
    return xy


def fit_circle_algebraic(xy):
    """Kasa's algebraic circle fit (linear least squares); a starting point for the geometric fit.

    Parameters
    ----------
    xy : (n, 2) float
        At least three points, not collinear.

    Returns
    -------
    center : (2,) float
    radius : float
    """
    xy = _check(xy)
    mean = xy.mean(axis=0)
    scale = np.sqrt(np.mean(np.sum((xy - mean) ** 2, axis=1))) or 1.0
    u = (xy - mean) / scale
    # x^2 + y^2 + D x + E y + F = 0
    design = np.column_stack([u, np.ones(len(u))])
    target = -np.sum(u**2, axis=1)
    solution, _, rank, _ = np.linalg.lstsq(design, target, rcond=None)
    if rank < 3:
        raise PointsError("the rim points are collinear: no circle is defined")
    d, e, f = solution
    center = np.array([-d / 2.0, -e / 2.0])
    radius_sq = center @ center - f
    if radius_sq <= 0:
        raise PointsError("the algebraic circle fit is degenerate")
    return center * scale + mean, float(np.sqrt(radius_sq) * scale)


def _normalised(xy, start):
    """Points centred on their mean and scaled by the start radius, and the start as parameters.

    Returns ``(mean, scale, u, params)`` with ``u = (xy - mean) / scale`` and ``params`` the start
    circle ``(cx, cy, r)`` in those units (its radius 1).
    """
    center, radius = start
    mean = xy.mean(axis=0)
    scale = max(float(radius), 1e-300)
    params = np.array([(center[0] - mean[0]) / scale, (center[1] - mean[1]) / scale, 1.0])
    return mean, scale, (xy - mean) / scale, params


def _radial(params, u):
    return np.hypot(u[:, 0] - params[0], u[:, 1] - params[1]) - params[2]


def _radial_jacobian(params, u):
    dx = u[:, 0] - params[0]
    dy = u[:, 1] - params[1]
    dist = np.hypot(dx, dy)
    dist[dist == 0] = 1e-300
    return np.column_stack([-dx / dist, -dy / dist, -np.ones(len(u))])


def fit_circle_geometric(xy, start=None):
    """Geometric least-squares circle fit (Levenberg-Marquardt on the radial residuals).

    Parameters
    ----------
    xy : (n, 2) float
        At least three points, not collinear.
    start : ((2,) float, float), optional
        Initial center and radius; by default the algebraic fit.

    Returns
    -------
    CircleFit
    """
    xy = _check(xy)
    mean, scale, u, x0 = _normalised(xy, start if start is not None else fit_circle_algebraic(xy))
    solution = _solve(u, x0)
    center = solution[:2] * scale + mean
    radius = float(abs(solution[2]) * scale)
    residuals = np.hypot(*(xy - center).T) - radius
    return CircleFit(center=center, radius=radius, residuals=residuals, kept=np.ones(len(xy), bool))


def _solve(u, params):
    """The geometric fit of the centred, scaled points ``u`` from ``params`` ``(cx, cy, r)`` in their units
    (:func:`holecli.geometry.lsq.levenberg_marquardt` with the radial residuals' analytic Jacobian)."""
    return levenberg_marquardt(lambda p: _radial(p, u), params, lambda p, f: _radial_jacobian(p, u))


def _least_quantile_circle(xy, hypotheses=200, quantile=75):
    """Initial circle by least quantile of squares over circles through point triples.

    The algebraic fit of every point is the start when the points are clean; a circle through three
    points that minimises the 75th percentile of the absolute residuals (and halves that of the
    algebraic fit) replaces it, which survives up to a quarter of
    the points being outliers (the median would survive half, but on a sparse rim it also prefers a
    circle through one side of the hole). The triples are drawn with a fixed seed from the points
    sorted by their coordinates: the result depends neither on global random state nor on the order
    of the points.

    Parameters
    ----------
    xy : (n, 2) float
        At least three points, not collinear.
    hypotheses : int
        Point triples tried.
    quantile : float
        Percentile of the absolute radial residuals that scores a circle.

    Returns
    -------
    center : (2,) float
    radius : float
    """
    center, radius = fit_circle_algebraic(xy)
    best = float(np.percentile(np.abs(np.hypot(*(xy - center).T) - radius), quantile))
    if len(xy) < 6:
        return center, radius
    # Triples drawn from the points in coordinate order, so that the order they came in is irrelevant.
    ordered = xy[np.lexsort((xy[:, 1], xy[:, 0]))]
    rng = np.random.default_rng(0)
    triples = rng.integers(0, len(ordered), size=(hypotheses, 3))
    centers, radii = circles_through(ordered[triples[:, 0]], ordered[triples[:, 1]], ordered[triples[:, 2]])
    # Nearly collinear triples give huge circles whose residuals round to nothing: a circle larger
    # than ten times the points' extent is no rim.
    size = float(np.max(np.ptp(xy, axis=0)))
    valid = np.isfinite(radii) & (radii > 0) & (radii < 10.0 * size)
    if not np.any(valid):
        return center, radius
    centers, radii = centers[valid], radii[valid]
    residuals = np.abs(np.hypot(xy[None, :, 0] - centers[:, None, 0], xy[None, :, 1] - centers[:, None, 1])
                       - radii[:, None])
    medians = np.percentile(residuals, quantile, axis=1)
    index = int(np.argmin(medians))
    # Only a clearly better circle replaces the fit of every point: on a sparse, structured rim (a few
    # scan lines) some triple always fits three quarters of the points a little better by chance
    # (taking any better triple puts the stripes-pitch-4h scene of tests/robust/test_robust_scenes.py
    # 1.02 h small; without the triples, a cluster of reflections keeps the algebraic start:
    # tests/robust/test_acceptance.py).
    if medians[index] < 0.5 * best:
        return centers[index], float(radii[index])
    return center, radius


def fit_circle_robust(xy, *, clip=None, floor=0.0, max_rounds=10, start=None, settings=DEFAULT_SETTINGS.rim):
    """Geometric circle fit with iterative sigma clipping of radial outliers.

    Each round fits the kept points geometrically, estimates the residual scale robustly
    (1.4826 * median absolute residual, never below ``floor``), and keeps the points within
    ``clip`` times that scale; it stops when the kept set no longer changes.

    Parameters
    ----------
    xy : (n, 2) float
        At least three points, not collinear.
    clip : float, optional
        Clipping threshold in robust standard deviations (default ``settings.clip_sigmas``, so that a
        default fit is the production fit).
    floor : float
        Smallest residual scale, in the units of ``xy`` (keeps noise-free data from clipping
        round-off).
    max_rounds : int
        Most clipping rounds.
    start : ((2,) float, float), optional
        Initial center and radius; by default the algebraic fit of all points, or a
        least-quantile-of-squares circle through three of them when it halves the 75th percentile of
        the absolute residuals (:func:`_least_quantile_circle`).
    settings : holecli.settings.RimSettings or RobustSettings
        Source of ``clip`` when not given.

    Returns
    -------
    CircleFit
        ``kept`` marks the points of the final fit.
    """
    xy = _check(xy)
    clip = settings.clip_sigmas if clip is None else clip
    mean, scale, u, params = _normalised(xy, start if start is not None else _least_quantile_circle(xy))
    def refit(p, kept):  # from the previous round's circle: Gauss-Newton (lsq.gauss_newton says why)
        points = u[kept]
        return gauss_newton(lambda q: _radial(q, points), p, lambda q, f: _radial_jacobian(q, points))

    # Start from the points the initial circle explains (within clip robust sd), not from all of them:
    # a fit to every point leans toward the outliers and the clipping then keeps them.
    params, kept = trimmed_refit(refit, lambda p: _radial(p, u), params,
                                 clip=clip, floor=floor / scale, rounds=max_rounds, minimum=3, refit_last=True)
    center = params[:2] * scale + mean
    radius = float(abs(params[2]) * scale)
    residuals = np.hypot(*(xy[kept] - center).T) - radius
    return CircleFit(center=center, radius=radius, residuals=residuals, kept=kept)
