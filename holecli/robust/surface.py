"""The surface at one hole: the tangent plane where the hole's axis meets it (:func:`local_normal`), the
plane of the ring of surface points around it (:func:`ring_plane`) and its frame
(:func:`plane_frame_at`), and on a curved panel the quadric that follows it
(:func:`tangent_of_quadric`, :func:`surface_height`; :mod:`holecli.geometry.quadric`)."""

from __future__ import annotations

import numpy as np

from holecli.errors import PointsError
from holecli.geometry.frame import from_plane_frame
from holecli.geometry.kernels import orient_normal
from holecli.geometry.plane import PlaneFit, fit_plane_scatter
from holecli.geometry.quadric import curved_quadric
from holecli.robust.uncertainty import plane_uncertainty

__all__ = ["local_normal", "plane_frame_at", "ring_plane", "surface_height", "tangent_of_quadric"]


def local_normal(scene, center, radius, settings):
    """The surface at one hole: its tangent plane where the hole's axis meets it, from a plane or,
    on a curved surface, a quadric fitted to the plane inliers in the ring [r, 3r] (see
    :func:`tangent_of_quadric`), and the standard uncertainties of its height at the hole and of
    its normal's direction (radians; :func:`holecli.robust.uncertainty.plane_uncertainty`), or
    ``(None, (None, None))`` when the ring holds too few points."""
    ring = ring_plane(scene, center, radius, 3.0)
    if ring is None:
        return None, (None, None)
    points, plane = ring
    on_plane = from_plane_frame(np.array([center[0], center[1], 0.0]), scene.origin, scene.rotation)
    tangent = tangent_of_quadric(points, plane, on_plane, settings.curvature_sigmas, scene.resolution)
    return tangent, plane_uncertainty(points, tangent, on_plane, resolution=scene.resolution)



def ring_plane(scene, center, radius, outer_radii):
    """The surface points in the ring [r, outer_radii r] around a hole (world) and their plane, or
    None when the ring holds too few points (under 30) for it."""
    ring = scene.within(scene.surface_xy, center, radius, outer_radii * radius)
    if len(ring) < 30:
        return None
    points = scene.points[scene.surface_index[ring]]
    try:
        return points, fit_plane_scatter(points)
    except PointsError:
        return None



def plane_frame_at(plane, near):
    """The foot of ``near`` on ``plane`` and the rows (first axis, second axis, normal) of the
    plane's frame there, the first along the plane's major axis."""
    normal = plane.normal
    first = plane.major - (plane.major @ normal) * normal
    first /= np.linalg.norm(first)
    foot = near - ((near - plane.point) @ normal) * normal
    return foot, np.vstack([first, np.cross(normal, first), normal])



def tangent_of_quadric(points, plane, near, sigmas, resolution=0.0):
    """Tangent plane of ``h = a + b s + c t + d s^2 + e s t + f t^2`` fitted to ``points`` in the frame
    of ``plane`` centred at ``near``'s foot on it, taken at that foot; ``plane`` itself when the
    curvature is not significant.

    A plane through the ring around a hole of a curved panel (cylindrical, R 500-2000 mm) lies below
    or above the surface at the hole by the sag of the ring (10 um for a 5 mm hole at R 800): the
    quadric follows the curvature and puts the center on the surface. The quadric is taken only where
    the surface really curves (:func:`holecli.geometry.quadric.curved_quadric`, check
    ``curvature_sigmas``). On a symmetric ring the linear terms (the normal) are those of the plane.
    """
    foot, basis = plane_frame_at(plane, near)
    first, second, normal = basis
    local = (points - foot) @ basis.T
    scale = float(np.sqrt(np.mean(local[:, 0] ** 2 + local[:, 1] ** 2)))  # conditioning: unit-size coordinates
    quadric = curved_quadric(local, scale, sigmas, resolution)
    if quadric is None:
        return plane
    origin = np.zeros((1, 2))
    (b, c), = quadric.gradient(origin)
    tangent_normal = orient_normal(normal - b * first - c * second)
    rms = float(np.sqrt(np.mean((quadric.height(local[:, :2]) - local[:, 2]) ** 2)))
    return PlaneFit(point=foot + float(quadric.height(origin)[0]) * normal, normal=tangent_normal, rms=rms,
                    major=first)



def surface_height(scene, center, radius, settings, xy):
    """Height of the surface itself at ``xy`` (plane frame) near a hole: 0, the global plane, unless
    the surface in the ring [r, 3r] curves away from it significantly (a curved panel, where the plane
    of a large scan lies tens of um off the surface at a hole and a countersink's depth would be
    measured from the wrong level); then a quadric fitted to that ring (check ``curvature_sigmas``)."""
    ring = scene.within(scene.surface_xy, center, radius, 3.0 * radius)
    if len(ring) < 30:
        return np.zeros(len(xy))
    local = np.column_stack([scene.surface_xy[ring] - center, scene.heights[scene.surface_index[ring]]])
    quadric = curved_quadric(local, radius, settings.curvature_sigmas, scene.resolution)
    if quadric is None:
        return np.zeros(len(xy))
    return quadric.height(xy - center)
