"""The whole drilled hole below its edge: its type, countersink, counterbore, bore, floor and axis.

The robust method finds each hole's edge on the surface (center, diameter, normal). Here the points
of the scan around and below that edge are read as the surfaces a drill leaves: a cone (countersink),
a flat step around the bore (counterbore), a flat floor across the hole (blind hole) and the bore's
cylindrical wall. Each is fitted in 3D with its axis free (:mod:`holecli.geometry.revolution`), so
that a hole drilled off the normal shows its tilt.

Steps (all distances from the edge's center ``c``; ``n`` the surface normal there, turned to point
out of the material: the side without the points below the surface):

1. Gather the points within ``shape_search_radii`` edge radii of the axis through ``c`` along ``n``
   and at most ``shape_depth_radii`` radii deep; a point is *below* when it lies more than
   ``shape_below_sigmas`` sigmas of the surface ring's noise under the surface.
2. A countersunk hole (the robust method accepted a cone at the edge, see
   :mod:`holecli.robust.estimators.cone`): the cone is fitted to the points below near the hinge the
   edge fit found, then again to every point within four rms of the first fit. Its diameter is taken
   where its axis meets the surface, its depth from there to where it meets the bore (fitted below
   it) or, with no bore seen, to the cone points' inner edge.
3. Otherwise a flat floor: of planes through three of the points below inside the edge (leaning at
   most ``shape_floor_max_tilt_deg`` off the normal: a floor is drilled square to a tilted axis),
   the one holding most points, fitted again to them. It makes the hole blind when its points reach the axis, counterbored when they ring
   it (a step around the bore). A floor needs ``shape_floor_fraction`` of the points below, spread
   over at least ``shape_floor_min_width`` radii (one row of wall points lies at one depth too).
4. The bore wall: the points below that are on no cone or floor (and under the step or cone), near
   their median distance from the axis; a cylinder is fitted with a free axis when the wall spans at
   least ``shape_axis_min_span`` radii along it, else parallel to the axis already known.
5. The axis: the cone's, else the bore's (free fit), else the floor's normal; the perpendicularity
   is its angle to ``n``.

A value the points cannot support is None, and the hole's notes say why (codes in
:data:`holecli.vocabulary.NOTE_CODES`): fewer than ``shape_min_points`` points, or a coverage around the
axis under ``shape_min_arc_deg`` degrees. Points that contradict the shape the hole was taken for (no
cone, no cylinder, an implausible angle) make the value None too, but with a warning
(:data:`holecli.vocabulary.WARNING_CODES`): the hole's type, and a countersink's edge, may be wrong.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional

import numpy as np

from holecli.geometry.kernels import largest_angular_gap, robust_sigma
from holecli.geometry.revolution import fit_cone, fit_cylinder, frame_about
from holecli.robust.uncertainty import model_error_rms, with_model_error
from holecli.results import (Bore, BoreUncertainty, Counterbore, CounterboreUncertainty, Countersink,
                             CountersinkUncertainty, HoleNote, HoleWarning)
from holecli.settings import DEFAULT_SETTINGS
from holecli.vocabulary import NOTE_CODES, WARNING_CODES

@dataclass(frozen=True)
class HoleShape:
    """What the points below a hole's edge show (see the module docstring)."""

    type: str
    countersink: Optional[Countersink]
    counterbore: Optional[Counterbore]
    bore: Bore
    axis: Optional[tuple]
    perpendicularity_deg: Optional[float]
    warnings: tuple  # of HoleWarning (WARNING_CODES)
    uncertainty: Optional[dict] = None  # countersink, counterbore, bore, axis_deg (see _uncertainty)
    notes: tuple = ()  # of HoleNote (NOTE_CODES): why a value is None
    # The bore diameter's standard uncertainty from its cylinder fit's noise alone (None without a bore
    # diameter): uncertainty["bore"] adds the model error, which the edge shares (see assemble.with_shape)
    bore_noise_u: Optional[float] = None


