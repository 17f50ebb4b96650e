"""The largest empty circle at a hole: the edge estimate of irregular sampling.

On random or jittered sampling the rim points of a hole scatter over about a point spacing outside its
edge, and a circle fitted to them is only as good as that scatter allows (about 0.1 h in diameter). The
points themselves say more: no point lies inside the hole, and the largest circle that holds none of
them is pinned by the few points that come closest to the edge. Its center is a vertex of the points'
Voronoi diagram, the circumcenter of one of their Delaunay triangles, so one triangulation of the
points around the hole finds it.

It overshoots the true edge by the gaps between those closest points (on average about 0.05 h on
random sampling of spacing h); :func:`empty_circle_bias` measures that overshoot on synthetic holes cut
into the same points, as :mod:`holecli.robust.bias` does for rim fits.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import Delaunay, QhullError

from holecli.geometry.kernels import circumradii
from holecli.robust.bias import SyntheticErrors


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
    holecli.robust.bias.SyntheticErrors or None
        The overshoots (their mean is the bias; positive: the empty circle comes out too large) and
        the center errors, None when no synthetic hole could be measured.
    """
    xy = np.asarray(xy, dtype=np.float64)
    distance = np.hypot(*(xy - center).T)
    radial, shifts = [], []
    for i, offset in enumerate(offsets):
        synthetic = radius + offset
        kept = xy[distance >= synthetic]
        if reflections is not None and reflections[i] is not None and len(reflections[i]):
            kept = np.vstack([kept, reflections[i]])
        found = largest_empty_circle(kept, center, synthetic, reach)
        if found is not None:
            radial.append(found[1] - synthetic)
            shifts.append(np.asarray(found[0]) - center)
    if not radial:
        return None
    return SyntheticErrors(radial=np.array(radial), center=np.array(shifts).reshape(-1, 2))
