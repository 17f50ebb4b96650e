"""Least-squares fits of the two surfaces a drilled hole is made of: a cylinder (the bore, a
counterbore's wall) and a cone (a countersink), each about an axis of free direction.

Both are parametrised about a reference frame the caller gives: an origin ``o`` near the axis and a
guess ``g`` of its direction. In that frame (``g`` as z) the axis passes through ``(x, y, 0)`` with
direction ``normalise(a, b, 1)``; the cylinder adds its radius ``r``, the cone its radius ``R0`` in
the plane through ``(x, y, 0)`` perpendicular to the axis and its half angle ``theta`` (the cone
widens toward +axis: ``R(t) = R0 + t tan(theta)`` at axial position ``t``). The residual of a point is
its orthogonal distance to the surface: ``rho - r`` for the cylinder, ``(rho - R(t)) cos(theta)`` for
the cone (exact for points off the apex's side), where ``rho`` is its distance from the axis.

The fits are Levenberg-Marquardt on forward-difference Jacobians (five or six parameters, thousands of
points: the residuals are cheap) inside a trimming loop: before the first fit (from the starting surface) and after each fit the
points farther than ``trim_sigmas`` robust standard deviations of the residuals (never less than
``floor``) are set aside and the fit is repeated, so that stray points from another surface do not
pull it (:mod:`holecli.geometry.lsq`). Numpy only.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from holecli.geometry.lsq import covariance, forward_difference, levenberg_marquardt, trimmed_refit


@dataclass(frozen=True)
class Cylinder:
    """A fitted cylinder: a point on its axis, the axis (unit), radius, residuals of every point
    given (orthogonal distances), which points the last fit kept, and their rms."""

    point: np.ndarray
    axis: np.ndarray
    radius: float
    residuals: np.ndarray
    kept: np.ndarray
    rms: float
    covariance: object = None  # least-squares covariance of the fit's parameters (see _covariance)


@dataclass(frozen=True)
class Cone:
    """A fitted cone: a point on its axis, the axis (unit, toward the wide end), the radius in the
    plane through ``point`` perpendicular to the axis, the half angle (radians), residuals of every
    point given, which points the last fit kept, and their rms."""

    point: np.ndarray
    axis: np.ndarray
    radius: float
    half_angle: float
    residuals: np.ndarray
    kept: np.ndarray
    rms: float
    covariance: object = None  # least-squares covariance of (x, y, a, b, R0, theta) (see _covariance)

    def radius_at(self, axial):
        """Radius of the cone at axial position ``axial`` from :attr:`point` (toward the wide end).

        Parameters
        ----------
        axial : float or ndarray

        Returns
        -------
        float or ndarray
        """
        return self.radius + np.asarray(axial) * np.tan(self.half_angle)


def frame_about(direction):
    """Rotation (3, 3) whose third row is the unit ``direction`` (rows: two perpendicular axes, then it).

    Parameters
    ----------
    direction : (3,) float

    Returns
    -------
    (3, 3) float
    """
    z = np.asarray(direction, dtype=np.float64)
    z = z / np.linalg.norm(z)
    helper = np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = np.cross(helper, z)
    x /= np.linalg.norm(x)
    return np.vstack([x, np.cross(z, x), z])


def _axis_of(a, b):
    u = np.array([a, b, 1.0])
    return u / np.sqrt(1.0 + a * a + b * b)


def _radial_axial(local, x, y, a, b):
    """Distance from the axis and axial position of ``local`` points (reference frame)."""
    u = _axis_of(a, b)
    q = local - np.array([x, y, 0.0])
    t = q @ u
    rho = np.sqrt(np.maximum(np.einsum("ij,ij->i", q, q) - t * t, 0.0))
    return rho, t


def _cylinder_residuals(parameters, local):
    x, y, a, b, r = parameters
    rho, _ = _radial_axial(local, x, y, a, b)
    return rho - r


def _cone_residuals(parameters, local):
    x, y, a, b, r0, theta = parameters
    rho, t = _radial_axial(local, x, y, a, b)
    return (rho - r0 - t * np.tan(theta)) * np.cos(theta)


def _trimmed(residuals_of, start, steps, local, floor, trim_sigmas, rounds):
    """The fit repeated on the points within ``trim_sigmas`` robust sigmas of the previous fit
    (:func:`holecli.geometry.lsq.trimmed_refit`), each fit Levenberg-Marquardt on the forward
    differences of ``steps``; the parameters, the residuals of every point, which were kept and their rms."""
    def fit(p, kept):
        def residuals(q):
            return residuals_of(q, local[kept])
        return levenberg_marquardt(residuals, p, forward_difference(residuals, steps), iterations=50,
                                   tolerance=1e-12, stop="decrease")

    p, kept = trimmed_refit(fit, lambda q: residuals_of(q, local), start, clip=trim_sigmas, floor=floor,
                            rounds=rounds, minimum=len(start) + 1)
    residuals = residuals_of(p, local)
    rms = float(np.sqrt(np.mean(residuals[kept] ** 2)))
    return p, residuals, kept, rms


def _covariance(residuals_of, p, steps, local):
    """Least-squares covariance of the parameters ``p`` fitted to ``local`` (the points kept), on the
    forward-difference Jacobian (:func:`holecli.geometry.lsq.covariance`); None when singular or too
    few points. In the fit's frame: the axis tilts ``a, b`` are radians to first order."""
    def residuals(q):
        return residuals_of(q, local)
    f = residuals(p)
    if len(f) <= len(p):
        return None
    return covariance(forward_difference(residuals, steps)(p, f), f)


