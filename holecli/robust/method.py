"""The robust method: every hole in the scan, with rim outliers rejected and the sampling bias removed.

Steps (each its own module):

1. plane of the dominant surface by RANSAC and iterated least squares (:func:`holecli.geometry.plane.fit_plane_robust`);
2. rotation into the plane frame, with an orthogonal projection or, given the sensor's view and nothing
   seen behind the surface, a slide of the surface's points along it (:mod:`holecli.geometry.frame`);
3. the sampling's spacing and gap scale (:mod:`holecli.robust.sampling`): every threshold below is a multiple;
4. hole candidates as voids of an occupancy grid, linear in the point count (:mod:`holecli.robust.candidates`);
   steps 1-4 build the scene (:func:`holecli.robust.scene.build_scene`);
5. per candidate, a local Delaunay triangulation and its alpha-shape rim (:mod:`holecli.robust.boundary`);
6. a robust geometric circle fit (:mod:`holecli.robust.edge`, :mod:`holecli.geometry.circle`), checks that the void is
   a round hole and not a boss, a dent of the border or a natural gap, and its scanned coverage
   (:mod:`holecli.robust.acceptance`);
7. the edge: where a countersink cone meets the surface (:mod:`holecli.robust.estimators.cone`; the flat
   floor of a blind hole is no cone), else the rim fit corrected for the sampling bias, by lattice
   brackets on regular scans (:mod:`holecli.robust.estimators.lattice`) or by synthetic holes
   (:mod:`holecli.robust.estimators.rim_fit`); a local plane
   gives the normal and the 3D center (:mod:`holecli.robust.surface`), and on a curved panel the hole is
   measured again on its flattened neighbourhood (:mod:`holecli.robust.curved`).

Steps 5-7 measure one candidate (:mod:`holecli.robust.measure`); the holes found and the candidates
refused go back to the world as the record's objects (:mod:`holecli.robust.assemble`). This module
conducts them: :func:`detect_robust`.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from holecli.geometry.kernels import orient_normal
from holecli.results import Hole, Plane, Scales
from holecli.robust.acceptance import beyond_max_holes, duplicate, partial_left_out, pocket
from holecli.robust.assemble import loop_hole, overlaps, to_hole, to_rejection, with_shape
from holecli.robust.candidate import Refusal
from holecli.robust.candidates import find_voids
from holecli.robust.curved import on_curved_surface
from holecli.robust.edge_loops import coordinate_step, edge_loops, faces_empty
from holecli.robust.measure import measure_candidates
from holecli.robust.scene import build_scene
from holecli.settings import DEFAULT_SETTINGS
from holecli.stages import StageClock
# (still an attribute of this module, as before issue 26, for the library users who read it here)
from holecli.vocabulary import REJECTION_REASONS  # noqa: F401

__all__ = ["RobustResult", "detect_robust"]


class RobustResult(NamedTuple):
    """What :func:`detect_robust` returns.

    Attributes
    ----------
    plane : Plane
    holes : tuple of Hole
        Full holes before partial ones, each group ordered by center x, then y, then z.
    rejected : tuple of Rejection
        Every candidate void that is not a hole, with the check that refused it, largest first.
    scales : Scales
        The sampling's scales and the minimum diameter used.
    stages : tuple of (str, float)
        Milliseconds of the stages ``plane``, ``frame``, ``sampling``, ``grid``, ``candidates`` and
        ``shape``.
    candidates : int
        Candidate voids examined: each is a hole or a rejection.
    """

    plane: Plane
    holes: tuple
    rejected: tuple
    scales: Scales
    stages: tuple
    candidates: int


def detect_robust(points, *, view_dir=None, min_diameter=None, max_holes=None, full_only=False,
                  gauge_depth=None, settings=DEFAULT_SETTINGS, rng=0, progress=None):
    """The robust method; see the module docstring.

    Parameters
    ----------
    points : (n, 3) float64
        Checked points (:func:`holecli.pipeline.validate_points`).
    view_dir, min_diameter, max_holes, full_only, gauge_depth, settings, rng
        See :func:`holecli.detect`.
    progress : callable, optional
        Called with the name of each stage as it starts (see :class:`holecli.stages.StageClock`).

    Returns
    -------
    RobustResult
    """
    clock = StageClock(progress)
    scene = build_scene(points, view_dir=view_dir, min_diameter=min_diameter, settings=settings, rng=rng,
                        clock=clock)
    voids = find_voids(scene.grid)
    if len(voids) >= settings.cell_index_from_candidates:
        # Many candidates (the natural gaps of random sampling grow with the points).
        scene = scene.with_cell_indices()
    clock.start("candidates")
    found, rejected = [], []
    for measured in measure_candidates(scene, voids, settings):
        if isinstance(measured, Refusal):
            rejected.append(measured)
            continue
        twin = next((i for i, other in enumerate(found) if overlaps(measured, other)), None)
        if twin is None:
            found.append(measured)
            continue
        refused = duplicate(measured, found[twin])
        if refused is None:  # the twin is the duplicate
            refused, found[twin] = duplicate(found[twin], measured), measured
        rejected.append(refused)
    left_out = [partial_left_out(m, full_only, settings) for m in found]
    rejected.extend(refused for refused in left_out if refused is not None)
    found = [m for m, refused in zip(found, left_out) if refused is None]
    kept, beyond = beyond_max_holes([2.0 * m.radius for m in found], lambda i: (found[i].center, found[i].radius),
                                    max_holes)
    rejected.extend(beyond)
    found = [found[i] for i in kept]
    clock.start("shape")
    holes = [on_curved_surface(scene, measured, settings, view_dir, rng) or to_hole(scene, measured, 0)
             for measured in found]
    holes = [with_shape(scene, hole, measured, gauge_depth, settings) for hole, measured in zip(holes, found)]
    pockets = [pocket(measured, hole, settings) for measured, hole in zip(found, holes)]
    rejected.extend(refused for refused in pockets if refused is not None)
    holes = [hole for hole, refused in zip(holes, pockets) if refused is None]
    sampling, plane = scene.sampling, scene.plane
    if scene.vertices:
        # A CAD export's vertices: no point inside a face, the holes are the loops of its edges.
        loops, loop_rejected = edge_loops(scene.xy, scene.heights, plane.inliers, scene.height_noise,
                                          min_diameter=min_diameter, resolution=scene.resolution,
                                          step=coordinate_step(scene.points), settings=settings)
        if loops or faces_empty(float(sampling.spacing), float(sampling.gap)):
            # (a small scan's sampling makes loops too, of a grid's ties: they are not what it shows)
            rejected.extend(Refusal(check=r.check, value=r.value, limit=r.limit, center=r.center,
                                      radius=r.radius) for r in loop_rejected)
        for loop in loops:
            if not any(np.hypot(*(loop.center - m.center)) < max(m.radius, 0.5 * loop.diameter) for m in found):
                holes.append(loop_hole(scene, loop))
        kept, beyond = beyond_max_holes(
            [hole.diameter for hole in holes],
            lambda i: ((scene.rotation @ (np.asarray(holes[i].center) - scene.origin))[:2], holes[i].radius),
            max_holes)
        rejected.extend(beyond)
        holes = [holes[i] for i in kept]
    holes.sort(key=lambda hole: (hole.partial, hole.center))
    holes = tuple(Hole(**{**hole.__dict__, "index": i}) for i, hole in enumerate(holes))
    plane_result = Plane(point=tuple(map(float, plane.point)), normal=tuple(map(float, orient_normal(plane.normal))),
                         rms=plane.rms, inliers=int(plane.inliers.sum()), facing=scene.facing)
    rejections = tuple(sorted((to_rejection(scene, r) for r in rejected), key=lambda r: (-r.diameter, r.center)))
    scales = Scales(point_spacing=float(sampling.spacing), gap_scale=float(sampling.gap),
                    line_pitch=None if sampling.line_pitch is None else float(sampling.line_pitch),
                    period=None if sampling.period is None else float(sampling.period), lattice=bool(sampling.lattice),
                    height_noise=float(scene.height_noise), min_diameter=2.0 * float(scene.min_radius))
    return RobustResult(plane=plane_result, holes=holes, rejected=rejections, scales=scales, stages=clock.stop(),
                        candidates=len(voids))
