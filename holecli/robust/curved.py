"""A hole on a curved panel: measured again on the surface around it flattened
(:func:`on_curved_surface`), as every candidate is (:func:`holecli.robust.measure.measure_candidate`).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from holecli.errors import PointsError
from holecli.geometry.frame import from_plane_frame
from holecli.geometry.kernels import orient_normal
from holecli.geometry.quadric import curved_quadric
from holecli.robust.assemble import to_hole
from holecli.robust.candidate import Refusal
from holecli.robust.candidates import find_voids
from holecli.robust.measure import measure_candidate
from holecli.robust.scene import build_scene, seen_from
from holecli.robust.surface import plane_frame_at, ring_plane

__all__ = ["on_curved_surface"]


def on_curved_surface(scene, measured, settings, view_dir, rng):
    """The hole measured again on the surface around it flattened, when that surface is curved; else
    None.

    The scan's plane serves to find the holes. On a curved panel it lies far off the surface at a hole
    away from the middle (0.4 mm across a 50 mm scan at R 800), so the band of surface points is wide,
    the top of a countersink's cone counts as surface on one side of the hole more than on the other,
    and the rim, the edge and the center move (50 um). Here the points within ``crop_radii`` radii of
    the hole are taken into the frame of the ring's own plane, the quadric of the ring
    (:func:`holecli.geometry.quadric.curved_quadric`) is subtracted from their heights, and the void at
    the hole's center in the scene of that flat crop (:func:`holecli.robust.scene.build_scene`) is
    measured as every candidate is (:func:`measure_candidate`); its center and normal go back onto
    the quadric. None too when the crop's void is refused, or its hole lies half a radius or more from
    the hole's center.
    """
    center, radius = measured.center, measured.radius
    around = seen_from(scene, measured)  # (the ring and the crop from the points gathered around the hole)
    ring = ring_plane(around, center, radius, settings.crop_ring_radii)
    if ring is None:
        return None
    ring_points, plane = ring
    near = from_plane_frame(np.array([center[0], center[1], 0.0]), scene.origin, scene.rotation)
    foot, basis = plane_frame_at(plane, near)
    first, second, normal = basis
    if float(normal @ scene.rotation[2]) < 0:
        # The crop's frame with the sensor on +z, as the scene's (build_scene's flattened takes that side).
        second, normal = -second, -normal
        basis = np.vstack([first, second, normal])
    quadric = curved_quadric((ring_points - foot) @ basis.T, radius, settings.curvature_sigmas, scene.resolution)
    if quadric is None:
        return None
    crop = scene.points[around.within(scene.xy, center, 0.0, settings.crop_radii * radius)]
    local = (crop - foot) @ basis.T
    local[:, 2] -= quadric.height(local[:, :2])
    slide = None if view_dir is None else basis @ (np.asarray(view_dir, dtype=np.float64) / np.linalg.norm(view_dir))
    try:
        flat = build_scene(local, view_dir=slide, min_diameter=radius, settings=settings, rng=rng, flattened=True)
    except PointsError:
        return None
    # The hole's center (the crop frame's origin) in the flat scene's plane frame.
    void = _void_at(flat, find_voids(flat.grid), (flat.rotation @ -flat.origin)[:2], 0.5 * radius)
    if void is None:
        return None
    found = measure_candidate(flat, void, settings)
    if isinstance(found, Refusal):
        return None
    hole = to_hole(flat, found, 0)
    if np.hypot(hole.center[0], hole.center[1]) > 0.5 * radius:
        return None
    at = np.array([[hole.center[0], hole.center[1]]])
    height = float(quadric.height(at)[0])
    ds, dt = quadric.gradient(at)[0]
    world_center = foot + at[0, 0] * first + at[0, 1] * second + height * normal
    world_normal = orient_normal(normal - ds * first - dt * second)
    return replace(hole, center=tuple(map(float, world_center)), normal=tuple(map(float, world_normal)))


def _void_at(scene, voids, xy, reach):
    """The void of ``voids`` whose cells come nearest to ``xy`` (plane frame): the one that holds it,
    else one within ``reach`` of it; None when every void lies farther."""
    best, nearest = None, np.inf
    for void in voids:
        distance = float(np.min(np.hypot(*(scene.grid.center_of(void.cells) - xy).T)))
        if distance < nearest:
            best, nearest = void, distance
    return best if nearest <= reach else None