def _from_local_surface(d, height, rho, n, R, noise, spacing, settings):
    """Heights above the surface around the hole itself, and that surface's noise.

    The scan's noise and plane describe the whole scan; on a curved panel its heights spread by the
    sag across it (0.1 mm over 20 mm at R 500), which is no noise here, and the surface around a hole
    leaves its tangent plane by r^2 / 2R (20 um at 1.3 x 3.5 mm, R 500). A quadric in the hole's frame
    is fitted to the surface ring from the edge (plus two spacings) out to ``shape_search_radii`` edge
    radii, trimmed twice at ``shape_trim_sigmas``: heights are taken from it and the noise is its
    residuals'. With fewer than 12 ring points the tangent plane and the scan's noise stay.
    """
    ring = (rho > R + 2.0 * spacing) & (np.abs(height) < max(0.05 * R, 10.0 * noise))
    if np.count_nonzero(ring) < 12:
        return height, noise
    rotation = frame_about(n)
    u, v = (d @ rotation[0]), (d @ rotation[1])
    design = np.column_stack([np.ones(len(u)), u, v, u * u, u * v, v * v])
    kept = ring
    for _ in range(3):
        coefficients, *_ = np.linalg.lstsq(design[kept], height[kept], rcond=None)
        residual = height - design @ coefficients
        scale = max(robust_sigma(residual[kept]), 1e-9 * R)
        new_kept = ring & (np.abs(residual) < settings.shape_trim_sigmas * scale)
        if np.count_nonzero(new_kept) < 12 or np.array_equal(new_kept, kept):
            break
        kept = new_kept
    return residual, max(robust_sigma(residual[kept]), 1e-9 * R)


def _warning(code, detail):
    """A :class:`HoleNote` for a code of :data:`NOTE_CODES`, else a :class:`HoleWarning`."""
    if code in NOTE_CODES:
        return HoleNote(code=code, message=f"{NOTE_CODES[code]} ({detail})")
    return HoleWarning(code=code, message=f"{WARNING_CODES[code]} ({detail})")


def _arc_deg(points, center, axis):
    """Coverage (degrees) of ``points`` around the line through ``center`` along ``axis``."""
    if len(points) == 0:
        return 0.0
    rotation = frame_about(axis)
    xy = (points - center) @ rotation[:2].T
    return float(np.degrees(2.0 * np.pi - largest_angular_gap(xy, np.zeros(2))))


def _about(points, point, axis):
    """Distance from the axis line and axial position (along ``axis`` from ``point``) of ``points``."""
    d = points - point
    t = d @ axis
    rho = np.sqrt(np.maximum(np.einsum("ij,ij->i", d, d) - t * t, 0.0))
    return rho, t


def _surface_crossing(point, axis, center, normal):
    """Axial position (from ``point`` along ``axis``) where the axis meets the surface plane."""
    along = float(axis @ normal)
    return float((center - point) @ normal) / along if abs(along) > 1e-9 else 0.0


def _angle_deg(a, b):
    return float(np.degrees(np.arccos(np.clip(abs(float(a @ b)), -1.0, 1.0))))