def _reference_frame(points, origin, direction, radius):
    """The fit's frame (rows: two axes, then ``direction``), the points in it, the finite-difference step."""
    rotation = frame_about(direction)
    local = (np.asarray(points, dtype=np.float64) - origin) @ rotation.T
    return rotation, local, max(1e-7 * radius, 1e-12)


def _to_world(origin, rotation, x, y, a, b):
    point = origin + rotation.T @ np.array([x, y, 0.0])
    axis = rotation.T @ _axis_of(a, b)
    return point, axis / np.linalg.norm(axis)


def fit_cylinder(points, origin, direction, radius, *, fixed_axis=False, floor=0.0, trim_sigmas=3.0,
                 rounds=4):
    """Fit a cylinder to ``points`` from an axis guess through ``origin`` along ``direction``.

    Parameters
    ----------
    points : (n, 3) float
        Points on the wall (n >= 6; more is better).
    origin : (3,) float
        A point near the axis, where the axial positions count from.
    direction : (3,) float
        The axis guess (any length).
    radius : float
        The radius guess (> 0).
    fixed_axis : bool
        Keep the axis parallel to ``direction`` (fit its position and the radius only): for a wall
        seen over too short a length to say its direction.
    floor : float
        Least residual scale of the trimming (the points' noise).
    trim_sigmas : float
        Points beyond this many robust sigmas of the residuals are left out of the next round.
    rounds : int
        Trimming rounds at most.

    Returns
    -------
    Cylinder
    """
    rotation, local, step = _reference_frame(points, origin, direction, radius)
    if fixed_axis:
        def residuals_of(q, pts):
            return _cylinder_residuals((q[0], q[1], 0.0, 0.0, q[2]), pts)
        steps = (step, step, step)
        p, residuals, kept, rms = _trimmed(residuals_of, (0.0, 0.0, radius), steps, local,
                                           floor, trim_sigmas, rounds)
        x, y, a, b, r = p[0], p[1], 0.0, 0.0, p[2]
        covariance = _covariance(residuals_of, p, steps, local[kept])
        if covariance is not None:  # as (x, y, a, b, r), the tilts fixed
            full = np.zeros((5, 5))
            full[np.ix_([0, 1, 4], [0, 1, 4])] = covariance
            covariance = full
    else:
        steps = (step, step, 1e-7, 1e-7, step)
        p, residuals, kept, rms = _trimmed(_cylinder_residuals, (0.0, 0.0, 0.0, 0.0, radius),
                                           steps, local, floor, trim_sigmas, rounds)
        x, y, a, b, r = p
        covariance = _covariance(_cylinder_residuals, p, steps, local[kept])
    point, axis = _to_world(np.asarray(origin, dtype=np.float64), rotation, x, y, a, b)
    return Cylinder(point=point, axis=axis, radius=float(abs(r)), residuals=residuals, kept=kept, rms=rms,
                    covariance=covariance)


def fit_cone(points, origin, direction, radius, half_angle, *, floor=0.0, trim_sigmas=3.0, rounds=4):
    """Fit a cone to ``points`` from a guess: axis through ``origin`` along ``direction`` (toward the
    wide end), ``radius`` in the plane through ``origin`` perpendicular to it, ``half_angle``.

    Parameters
    ----------
    points : (n, 3) float
        Points on the cone (n >= 7).
    origin : (3,) float
    direction : (3,) float
    radius : float
    half_angle : float
        Radians, in (0, pi/2).
    floor, trim_sigmas, rounds
        As for :func:`fit_cylinder`.

    Returns
    -------
    Cone
    """
    rotation, local, step = _reference_frame(points, origin, direction, radius)
    steps = (step, step, 1e-7, 1e-7, step, 1e-7)
    p, residuals, kept, rms = _trimmed(_cone_residuals, (0.0, 0.0, 0.0, 0.0, radius, half_angle),
                                       steps, local, floor, trim_sigmas, rounds)
    x, y, a, b, r0, theta = p
    point, axis = _to_world(np.asarray(origin, dtype=np.float64), rotation, x, y, a, b)
    return Cone(point=point, axis=axis, radius=float(r0), half_angle=float(theta), residuals=residuals,
                kept=kept, rms=rms, covariance=_covariance(_cone_residuals, p, steps, local[kept]))
