"""The largest empty circle at a hole: the edge estimate of irregular sampling.

On random or jittered sampling the rim points of a hole scatter over about a point spacing outside its
edge, and a circle fitted to them is only as good as that scatter allows (about 0.1 h in diameter). The
points themselves say more: no point lies inside the hole, and the largest circle that holds none of
them is pinned by the few points that come closest to the edge. Its center is a vertex of the points'
Voronoi diagram, the circumcenter of one of their Delaunay triangles, so one triangulation of the
points around the hole finds it.

It overshoots the true edge by the gaps between those closest points (on average about 0.05 h on
random sampling of spacing h); :func:`empty_circle_bias` measures that overshoot on synthetic holes cut
into the same points, as :mod:`holecli.robust.estimators.rim_fit` does for rim fits.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial import Delaunay, QhullError

from holecli.geometry.kernels import circumradii
from holecli.robust.estimators import harness
from holecli.robust.estimators.harness import EdgeEstimate, synthetic_errors
from holecli.vocabulary import ESTIMATOR_EMPTY_CIRCLE

# The largest empty circle's center on random sampling of density rho around an edge of radius R: a few
# closest points pin it, and its error per coordinate has a standard deviation of about 0.46 / (rho R)
# (simulated: Poisson points of 16-400 per unit area, R = 1.25-4, 150 draws each, 0.41-0.50), with tails
# that a handful of synthetic holes rarely sample (1 in 50 beyond 4 times it). Rounded up to 0.5, a floor
# of the empty circle's center uncertainty (random sampling is the one it is used on).
EMPTY_CIRCLE_CENTER = 0.5


def _holds_its_circumcenter(points, simplices):
    """Triangles with no obtuse angle. Only such a triangle's circumcircle is a largest empty circle
    locally: when the center lies outside the triangle, moving it away from the long side grows the
    circle (on a region open to one side, without bound)."""
    corners = points[simplices]
    acute = np.ones(len(simplices), dtype=bool)
    for k in range(3):
        at, one, other = corners[:, k], corners[:, (k + 1) % 3], corners[:, (k + 2) % 3]
        acute &= np.einsum("ij,ij->i", one - at, other - at) >= 0.0
    return acute


def largest_empty_circle(xy, center, radius, reach):
    """The largest circle holding none of ``xy`` whose center lies within ``reach`` of ``center``.

    Parameters
    ----------
    xy : (n, 2) float
        Points around the hole (its surface; nothing inside the hole).
    center : (2,) float
    radius : float
        Current estimate of the hole's radius; only points within ``radius + 2 reach`` of ``center``
        can bound a circle of radius up to ``radius + reach`` centred within ``reach``.
    reach : float
        How far the empty circle's center may lie from ``center``.

    Returns
    -------
    (center, radius) or None
        None when no locally largest empty circle (one whose three points surround its center) has
        its center within ``reach``, or when it is larger than ``radius + reach`` (points farther out
        were not looked at).
    """
    xy = np.asarray(xy, dtype=np.float64)
    center = np.asarray(center, dtype=np.float64)
    offset = xy - center
    near = xy[np.einsum("ij,ij->i", offset, offset) < (radius + 2.0 * reach) ** 2]
    if len(near) < 3:
        return None
    # Coordinates relative to the hole and in units of its radius: Qhull's tolerances are then the
    # same in millimetres and metres, far from the origin or near it.
    unit = (near - center) / radius
    try:
        simplices = Delaunay(unit).simplices
    except (QhullError, ValueError):
        return None
    radii, centers = circumradii(unit, simplices)
    candidate = np.hypot(centers[:, 0], centers[:, 1]) < reach / radius
    candidate &= np.isfinite(radii) & _holds_its_circumcenter(unit, simplices)
    if not np.any(candidate):
        return None
    best = np.flatnonzero(candidate)[np.argmax(radii[candidate])]
    if radii[best] > 1.0 + reach / radius:
        return None
    return center + radius * centers[best], float(radius * radii[best])


def empty_circle_bias(xy, center, radius, offsets, reach):
    """Mean overshoot of the largest empty circle over the true radius of synthetic holes
    (:func:`empty_circle_errors`' bias), None when no synthetic hole could be measured."""
    errors = empty_circle_errors(xy, center, radius, offsets, reach)
    return None if errors is None else errors.bias


def empty_circle_errors(xy, center, radius, offsets, reach, reflections=None):
    """The errors of the largest empty circle on synthetic holes of known center and radius.

    Each synthetic hole of radius ``radius + offset`` is cut at ``center`` into ``xy`` (its points
    removed) and measured by :func:`largest_empty_circle`; the offsets are positive so that the real
    hole's emptiness does not count.

    Parameters
    ----------
    xy : (n, 2) float
        Surface points around the hole, reaching at least ``radius + max(offsets) + 2 reach``.
    center : (2,) float
    radius : float
        The current estimate of the true edge radius.
    offsets : sequence of float
        Positive offsets of the synthetic radii.
    reach : float
        As for :func:`largest_empty_circle`.
    reflections : sequence of (m, 2) float or None, optional
        Per offset, the points added inside that synthetic hole (None: none).

    Returns
    -------
    holecli.robust.estimators.harness.SyntheticErrors or None
        The overshoots (their mean is the bias; positive: the empty circle comes out too large) and
        the center errors, None when no synthetic hole could be measured.
    """
    xy = np.asarray(xy, dtype=np.float64)
    distance = np.hypot(*(xy - center).T)

    def measure(synthetic, inside):
        kept = xy[distance >= synthetic]
        if inside is not None and len(inside):
            kept = np.vstack([kept, inside])
        return largest_empty_circle(kept, center, synthetic, reach)

    return synthetic_errors(measure, center, [radius + offset for offset in offsets], reflections)


def _empty_circle(scene, local, center, radius, settings):
    """The edge of a hole in irregular sampling: the largest circle empty of its surface points,
    less that circle's overshoot on synthetic holes cut into the same points.
    ``(center, radius, overshoot, SyntheticErrors)`` or None."""
    reach = scene.alpha
    found = largest_empty_circle(local, center, radius, reach)
    if found is None:
        return None
    empty_center, empty_radius = found
    offsets = [k * scene.sampling.gap for k in settings.bias_offsets]
    ring = scene.surface_xy[scene.within(scene.surface_xy, empty_center, empty_radius,
                                         empty_radius + offsets[-1] + 3.0 * reach)]
    errors = empty_circle_errors(ring, empty_center, empty_radius, offsets, reach,
                                 reflections=harness.reflections(scene, empty_center, empty_radius, offsets))
    if errors is None:
        return None
    return empty_center, empty_radius - errors.bias, errors.bias, errors


class EmptyCircle:
    """The largest empty circle less its overshoot on synthetic holes: a full hole on irregular
    sampling (no period) whose in-plane scatter is small.

    Its bias correction is given a Type B term of its own (:attr:`correction_share`) and its center's
    uncertainty a floor (:meth:`center_floor`)."""

    name = ESTIMATOR_EMPTY_CIRCLE  # its precedence: holecli.vocabulary.ESTIMATORS
    # The method terms (a, b) for the in-plane center and the diameter: a h and b sigma_h in
    # quadrature (see holecli.robust.uncertainty for how they were measured).
    method_terms = {"center": (0.015, 0.3), "diameter": (0.0, 0.0)}
    # The correction is itself uncertain: its synthetic holes see the points around the real hole,
    # not the reflections deep inside it that bound the empty circle. The true correction is taken
    # to lie anywhere between none and twice the one applied (a rectangular distribution, GUM
    # 4.3.7): a standard uncertainty of |correction| / sqrt(3) on the diameter.
    correction_share = 1.0 / math.sqrt(3.0)
    bias_corrected = True
    at_least_fit = False
    from_cone_covariance = False

    def center_floor(self, density, radius):
        """:data:`EMPTY_CIRCLE_CENTER` ``/ (density radius)``: that of a
        largest empty circle on random sampling, whose heavy tails the synthetic holes rarely sample
        (0 without a density or a radius)."""
        if density and radius > 0:
            return EMPTY_CIRCLE_CENTER / (float(density) * float(radius))
        return 0.0

    def applies(self, scene, partial, settings):
        """A full hole on irregular sampling (no period) whose surface is quiet: on a noisy surface
        the noise carries points into the hole and the empty circle shrinks with it."""
        quiet = scene.height_noise * np.sqrt(scene.surface_density) <= settings.empty_circle_max_noise
        return not partial and scene.sampling.period is None and quiet

    def edge(self, scene, local, rim_xy, center, radius, partial, floor, settings):
        """The largest empty circle less its overshoot (:func:`_empty_circle`); None when there is
        none or its synthetic holes give no overshoot."""
        found = _empty_circle(scene, local, center, radius, settings)
        if found is None:
            return None
        return EdgeEstimate(estimator=self, center=found[0], radius=found[1], bias=radius - found[1],
                            synthetic=found[3])


EMPTY_CIRCLE = EmptyCircle()