def measure_hole_shape(points, center, normal, edge_radius, *, noise, spacing, cone_slope=None,
                       gauge_depth=None, settings=DEFAULT_SETTINGS):
    """Type, countersink, counterbore, bore and axis of one hole from the points around it.

    Parameters
    ----------
    points : (n, 3) float
        Points of the scan around the hole (at least those within ``shape_search_radii`` edge radii
        of its axis); others are ignored.
    center : (3,) float
        The edge's center on the surface.
    normal : (3,) float
        Unit surface normal at the hole (either sign).
    edge_radius : float
        The edge's radius on the surface.
    noise : float
        Standard deviation of the surface points' heights.
    spacing : float
        The scan's point spacing.
    cone_slope : float or None
        Depth per radius of the countersink cone the robust method accepted at the edge; None when it
        accepted none (the hole is then not countersunk).
    gauge_depth : float or None
        Depth below the surface at which to give the countersink's diameter.
    settings : RobustSettings
        The ``shape_*`` thresholds.

    Returns
    -------
    HoleShape
    """
    c = np.asarray(center, dtype=np.float64)
    n = np.asarray(normal, dtype=np.float64)
    n = n / np.linalg.norm(n)
    R = float(edge_radius)
    d = np.asarray(points, dtype=np.float64) - c
    height = d @ n
    rho = np.sqrt(np.maximum(np.einsum("ij,ij->i", d, d) - height * height, 0.0))
    near = (rho < settings.shape_search_radii * R) & (np.abs(height) < settings.shape_depth_radii * R)
    pts, height, rho = np.asarray(points, dtype=np.float64)[near], height[near], rho[near]
    height, noise = _from_local_surface(pts - c, height, rho, n, R, noise, spacing, settings)
    threshold = settings.shape_below_sigmas * max(noise, 1e-9 * R)
    # Out of the material: the side of the surface without the points inside the edge off it.
    inner = rho < R
    if np.count_nonzero(inner & (height > threshold)) > np.count_nonzero(inner & (height < -threshold)):
        n, height = -n, -height
    below = height < -threshold
    floor_noise = max(noise, 1e-9 * R)
    warnings = []
    countersink = counterbore = cone = floor = None
    axis = None
    wall_mask = np.zeros(len(pts), dtype=bool)
    known_axis = n

    if cone_slope is not None:
        kind = "countersunk"
        countersink, cone, cone_mask = _countersink(pts, rho, -height, below, c, n, R, cone_slope, floor_noise,
                                                    spacing, gauge_depth, settings, warnings)
        if cone is not None:
            axis, known_axis = cone.axis, cone.axis
            # Under the cone: deeper along the axis than the cone is at the point's distance from it
            # (the bore wall below the cone's lower edge, where the cone's extension would be narrower).
            crp, crt = _about(pts, cone.point, cone.axis)
            level = (crp - cone.radius) / np.tan(cone.half_angle)
            under_cone = crt < level - max(4.0 * cone.rms, 3.0 * floor_noise, 1e-6 * R)
            wall_mask = below & ~cone_mask & under_cone
        else:
            wall_mask = below & (rho < R)
    else:
        floor = _floor(pts, rho, below, n, R, floor_noise, settings)
        if floor is None:
            kind = "through"
            wall_mask = below & (rho < R + 2.0 * spacing + 0.1 * R)
        else:
            floor_point, floor_normal, floor_mask, floor_rms = floor
            floor_normal = floor_normal if floor_normal @ n > 0 else -floor_normal
            blind = _floor_is_blind(pts[floor_mask], rho[floor_mask], c, floor_normal, R, settings)
            kind = "blind" if blind else "counterbored"
            known_axis = floor_normal
            # Height above the floor's plane: a blind hole's wall stands above it, a counterbore's bore
            # goes on below it.
            above_floor = (pts - floor_point) @ floor_normal
            if blind:
                wall_mask = below & ~floor_mask & (above_floor > 3.0 * floor_noise)
            else:
                wall_mask = below & ~floor_mask & (above_floor < -3.0 * floor_noise)

    bore, bore_axis, cylinder = _bore(pts, wall_mask, c, n, known_axis, floor_noise, settings, warnings)
    if cone is not None:
        if bore.diameter is not None:
            lower, source = 0.5 * bore.diameter, "bore"
        else:
            lower, source = _inner_edge_radius(cone, pts[cone_mask]), "cone_inner_edge"
        countersink = _with_depth(countersink, cone, c, n, lower, source, gauge_depth, warnings)
    if axis is None:
        axis = bore_axis if bore_axis is not None else (known_axis if kind in ("blind", "counterbored") else None)
    if axis is not None:
        axis = axis if axis @ n > 0 else -axis
    if floor is not None:
        # The floor's depth along the axis (known: the bore's, else the floor's own normal), where the
        # axis through c meets the floor's plane.
        along_axis = float((c - floor_point) @ floor_normal) / float(axis @ floor_normal)
        if kind == "blind":
            bore = Bore(**{**bore.__dict__, "floor_depth": along_axis, "floor_rms": floor_rms})
        else:
            counterbore = Counterbore(diameter=2.0 * R, depth=along_axis, rms=floor_rms,
                                      points=int(np.count_nonzero(floor_mask)))
    if axis is None:
        warnings.append(_warning("axis_not_measured", f"{kind} hole"))
        perpendicularity = None
    else:
        perpendicularity = _angle_deg(axis, n)
        axis = tuple(float(v) for v in axis)
    from_inner_edge = countersink is not None and countersink.depth_from == "cone_inner_edge"
    inner_gap = _inner_edge_gap(cone, pts[cone_mask]) if from_inner_edge else 0.0
    uncertainty = _uncertainty(countersink, cone, counterbore, bore, cylinder if bore.diameter is not None else None,
                               c, n, axis, bore_axis, floor_rms if floor is not None else None,
                               noise=floor_noise, inner_gap=inner_gap)
    bore_noise_u = None
    if bore.diameter is not None and cylinder is not None and cylinder.covariance is not None:
        bore_noise_u = 2.0 * math.sqrt(max(float(cylinder.covariance[4, 4]), 0.0))
    return HoleShape(type=kind, countersink=countersink, counterbore=counterbore, bore=bore, axis=axis,
                     perpendicularity_deg=perpendicularity,
                     warnings=tuple(w for w in warnings if isinstance(w, HoleWarning)), uncertainty=uncertainty,
                     notes=tuple(w for w in warnings if isinstance(w, HoleNote)), bore_noise_u=bore_noise_u)


