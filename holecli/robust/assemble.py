"""From the plane frame to the world: the record's objects of a measured hole (:func:`to_hole`, its
uncertainty, :func:`with_shape` for what lies below its edge and its doubts), of a refused candidate
(:func:`to_rejection`), and of an edge loop of a CAD export's vertices (:func:`loop_hole`);
:func:`overlaps` finds two candidates of one hole (the selection checks are
:mod:`holecli.robust.acceptance`'s).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from holecli.geometry.frame import from_plane_frame
from holecli.geometry.kernels import largest_angular_gap, orient_normal
from holecli.results import Bore, Counterbore, Countersink, Hole, HoleNote, Rejection, Uncertainty
from holecli.robust.doubts import Doubts, doubt_warnings, edge_bore_warning
from holecli.robust.estimators import ESTIMATOR_NAMED
from holecli.robust.hole_shape import measure_hole_shape
from holecli.robust.scene import seen_from
from holecli.robust.uncertainty import edge_uncertainty, resolution_uncertainty
from holecli.vocabulary import ESTIMATOR_RIM_FIT, NOTE_CODES, REJECTION_REASONS

__all__ = ["loop_hole", "overlaps", "to_hole", "to_rejection", "with_shape"]


def to_hole(scene, measured, index):
    center2d = measured.center
    local_plane = measured.surface_plane
    on_plane = from_plane_frame(np.array([center2d[0], center2d[1], 0.0]), scene.origin, scene.rotation)
    normal = orient_normal(scene.rotation[2])  # (toward the sensor in the scene: reported z-positive)
    if local_plane is not None:
        normal = local_plane.normal
        # Move the center along the projection direction onto the local plane.
        along = float(scene.direction @ normal)
        if abs(along) > 1e-6:
            on_plane = on_plane - scene.direction * (float((on_plane - local_plane.point) @ normal) / along)
    fit = measured.fit
    return Hole(
        index=index,
        center=tuple(map(float, on_plane)),
        diameter=2.0 * measured.radius,
        normal=tuple(map(float, normal)),
        rim_points=int(fit.kept.sum()),
        fit_rms=fit.rms,
        max_residual=fit.max_residual,
        roundness=fit.roundness,
        bias_correction=2.0 * measured.bias,
        partial=measured.partial,
        arc_deg=measured.arc_deg,
        scan_lines=_scan_lines(scene, measured.rim_xy, center2d, measured.radius),
        uncertainty=_uncertainty(scene, measured),
    )


def _scan_lines(scene, rim_xy, center, radius):
    """Number of scan lines with rim points across the hole, for striped scans (else None)."""
    sampling = scene.sampling
    if sampling.line_direction is None:
        return None
    across_axis = np.array([-sampling.line_direction[1], sampling.line_direction[0]])
    across = rim_xy @ across_axis - center @ across_axis
    across = across[np.abs(across) < radius]
    if len(across) == 0:
        return 0
    return int(len(np.unique(np.round((across - across.min()) / sampling.line_pitch))))


def _uncertainty(scene, measured):
    """The :class:`holecli.results.Uncertainty` of a measured hole's edge and surface (the values below
    the edge are added with its shape, :func:`with_shape`)."""
    fit = measured.fit
    u_center, u_diameter = edge_uncertainty(ESTIMATOR_NAMED[measured.estimator], measured.synthetic,
                                            measured.rim_xy, fit.center, fit.radius, float(scene.sampling.spacing), float(scene.height_noise),
                                            measured.cone_covariance, diameter_correction=2.0 * measured.bias,
                                            edge_fringe=measured.fringe[0],
                                            resolution=scene.resolution, radius_range=measured.radius_range,
                                            density=float(scene.surface_density))
    if _bias_not_measured(measured):
        # The correction it would have had: the rim lies inside the edge by up to a gap (radius), so
        # the diameter is off by up to two gaps; uniform over +-2 g (warning bias_not_measured).
        u_diameter = math.hypot(u_diameter, 2.0 * scene.sampling.gap / math.sqrt(3.0))
    height, normal = measured.surface_uncertainty
    if height is None:  # no local plane: the scan's plane (its height noise over its inliers)
        count = max(len(scene.surface_xy), 1)
        least = resolution_uncertainty(scene.resolution)
        height = max(float(scene.height_noise) / math.sqrt(count), least)
        extent = float(np.sqrt(np.mean(np.sum(scene.surface_xy ** 2, axis=1)))) if len(scene.surface_xy) else 1.0
        normal = max(float(scene.height_noise) / math.sqrt(count), least) / max(extent, 1e-300)
    return Uncertainty(center_in_plane=float(u_center), center_along_normal=float(height),
                       diameter=float(u_diameter), normal_deg=math.degrees(float(normal)),
                       estimator=measured.estimator)


def with_shape(scene, hole, measured, gauge_depth, settings):
    """The hole with what its points below the edge show (:mod:`holecli.robust.hole_shape`)."""
    scene = seen_from(scene, measured)  # (its points from those gathered around the hole)
    center = np.asarray(hole.center)
    center2d = (scene.rotation @ (center - scene.origin))[:2]
    # The plane frame's disk holds every point within the search radius of the hole's axis, deep
    # points of a hole drilled off the normal or seen on a tilted part included.
    reach = shape_reach(hole.radius, settings)
    index = scene.within(scene.xy, center2d, 0.0, reach)
    shape = measure_hole_shape(scene.points[index], center, np.asarray(hole.normal), hole.radius,
                               noise=scene.height_noise, spacing=scene.sampling.spacing,
                               cone_slope=measured.cone_slope, gauge_depth=gauge_depth, settings=settings)
    doubts = doubt_warnings(_doubts(scene, hole, measured), settings)
    if shape.type == "through" and shape.bore is not None and shape.bore.diameter is not None \
            and hole.uncertainty is not None and shape.uncertainty is not None:
        # the bore's u from its fit's noise alone: the model error that widens the reported one (a
        # faceted bore's departure from a cylinder) is the same polygon at the edge and on the wall, so
        # it does not part them; only the two fits' own errors do
        mismatch = edge_bore_warning(hole.diameter, hole.uncertainty.diameter, shape.bore.diameter,
                                     shape.bore_noise_u or 0.0, settings)
        doubts = doubts + ((mismatch,) if mismatch is not None else ())
    return Hole(**{**hole.__dict__, "type": shape.type, "countersink": shape.countersink,
                   "counterbore": shape.counterbore, "bore": shape.bore, "axis": shape.axis,
                   "perpendicularity_deg": shape.perpendicularity_deg, "warnings": shape.warnings + doubts,
                   "notes": shape.notes, "uncertainty": _with_shape_uncertainty(hole.uncertainty, shape, scene.resolution)})


def shape_reach(radius, settings):
    """The radius about a hole's center (plane frame) within which :func:`with_shape` takes the
    points of its shape: ``shape_search_radii`` edge radii, widened for a hole whose points down to
    ``shape_depth_radii`` radii deep lie off the normal (drilled off it, or seen on a tilted part)."""
    return settings.shape_search_radii * radius * (1.0 + settings.shape_depth_radii * 0.2)


def _at_least(values, least):
    """A dataclass of standard uncertainties with each length (every field but ``angle_deg``) raised
    to ``least`` (``2 least`` for a diameter); None stays None."""
    if values is None:
        return None
    raised = {name: (value if value is None or name == "angle_deg"
                     else max(value, (2.0 if "diameter" in name else 1.0) * least))
              for name, value in values.__dict__.items()}
    return replace(values, **raised)


def _with_shape_uncertainty(uncertainty, shape, resolution=0.0):
    """The hole's :class:`holecli.results.Uncertainty` with its shape's values'
    (:func:`holecli.robust.hole_shape.measure_hole_shape`): a counterbore's diameter is the edge's,
    an axis from a floor's normal is as uncertain as the surface's normal, and the perpendicularity
    combines the axis's and the normal's. No length is below the data's resolution
    (:func:`holecli.robust.uncertainty.resolution_uncertainty`)."""
    if uncertainty is None or shape.uncertainty is None:
        return uncertainty
    least = resolution_uncertainty(resolution)
    values = {name: _at_least(value, least) if name != "axis_deg" else value
              for name, value in dict(shape.uncertainty).items()}
    if values["counterbore"] is not None:
        values["counterbore"] = replace(values["counterbore"], diameter=uncertainty.diameter)
    if shape.axis is not None and values["axis_deg"] is None:
        values["axis_deg"] = uncertainty.normal_deg
    perpendicularity = None
    if shape.perpendicularity_deg is not None and values["axis_deg"] is not None:
        perpendicularity = math.hypot(values["axis_deg"], uncertainty.normal_deg)
    return replace(uncertainty, countersink=values["countersink"], counterbore=values["counterbore"],
                   bore=values["bore"], axis_deg=values["axis_deg"] if shape.axis is not None else None,
                   perpendicularity_deg=perpendicularity)


def _doubts(scene, hole, measured):
    """The numbers that make ``hole`` doubtful or not (:class:`holecli.robust.doubts.Doubts`).

    Everything in the plane frame of the scan: the rim points the circle was fitted to, the surface
    points deeper than two gaps inside the edge (the lower of the fitted rim circle and the edge
    reported: a countersink's edge lies outside its rim fit, and the cone's top inside it is in the
    surface band), the local surface plane's rms, and the distance to the scan's outside.
    """
    center, radius = measured.center, measured.radius
    gap = scene.sampling.gap
    inner = max(min(radius, radius + measured.bias) - 2.0 * gap, 0.0)
    inside = len(scene.within(scene.surface_xy, center, 0.0, inner)) if inner > 0 else 0
    cell = scene.grid.cell_of(center[None, :])[0]
    shape = scene.border_distance.shape
    if 0 <= cell[0] < shape[0] and 0 <= cell[1] < shape[1]:
        border_gap = max(float(scene.border_distance[cell[0], cell[1]]) - radius, 0.0)
    else:
        border_gap = 0.0
    surface = measured.surface_plane
    return Doubts(rim_points=int(hole.rim_points),
                  rim_gap_deg=float(np.degrees(largest_angular_gap(measured.rim_xy, center))),
                  inside_points=int(inside), inside_expected=float(scene.surface_density * np.pi * inner ** 2),
                  surface_rms=None if surface is None else float(surface.rms), height_noise=float(scene.height_noise),
                  arc_deg=float(hole.arc_deg), border_gap=border_gap, radius=float(radius),
                  bias_correction=None if measured.cone_slope is not None else float(hole.bias_correction),
                  spacing=float(scene.sampling.spacing), fit_rms=float(hole.fit_rms), gap=float(gap),
                  hidden_fringe=float(measured.fringe[2]),
                  bias_measured=not _bias_not_measured(measured), facing_conflict=scene.facing.conflict)


def _bias_not_measured(measured):
    """A rim fit whose sampling-bias correction was wanted and could not be measured: no synthetic
    hole cut into the material around it gave a rim (``holecli.robust.estimators.rim_fit._sampling_bias``)."""
    return measured.estimator == ESTIMATOR_RIM_FIT and measured.synthetic is None


def overlaps(a, b):
    """Whether two measured holes (:class:`holecli.robust.candidate.Measured`) are one: the center of
    either lies within the larger's radius of the other's."""
    return np.hypot(*(a.center - b.center)) < max(a.radius, b.radius)


def to_rejection(scene, rejected):
    """The :class:`holecli.results.Rejection` of a :class:`holecli.robust.candidate.Refusal` (plane
    frame) in the world."""
    center = from_plane_frame(np.array([rejected.center[0], rejected.center[1], 0.0]), scene.origin, scene.rotation)

    def number(value):
        return None if value is None else (int(value) if isinstance(value, (int, np.integer)) else float(value))

    shape = None
    if rejected.shape is not None:
        length, width, major = rejected.shape
        direction = scene.rotation[:2].T @ major  # in-plane axes back to the world
        shape = {"length": length, "width": width, "direction": [float(v) for v in direction]}
    return Rejection(check=rejected.check, reason=REJECTION_REASONS[rejected.check],
                     center=tuple(map(float, center)), diameter=2.0 * rejected.radius,
                     value=number(rejected.value), limit=number(rejected.limit), shape=shape)


def loop_hole(scene, loop):
    """The :class:`Hole` of an edge loop of a CAD export's vertices (:mod:`holecli.robust.edge_loops`)."""

    def world(center2d, height):
        return from_plane_frame(np.array([center2d[0], center2d[1], height]), scene.origin, scene.rotation)

    normal = scene.rotation[2]
    center = world(loop.center, 0.0)
    bore = countersink = counterbore = axis = None
    if loop.bore is not None:
        ring = loop.bore
        bore = Bore(diameter=ring.diameter, rms=ring.rms, points=ring.points, depth_range=(0.0, ring.depth),
                    arc_deg=360.0)
        along = center - world(ring.center, -ring.depth)
        axis = tuple(map(float, along / np.linalg.norm(along)))
    if loop.type == "countersunk":
        countersink = Countersink(diameter=loop.diameter, angle_deg=loop.cone_angle_deg, depth=loop.bore.depth,
                                  depth_from="bore", diameter_at_depth=None, gauge_depth=None, rms=None,
                                  points=loop.vertices + loop.bore.points, arc_deg=360.0)
    elif loop.type == "counterbored":
        counterbore = Counterbore(diameter=loop.diameter, depth=loop.counterbore_depth, rms=0.0,
                                  points=loop.bore.points)
    perpendicularity = None
    if axis is not None:
        perpendicularity = math.degrees(math.acos(min(1.0, abs(float(np.dot(axis, normal))))))
    count = max(len(scene.surface_xy), 1)
    extent = float(np.sqrt(np.mean(np.sum(scene.surface_xy ** 2, axis=1)))) if len(scene.surface_xy) else 1.0
    u_normal = max(float(scene.height_noise) / math.sqrt(count), resolution_uncertainty(scene.resolution)) / extent
    note = HoleNote(code="edge_loops", message=(
        f"{NOTE_CODES['edge_loops']} ({loop.vertices} vertices; the circle through them is "
        f"{loop.vertex_diameter:.6g})"))
    return Hole(index=0, center=tuple(map(float, center)), diameter=float(loop.diameter),
                normal=tuple(map(float, orient_normal(normal))), rim_points=int(loop.vertices), fit_rms=loop.rms,
                max_residual=loop.max_residual, roundness=loop.roundness, bias_correction=0.0, partial=False,
                arc_deg=360.0, scan_lines=None, type=loop.type, countersink=countersink, counterbore=counterbore,
                bore=bore, axis=axis, perpendicularity_deg=perpendicularity, notes=(note,),
                uncertainty=Uncertainty(center_in_plane=loop.u_center, center_along_normal=loop.u_height,
                                        diameter=loop.u_diameter, normal_deg=math.degrees(u_normal),
                                        estimator="edge_loops"))