def _uncertainty(countersink, cone, counterbore, bore, cylinder, c, n, axis, bore_axis, floor_rms, noise=0.0,
                 inner_gap=0.0):
    """Standard uncertainties of the values below the edge, from the least-squares covariances of the
    cone and cylinder fits (:func:`holecli.geometry.revolution.fit_cone`), propagated to first order:
    ``{"countersink", "counterbore", "bore", "axis_deg"}`` (dataclasses of holecli.results or None).

    Each covariance is widened for the residuals the surface's ``noise`` does not explain
    (:func:`holecli.robust.uncertainty.with_model_error`: a faceted or finely sampled noise-free cone's
    departure from the model does not average down with the number of points). A depth down to the
    cone points' inner edge (no bore seen) also carries that edge's sampling gap ``inner_gap``
    (:func:`_inner_edge_gap`: the innermost point lies on average that far outside the edge, with a
    spread as large).

    The countersink's diameters also carry the model error's mean offset, which the fit takes into
    its radius and so the residuals cannot show: a surface departing from the cone by rms ``m`` (see
    :func:`holecli.robust.uncertainty.model_error_rms`) may lie on average that far off the cone a
    drawing means (a tessellated cone's facets lie 2.2 ``m`` inside the circle through its vertices,
    the CAD model's nominal), a radius's ``m / cos(half angle)``, added in quadrature.

    A floor's depth gets its points' rms (the scatter of the floor, an upper bound of its plane's
    height uncertainty); the counterbore's diameter is its edge's, given by the hole's own
    uncertainty (None here)."""
    out = {"countersink": None, "counterbore": None, "bore": None, "axis_deg": None}
    axis_covariance = None
    if cone is not None and cone.covariance is not None and countersink is not None:
        cov = with_model_error(cone.covariance, cone.rms, noise, np.count_nonzero(cone.kept))
        tangent, secant2 = float(np.tan(cone.half_angle)), 1.0 / float(np.cos(cone.half_angle)) ** 2

        def u_radius_at(axial):
            variance = cov[4, 4] + axial ** 2 * secant2 ** 2 * cov[5, 5] + 2.0 * axial * secant2 * cov[4, 5]
            return math.sqrt(max(float(variance), 0.0))

        top = _surface_crossing(cone.point, cone.axis, c, n)
        u_top = u_radius_at(top)
        offset = model_error_rms(cone.rms, noise) / float(np.cos(cone.half_angle))
        u_depth = None
        if countersink.depth is not None:
            cylinder_cov = (None if cylinder is None else
                            with_model_error(cylinder.covariance, cylinder.rms, noise, np.count_nonzero(cylinder.kept)))
            lower_u = (float(inner_gap) if cylinder_cov is None
                       else math.sqrt(max(float(cylinder_cov[4, 4]), 0.0)))
            u_depth = (math.hypot(u_top, lower_u) / tangent
                       + countersink.depth * secant2 / tangent * math.sqrt(max(float(cov[5, 5]), 0.0)))
        at_depth = None
        if countersink.diameter_at_depth is not None and countersink.gauge_depth is not None:
            at_depth = 2.0 * math.hypot(u_radius_at(top - countersink.gauge_depth), offset)
        out["countersink"] = CountersinkUncertainty(
            diameter=None if countersink.diameter is None else 2.0 * math.hypot(u_top, offset),
            angle_deg=None if countersink.angle_deg is None else math.degrees(2.0 * math.sqrt(max(float(cov[5, 5]), 0.0))),
            depth=u_depth, diameter_at_depth=at_depth)
        axis_covariance = cov[2:4, 2:4]
    if bore is not None and (bore.diameter is not None or bore.floor_depth is not None):
        u_bore = None
        if bore.diameter is not None and cylinder is not None and cylinder.covariance is not None:
            cylinder_cov = with_model_error(cylinder.covariance, cylinder.rms, noise, np.count_nonzero(cylinder.kept))
            u_bore = 2.0 * math.sqrt(max(float(cylinder_cov[4, 4]), 0.0))
            if axis_covariance is None and bore_axis is not None:
                axis_covariance = cylinder_cov[2:4, 2:4]
        out["bore"] = BoreUncertainty(diameter=u_bore,
                                      floor_depth=None if bore.floor_depth is None else bore.floor_rms)
    if counterbore is not None:
        out["counterbore"] = CounterboreUncertainty(diameter=None, depth=floor_rms)
    # an axis from a floor's normal gets the surface normal's uncertainty (holecli.robust.assemble)
    if axis is not None and axis_covariance is not None:
        out["axis_deg"] = math.degrees(math.sqrt(max(float(np.linalg.eigvalsh(axis_covariance)[-1]), 0.0)))
    return out


def _countersink(pts, rho, depth, below, c, n, R, slope, noise, spacing, gauge_depth, settings, warnings):
    """The countersink from the cone fit; (Countersink, Cone or None, mask of the cone's points)."""
    margin = max(10.0 * noise, 0.15 * R)
    guess = below & (rho < R + 2.0 * spacing) & (np.abs(depth - slope * np.maximum(R - rho, 0.0)) < margin)
    empty = Countersink(diameter=None, angle_deg=None, depth=None, depth_from=None, diameter_at_depth=None,
                        gauge_depth=gauge_depth, rms=None, points=int(np.count_nonzero(guess)), arc_deg=0.0)
    if np.count_nonzero(guess) < settings.shape_min_points:
        warnings.append(_warning("cone_few_points", f"{np.count_nonzero(guess)} < {settings.shape_min_points}"))
        return empty, None, guess
    half = float(np.arctan(1.0 / slope))
    cone = fit_cone(pts[guess], c, n, R, half, floor=noise, trim_sigmas=settings.shape_trim_sigmas)
    # Once more on every point near the first fit: the first guess's band is a hinge's, not the cone's.
    crp, crt = _about(pts, cone.point, cone.axis)
    residual = (crp - cone.radius_at(crt)) * np.cos(cone.half_angle)
    on_cone = below & (np.abs(residual) < max(4.0 * cone.rms, 3.0 * noise))
    if np.count_nonzero(on_cone) >= settings.shape_min_points:
        cone = fit_cone(pts[on_cone], cone.point, cone.axis, cone.radius, cone.half_angle, floor=noise,
                        trim_sigmas=settings.shape_trim_sigmas)
        mask = on_cone.copy()
        mask[on_cone] = cone.kept
    else:
        mask = guess.copy()
        mask[guess] = cone.kept
    used = int(np.count_nonzero(mask))
    arc = _arc_deg(pts[mask], cone.point, cone.axis)
    angle = float(np.degrees(2.0 * cone.half_angle))
    base = Countersink(diameter=None, angle_deg=None, depth=None, depth_from=None, diameter_at_depth=None,
                       gauge_depth=gauge_depth, rms=cone.rms, points=used, arc_deg=arc)
    if used < settings.shape_min_points:
        warnings.append(_warning("cone_few_points", f"{used} < {settings.shape_min_points}"))
        return base, None, mask
    if arc < settings.shape_min_arc_deg:
        warnings.append(_warning("cone_short_arc", f"{arc:.0f} < {settings.shape_min_arc_deg:g} degrees"))
        return base, None, mask
    limit = _rms_limit(noise, R, settings)
    if cone.rms > limit:
        warnings.append(_warning("cone_not_conical", f"rms {cone.rms:.3g} > {limit:.3g}"))
        return base, None, mask
    if not settings.shape_min_angle_deg <= angle <= settings.shape_max_angle_deg:
        warnings.append(_warning("cone_angle_implausible", f"{angle:.1f} degrees"))
        return base, None, mask
    top = _surface_crossing(cone.point, cone.axis, c, n)
    diameter = float(2.0 * cone.radius_at(top))
    measured = Countersink(diameter=diameter, angle_deg=angle, depth=None, depth_from=None,
                           diameter_at_depth=None, gauge_depth=gauge_depth, rms=cone.rms, points=used, arc_deg=arc)
    return measured, cone, mask


def _rms_limit(noise, radius, settings):
    """Largest rms a cone or cylinder fit may leave: shape_max_rms_sigmas times the surface noise, and
    at least shape_max_rms_radii of the radius (for noise-free scans, whose facets and round-off
    remain)."""
    return max(settings.shape_max_rms_sigmas * noise, settings.shape_max_rms_radii * radius)


def _inner_edge_gap(cone, pts):
    """The gap expected between the cone's inner edge and the innermost of ``pts`` (see
    :func:`_inner_edge_radius`)."""
    radius, _ = _about(pts, cone.point, cone.axis)
    inner, outer = float(np.min(radius)), float(np.max(radius))
    density = len(pts) / max(np.pi * (outer ** 2 - inner ** 2), 1e-300)
    return 1.0 / max(density * 2.0 * np.pi * inner, 1e-300)


def _inner_edge_radius(cone, pts):
    """Radius of the cone points' inner edge, where the cone meets the bore (seen from above, the
    bore wall hidden): the innermost cone point's distance from the axis, less the gap expected
    between the edge and the innermost of points of the density seen (1 / (density x circumference)
    for points spread at random; a few um at 0.1 mm pitch). The distance from the axis of a point
    seen along the axis does not move with its range noise."""
    radius, _ = _about(pts, cone.point, cone.axis)
    inner = float(np.min(radius))
    outer = float(np.max(radius))
    density = len(pts) / max(np.pi * (outer ** 2 - inner ** 2), 1e-300)
    return inner - 1.0 / max(density * 2.0 * np.pi * inner, 1e-300)


def _with_depth(countersink, cone, c, n, lower_radius, source, gauge_depth, warnings):
    """The countersink with its depth to the lower edge of ``lower_radius`` and the gauge diameter."""
    top = _surface_crossing(cone.point, cone.axis, c, n)
    tangent = float(np.tan(cone.half_angle))
    depth = float((cone.radius_at(top) - lower_radius) / tangent)
    at_depth = None
    if gauge_depth is not None:
        if 0.0 <= gauge_depth <= depth:
            at_depth = float(2.0 * (cone.radius_at(top) - gauge_depth * tangent))
        else:
            warnings.append(_warning("gauge_depth_outside_cone", f"{gauge_depth:g} not in [0, {depth:.4g}]"))
    return Countersink(**{**countersink.__dict__, "depth": depth, "depth_from": source,
                          "diameter_at_depth": at_depth})


def _floor(pts, rho, below, up, R, noise, settings):
    """The flat floor inside the edge: (point, normal, mask, rms), or None when there is none
    (``up``: the surface normal)."""
    inside = below & (rho < R)
    count = int(np.count_nonzero(inside))
    if count < settings.shape_min_points:
        return None
    # The plane holding most of the points below: a floor drilled off the normal is tilted with the
    # axis, so its depth along the normal varies across it (by 2 R tan(5 deg) = 0.3 mm at 3.5 mm).
    # Planes through three of the points, those leaning at most shape_floor_max_tilt_deg off the
    # normal; seeded, so the result does not vary from run to run.
    index = np.flatnonzero(inside)
    band = max(4.0 * noise, 0.01 * R)
    rng = np.random.default_rng(0)
    triples = index[rng.integers(0, len(index), (settings.shape_floor_hypotheses, 3))]
    a, b, c3 = pts[triples[:, 0]], pts[triples[:, 1]], pts[triples[:, 2]]
    normals = np.cross(b - a, c3 - a)
    lengths = np.linalg.norm(normals, axis=1)
    usable = lengths > 1e-12 * R * R
    normals = normals[usable] / lengths[usable, None]
    a = a[usable]
    steep = np.abs(normals @ up) < np.cos(np.radians(settings.shape_floor_max_tilt_deg))
    normals, a = normals[~steep], a[~steep]
    if len(normals) == 0:
        return None
    offsets = np.einsum("ij,ij->i", a, normals)
    support = (np.abs(pts[index] @ normals.T - offsets) < band).sum(axis=0)
    best = int(np.argmax(support))
    candidates = inside & (np.abs((pts - a[best]) @ normals[best]) < band)
    if np.count_nonzero(candidates) < max(settings.shape_min_points, settings.shape_floor_fraction * count):
        return None
    mask = candidates
    for _ in range(4):
        floor_pts = pts[mask]
        point = floor_pts.mean(axis=0)
        _, _, vt = np.linalg.svd(floor_pts - point, full_matrices=False)
        normal = vt[2]
        distance = (pts - point) @ normal
        scale = max(robust_sigma(distance[mask]), noise)
        new_mask = inside & (np.abs(distance) < settings.shape_trim_sigmas * scale)
        if np.count_nonzero(new_mask) < settings.shape_min_points or np.array_equal(new_mask, mask):
            break
        mask = new_mask
    if np.count_nonzero(mask) < max(settings.shape_min_points, settings.shape_floor_fraction * count):
        return None
    if np.ptp(rho[mask]) < settings.shape_floor_min_width * R:
        return None
    rms = float(np.sqrt(np.mean(((pts[mask] - point) @ normal) ** 2)))
    return point, normal, mask, rms


def _floor_is_blind(floor_pts, floor_rho, c, normal, R, settings, sector_deg=10.0):
    """Whether a floor is a blind hole's (across the axis) rather than a counterbore's step (around it).

    It is when its points reach within ``shape_floor_center_radii`` edge radii of the axis. A blind
    floor seen from a tilted view can show only a lune on one side, the rest hidden by the wall: then
    its side toward the axis is an arc of the opening's shadow, and the floor lies inside the circle of
    that arc; a step's side toward the axis is the bore's edge, and the step lies outside it. The arc
    is the innermost floor point of every ``sector_deg`` sector around the axis, fitted with a circle.
    """
    if np.min(floor_rho) < settings.shape_floor_center_radii * R:
        return True
    rotation = frame_about(normal)
    xy = (floor_pts - c) @ rotation[:2].T
    sector = np.floor((np.degrees(np.arctan2(xy[:, 1], xy[:, 0])) + 180.0) / sector_deg).astype(np.int64)
    order = np.lexsort((floor_rho, sector))
    first = np.ones(len(order), dtype=bool)
    first[1:] = sector[order][1:] != sector[order][:-1]
    boundary = xy[order][first]
    if len(boundary) < 4:
        return False
    # Kasa's circle through the boundary: x^2 + y^2 = 2 a x + 2 b y + k.
    design = np.column_stack([2.0 * boundary, np.ones(len(boundary))])
    (a, b, k), *_ = np.linalg.lstsq(design, np.einsum("ij,ij->i", boundary, boundary), rcond=None)
    radius = np.sqrt(max(k + a * a + b * b, 0.0))
    inside = np.hypot(xy[:, 0] - a, xy[:, 1] - b) < radius
    return bool(np.mean(inside) > 0.5)


def _bore(pts, wall_mask, c, n, known_axis, noise, settings, warnings):
    """The bore from the wall points: (Bore, the cylinder's axis when its direction was fitted)."""
    count = int(np.count_nonzero(wall_mask))
    empty = Bore(diameter=None, rms=None, points=0, depth_range=None, arc_deg=None)
    if count < settings.shape_min_points:
        warnings.append(_warning("bore_not_seen", f"{count} wall points < {settings.shape_min_points}"))
        return empty, None, None
    radial, _ = _about(pts, c, known_axis)
    typical = float(np.median(radial[wall_mask]))
    candidates = wall_mask & (np.abs(radial - typical) < 0.25 * typical)
    if np.count_nonzero(candidates) < settings.shape_min_points:
        warnings.append(_warning("bore_not_seen", f"{int(np.count_nonzero(candidates))} wall points < "
                                                  f"{settings.shape_min_points}"))
        return empty, None, None
    axial = (pts[candidates] - c) @ known_axis
    span = float(np.ptp(axial))
    free = span >= settings.shape_axis_min_span * typical
    cylinder = fit_cylinder(pts[candidates], c, known_axis, typical, fixed_axis=not free, floor=noise,
                            trim_sigmas=settings.shape_trim_sigmas)
    if free and _angle_deg(cylinder.axis, known_axis) > settings.shape_max_axis_change_deg:
        # Walls of two radii (a counterbore's and the bore's) or a wall and stray points pull a free
        # axis over; a bore drilled that far off the axis known (the cone's, the floor's, the normal)
        # is no bore of this hole: its direction is not trusted.
        free = False
        cylinder = fit_cylinder(pts[candidates], c, known_axis, typical, fixed_axis=True, floor=noise,
                                trim_sigmas=settings.shape_trim_sigmas)
    wall = pts[candidates][cylinder.kept]
    arc = _arc_deg(wall, cylinder.point, cylinder.axis)
    depths = -((wall - c) @ n)
    if len(wall) < settings.shape_min_points:
        warnings.append(_warning("bore_not_seen", f"{len(wall)} wall points < {settings.shape_min_points}"))
        return empty, None, None
    limit = _rms_limit(noise, cylinder.radius, settings)
    if cylinder.rms > limit:
        warnings.append(_warning("bore_not_cylindrical", f"rms {cylinder.rms:.3g} > {limit:.3g}"))
        return Bore(diameter=None, rms=cylinder.rms, points=len(wall),
                    depth_range=(float(depths.min()), float(depths.max())), arc_deg=arc), None, None
    if arc < settings.shape_min_arc_deg:
        warnings.append(_warning("bore_short_arc", f"{arc:.0f} < {settings.shape_min_arc_deg:g} degrees"))
        return Bore(diameter=None, rms=cylinder.rms, points=len(wall),
                    depth_range=(float(depths.min()), float(depths.max())), arc_deg=arc), None, None
    bore = Bore(diameter=float(2.0 * cylinder.radius), rms=cylinder.rms, points=len(wall),
                depth_range=(float(depths.min()), float(depths.max())), arc_deg=arc)
    return bore, (cylinder.axis if free else None), cylinder
