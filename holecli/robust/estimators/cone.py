"""The edge of a countersunk hole: where the countersink cone meets the surface.

Near the edge the cone is only slightly below the surface, so with noise its outer part falls inside
the surface band and the rim of the surface points lies inside the true edge (by about 0.8 spacing
at 10 % noise). The cone itself is measured instead: around the rim, the depth of every point below
the surface is fitted by the hinge ``depth = s * max(0, R - rho)`` of the radial distance ``rho``
from the center, and ``R`` is the edge.

The hinge fits whatever lies below the surface near the rim, so a cone is accepted only when the
points it explains look like one; every refusal names its check (:class:`NotACone`). The visible
flat floor of a blind hole is the case to refuse: points at one depth all across the inside of the
edge (with the bore wall, an L in depth against radius), which the hinge turns into a steep cone
whose edge lies well outside the hole.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import partial

import numpy as np

from holecli.geometry import lsq
from holecli.geometry.kernels import robust_sigma
from holecli.robust.estimators.harness import EdgeEstimate
from holecli.robust.surface import surface_height
from holecli.settings import DEFAULT_SETTINGS
from holecli.vocabulary import ESTIMATOR_CONE

# A cone found by the least-median start must have its points below the surface spread over at least
# this fraction of the radii from the edge to the innermost of them (interquartile range): not a
# bore's wall, which stands at one radius (see fit_cone_edge).
WALL_COLUMN_SPREAD = 0.2


@dataclass(frozen=True)
class Cone:
    """A countersink cone: its edge radius on the surface and its wall slope (depth per radius)."""

    radius: float
    slope: float
    points: int


@dataclass(frozen=True)
class NotACone:
    """Why the points around a rim are not a countersink cone: the check, its value and its limit.

    ``check`` is ``"points_below"`` (too few points clearly below the surface inside the rim),
    ``"slope"`` (the wall's slope is outside [cone_min_slope, cone_max_slope]: a bore wall or no cone) or
    ``"flat_floor"`` (the depth does not grow toward the center as the cone's slope says: a flat
    hole floor, value and limit as fractions of the fitted slope) or ``"wall_column"`` (a hinge found
    from the least-median start whose points below the surface stand at one radius, a bore's wall:
    value and limit the interquartile range of their radii over the edge's distance to the innermost,
    :data:`WALL_COLUMN_SPREAD`) or ``"unresolved"`` (the points clearly below the surface reach less
    than ``cone_min_span_gaps`` gaps inside the edge: the fringe of mixed pixels at a plain hole's
    rim, not a cone the scan resolves; value and limit in the scan's length unit).
    """

    check: str
    value: float
    limit: float


def _hinge(rho, depth, edge):
    ramp = np.maximum(edge - rho, 0.0)
    energy = float(ramp @ ramp)
    if energy <= 0.0:
        return 0.0, np.inf
    slope = float(ramp @ depth) / energy
    residual = depth - slope * ramp
    return slope, float(residual @ residual)


def _least_median_hinge(rho, depth, edge, max_slope):
    """The hinge of :func:`_hinge` by least median of absolute residuals, over points below the
    surface: the slope in ``[0, 2 max_slope]`` (steps of 1 %, then 0.05 % around the best) whose hinge
    leaves the smallest median ``|depth - slope * max(edge - rho, 0)|``, and that median as the error.

    A bore wall seen on one side of the hole (a tilted view) stands at one radius with its points
    millimetres deep; on a coarse scan they can be as many as the cone's. In least squares they bend
    the hinge to a wall's slope; the cone's points are still more than half of the points below the
    surface, so the least median hinge follows them. Only points below the surface are given: the
    surface's own points fit a hinge of any slope beyond its edge, and where they are most of the
    points the median would be theirs."""
    if len(rho) == 0:
        return 0.0, np.inf
    ramp = np.maximum(edge - rho, 0.0)
    coarse = np.linspace(0.0, 2.0 * max_slope, 201)
    best = float(coarse[_least_median_slope(depth, ramp, coarse)[0]])
    step = coarse[1] - coarse[0]
    fine = np.linspace(best - step, best + step, 41)
    index, error = _least_median_slope(depth, ramp, fine)
    return float(fine[index]), float(error)


def _median_errors(depth, ramp, slopes):
    """Per slope, the median of ``|depth - slope * ramp|``."""
    errors = slopes[:, None] * ramp[None, :]
    np.subtract(depth[None, :], errors, out=errors)
    np.abs(errors, out=errors)
    return np.median(errors, axis=1, overwrite_input=True)  # (partitioned in place: no copy)


# _least_median_slope works out the medians of every STRIDES[0]-th slope first, then of every
# STRIDES[1]-th among those still possible, and so on.
STRIDES = (16, 8, 4, 2, 1)
# With at most this many errors (points times slopes) every median is worked out at once.
ALL_MEDIANS_UP_TO = 40_000


def _least_median_slope(depth, ramp, slopes):
    """``(i, e)``: the first index of the smallest of :func:`_median_errors` over ``slopes``, and that
    error; the same as ``np.argmin`` of all of them, without working out every median.

    A point's error ``|depth - s ramp|`` moves by at most ``|ds| ramp`` when the slope moves by
    ``ds``, and so does their median: with ``B`` the largest ramp, a slope ``s`` whose error is
    known to be ``e`` gives every other slope ``t`` an error of at least ``e - |t - s| B``. The
    medians are worked out coarse to fine (:data:`STRIDES`), and a slope whose bound from the
    medians known so far exceeds the smallest of them (by more than the round-off of the errors) can
    be neither the smallest nor tie it: its median is skipped. Each median is the one
    :func:`_median_errors` gives, so the result is the same to the last bit; on the thousands of
    points of a bore wall around a hole most of the 201 coarse and 41 fine medians are skipped.
    """
    count = len(slopes)
    largest = float(ramp.max())
    reach = float(np.max(np.abs(depth))) + float(np.max(np.abs(slopes))) * largest
    if (len(depth) * count <= ALL_MEDIANS_UP_TO or not np.isfinite(reach) or not np.all(np.isfinite(depth))
            or not np.all(np.isfinite(slopes))):
        # Few errors (the levels would cost more than they skip), or NaN or inf: argmin's own rules.
        errors = _median_errors(depth, ramp, slopes)
        index = int(np.argmin(errors))
        return index, float(errors[index])
    if largest == 0.0:
        # No point inside the edge: the errors are |depth| whatever the slope, all alike (s * 0 is
        # a zero), and the first is the smallest.
        return 0, float(_median_errors(depth, ramp, slopes[:1])[0])
    # The errors and their medians carry a few units of round-off of their magnitude (reach); the
    # margin is a million times that, far below any real difference between two slopes.
    margin = 1e-9 * reach
    errors = np.full(count, np.nan)
    known = np.zeros(count, dtype=bool)
    for stride in STRIDES:
        chosen = np.zeros(count, dtype=bool)
        chosen[::stride] = True
        chosen[-1] = True
        chosen &= ~known
        if known.any():
            bound = np.max(errors[known][None, :] - np.abs(slopes[:, None] - slopes[known][None, :]) * largest, axis=1)
            chosen &= bound - margin <= np.min(errors[known])
        if chosen.any():
            errors[chosen] = _median_errors(depth, ramp, slopes[chosen])
            known |= chosen
    smallest = np.min(errors[known])
    index = int(np.flatnonzero(known & (errors == smallest))[0])
    return index, float(errors[index])


def _best_edge(rho, depth, low, high, steps, hinge=_hinge):
    edges = np.linspace(low, high, steps)
    errors = np.array([hinge(rho, depth, edge)[1] for edge in edges])
    best = int(np.argmin(errors))
    # One finer pass around the best coarse edge.
    step = edges[1] - edges[0]
    fine = np.linspace(edges[best] - step, edges[best] + step, steps)
    errors = np.array([hinge(rho, depth, edge)[1] for edge in fine])
    edge = float(fine[int(np.argmin(errors))])
    return edge, hinge(rho, depth, edge)[0]


def _depth_slope(rho, depth, bins_count, min_bin_points):
    """Slope of depth against radius (positive: deeper toward the center), or None when unmeasurable.

    The Theil-Sen slope (median over pairs) of the median depths of ``bins_count`` radial bins spanning
    the points. Bin medians, and the median over pairs of bins, keep the slope of a floor at zero
    whatever a bore wall adds: the wall stands at one radius, so it moves one bin or two. The bins span
    the points themselves, not the range up to the fitted edge: a cone fitted to a floor claims
    points below the surface out to its edge, where there are none.
    """
    if len(rho) < 2 * min_bin_points:
        return None
    low, high = (float(v) for v in np.percentile(rho, [1.0, 99.0]))
    if not high > low:
        return None
    bins = np.clip(np.floor(bins_count * (rho - low) / (high - low)), 0, bins_count - 1).astype(np.int64)
    medians, centers = [], []
    for b in np.unique(bins):
        members = bins == b
        if np.count_nonzero(members) >= min_bin_points:
            medians.append(float(np.median(depth[members])))
            centers.append(float(np.median(rho[members])))
    if len(medians) < 2:
        return None
    medians, centers = np.array(medians), np.array(centers)
    i, j = np.triu_indices(len(medians), k=1)
    return float(np.median((medians[i] - medians[j]) / (centers[j] - centers[i])))


def points_on_hinge(rho, depth, edge, slope, noise, floor, trim_sigmas, among=None):
    """The points within ``trim_sigmas`` robust standard deviations of the hinge
    ``depth = slope * max(edge - rho, 0)``.

    Parameters
    ----------
    rho, depth : (n,) float
        As for :func:`fit_cone_edge`.
    edge, slope : float
        The hinge.
    noise, floor : float
        Least scale: the surface's height noise, and a floor for a noise-free scan.
    trim_sigmas : float
        ``cone_trim_sigmas``.
    among : (n,) bool, optional
        The points whose residuals give the scale (default: all).

    Returns
    -------
    (n,) bool
    """
    residual = depth - slope * np.maximum(edge - rho, 0.0)
    scale = max(robust_sigma(residual if among is None else residual[among]), noise, floor)
    return np.abs(residual) < trim_sigmas * scale


def _trimmed_hinge(rho, depth, radius, width, noise, settings, median_start=None):
    """The hinge's edge and slope after trimming the points far off it (bore-wall and bottom points,
    far below the cone), and the points kept.

    The first hinge is a least-squares one, or, given ``median_start`` (a mask of the points below the
    surface), a least median one over those points (:func:`_least_median_hinge`); the next are least
    squares over the points kept.

    The trimming scale is that of the kept points inside the edge (the cone's; when they are at least
    ``cone_min_points_below``), not of all kept points: most of those lie on the surface beyond the
    edge, where the hinge is flat and fits them to their noise. On a noise-free scan their residuals
    are 0 (or a range quantum), while a CAD countersink is a pyramid of flat facets whose points lie
    up to a sagitta off the cone: a scale from the surface trims every cone point and leaves a hinge
    of slope 0.
    """
    keep = np.ones(len(rho), dtype=bool)
    for round_ in range(settings.cone_trim_rounds):
        if round_ == 0 and median_start is not None:
            edge, slope = _best_edge(rho[median_start], depth[median_start], radius - width, radius + width,
                                     settings.cone_edge_steps,
                                     hinge=partial(_least_median_hinge, max_slope=settings.cone_max_slope))
        else:
            edge, slope = _best_edge(rho[keep], depth[keep], radius - width, radius + width,
                                     settings.cone_edge_steps)
        cone = keep & (rho < edge)
        among = cone if np.count_nonzero(cone) >= settings.cone_min_points_below else keep
        new_keep = points_on_hinge(rho, depth, edge, slope, noise, 1e-12 * radius, settings.cone_trim_sigmas,
                                   among=among)
        if np.array_equal(new_keep, keep):
            break
        keep = new_keep
    return edge, slope, keep


def fit_cone_edge(rho, depth, radius, width, noise, depth_slope_ratio=None, *,
                  settings=DEFAULT_SETTINGS, gap=None):
    """Countersink edge from points around a hole, or the reason there is no cone.

    Parameters
    ----------
    rho : (n,) float
        Radial distance of each point from the hole's center, in the plane.
    depth : (n,) float
        Depth of each point below the surface plane (positive below).
    radius : float
        The rim fit's radius (the edge lies near it).
    width : float
        Half-width of the radial window searched for the edge.
    noise : float
        Standard deviation of the surface points' heights.
    depth_slope_ratio : float, optional
        Least slope of depth against radius of the points below the surface inside the edge, as a
        fraction of the cone's slope (the ``"flat_floor"`` check); None: ``cone_depth_slope_ratio``
        of ``settings``.
    settings : RobustSettings
        Source of the cone's other limits: ``cone_inner_widths`` (the window reaches that many
        ``width`` inside ``radius``), ``cone_below_sigmas``, ``cone_min_points_below``,
        ``cone_trim_sigmas``, ``cone_trim_rounds``, ``cone_edge_steps``, ``cone_min_slope``,
        ``cone_max_slope``, ``cone_depth_bins``, ``cone_min_bin_points`` and ``cone_min_span_gaps``.
    gap : float, optional
        The scan's gap scale g, for the ``"unresolved"`` check (None: not checked).

    Returns
    -------
    Cone or NotACone
    """
    if depth_slope_ratio is None:
        depth_slope_ratio = settings.cone_depth_slope_ratio
    window = (rho > radius - settings.cone_inner_widths * width) & (rho < radius + width)
    rho, depth = rho[window], depth[window]
    clearly_below = settings.cone_below_sigmas * noise
    below = np.count_nonzero((depth > clearly_below) & (rho < radius))
    if below < settings.cone_min_points_below:
        return NotACone("points_below", float(below), float(settings.cone_min_points_below))
    edge, slope, keep = _trimmed_hinge(rho, depth, radius, width, noise, settings)
    if slope > settings.cone_max_slope:
        # Steeper than any countersink: a bore wall, or a cone whose hinge a bore wall seen on one side
        # of a tilted scan bent (its points, millimetres deep at one radius, as many as the cone's on a
        # coarse scan). Started by least median over the points below the
        # surface, the hinge follows the cone where there is one; where there is none it stays a
        # wall's, or fails the checks below.
        edge, slope, keep = _trimmed_hinge(rho, depth, radius, width, noise, settings,
                                           median_start=depth > clearly_below)
        # A bore's wall alone (no cone) is a column of points at one radius, which a hinge through
        # its median depth fits too: the cone's points below the surface must spread over the radii
        # between the edge and the bore (uniform over that ring, their interquartile range is about
        # half of it), not stand at one.
        on_cone = keep & (depth > clearly_below) & (rho < edge)
        if np.count_nonzero(on_cone) < 2:
            return NotACone("wall_column", 0.0, WALL_COLUMN_SPREAD)
        low, q1, q3 = np.percentile(rho[on_cone], [0.0, 25.0, 75.0])
        spread = float(q3 - q1) / max(float(edge - low), 1e-12 * radius)
        if spread < WALL_COLUMN_SPREAD:
            return NotACone("wall_column", spread, WALL_COLUMN_SPREAD)
    low_slope, high_slope = settings.cone_min_slope, settings.cone_max_slope
    if not low_slope <= slope <= high_slope:
        return NotACone("slope", slope, low_slope if slope < low_slope else high_slope)
    if gap is not None:
        # Resolved: the points below the surface reach beyond the fringe of mixed pixels at an edge.
        inner = (depth > clearly_below) & (rho < edge)
        span = float(edge - np.percentile(rho[inner], 5.0)) if np.any(inner) else 0.0
        least = settings.cone_min_span_gaps * gap
        if span < least:
            return NotACone("unresolved", span, least)
    # The points below the surface inside the edge must deepen toward the center at about the cone's
    # slope. All of them, not only those the hinge kept: a hinge through a floor keeps the few floor
    # points where its line crosses the floor's depth, and noise gives those any slope.
    inside = (depth > clearly_below) & (rho < edge)
    measured = _depth_slope(rho[inside], depth[inside], settings.cone_depth_bins, settings.cone_min_bin_points)
    ratio = 0.0 if measured is None else measured / slope
    if ratio < depth_slope_ratio:
        return NotACone("flat_floor", ratio, depth_slope_ratio)
    return Cone(radius=edge, slope=slope, points=int(keep.sum()))


def _countersink(scene, center, radius, settings):
    """The countersink cone around a fitted rim, or the named check it failed (a
    :class:`NotACone`).

    The edge is searched within a window of the rim's radius. Where the surface band is wide (a
    scan of a curved panel, whose plane lies tens of um off the surface), the top of the cone counts
    as surface and the rim lies inside the edge by more than the window: an edge found at the
    window's outer limit (settings ``cone_window_limit``) moves the window out to it, up to
    ``cone_window_moves`` times.
    """
    width = 2.0 * scene.alpha
    cone = None
    for _ in range(settings.cone_window_moves + 1):
        xy, depth = _points_around_edge(scene, center, radius, width, settings)
        rho = np.hypot(xy[:, 0] - center[0], xy[:, 1] - center[1])
        found = fit_cone_edge(rho, depth, radius, width, scene.height_noise,
                              depth_slope_ratio=settings.cone_depth_slope_ratio, settings=settings,
                              gap=scene.sampling.gap)
        if not isinstance(found, Cone):
            return found if cone is None else cone
        cone = found
        if found.radius < radius + (1.0 - settings.cone_window_limit) * width:
            break
        radius = found.radius
    return cone


def _points_around_edge(scene, center, radius, width, settings):
    """The points within [r - 2 width, r + width] of ``center`` that may lie on a countersink's cone
    (plane frame xy, (k, 2)), and their depth below the surface around the hole (k,)."""
    index = scene.within(scene.xy, center, max(radius - settings.cone_inner_widths * width, 0.0),
                         radius + width)
    # Points above the surface band (outliers, a stray point 1e8 off along the normal) are on no
    # cone, and one of them would outweigh every other point in the hinge's least squares.
    index = index[scene.heights[index] <= scene.band]
    xy = scene.xy[index]
    return xy, surface_height(scene, center, radius, settings, xy) - scene.heights[index]


def _cone_in_the_plane(scene, center, cone, settings):
    """Center and edge radius of a countersink from its cone, ``depth = s * max(0, R - |xy - c|)``
    fitted to the points around the edge with the center ``c`` free, and the covariance of
    ``(cx, cy, R)`` (None when the rim's center and the hinge's edge stay).

    The hinge of :func:`fit_cone_edge` takes the rim's center; the rim lies inside
    the edge by what the surface band hides of the cone, and on a tilted scan the camera sees more of
    one side of the cone than of the other, so the rim's center is off by up to 0.3 spacings there.
    The cone's own points, wherever they are, say where its axis is. A fit that runs off (its center
    or edge more than the edge's search window away, or its slope below a cone's) is not trusted: the
    rim's center and the hinge's edge stay.
    """
    from scipy.optimize import least_squares

    width = 2.0 * scene.alpha
    around_xy, around_depth = _points_around_edge(scene, center, cone.radius, width, settings)
    start = np.array([center[0], center[1], cone.radius, cone.slope])
    for _ in range(2):
        # Only the points on the cone: a bore wall seen on one side of a tilted scan would pull the
        # free center and edge toward itself (soft_l1 tempers an outlier, not hundreds). They are
        # chosen about the accepted cone, then again about the fitted one: about the rim's center,
        # which is off on a tilted scan, good points of one side of the cone miss the first choice.
        cx, cy, edge, slope = start
        rho = np.hypot(around_xy[:, 0] - cx, around_xy[:, 1] - cy)
        inside = rho < edge
        among = inside if np.count_nonzero(inside) >= settings.cone_min_points_below else None
        kept = points_on_hinge(rho, around_depth, edge, slope, scene.height_noise, 1e-12 * cone.radius,
                               settings.cone_trim_sigmas, among=among)
        # The loss's scale is the cone points' own scatter about the hinge, not the surface's noise: a
        # CAD countersink's facets lie up to a sagitta off the cone, and at the noise's scale soft_l1
        # weighs them as outliers and the edge falls toward the facets' apothem (a 24-gon: -18 um).
        misfit = around_depth - slope * np.maximum(edge - rho, 0.0)
        scale = max(robust_sigma(misfit if among is None else misfit[among]), scene.height_noise,
                    1e-12 * cone.radius)
        xy, depth = around_xy[kept], around_depth[kept]
        if len(xy) < settings.cone_min_points_below:
            return center, cone.radius, None

        def residuals(parameters, xy=xy, depth=depth):
            cx, cy, edge, slope = parameters
            rho = np.hypot(xy[:, 0] - cx, xy[:, 1] - cy)
            return (depth - slope * np.maximum(edge - rho, 0.0)) / scale

        try:
            result = least_squares(residuals, start, loss="soft_l1", f_scale=3.0, x_scale=[width, width, width, 1.0])
        except (ValueError, np.linalg.LinAlgError):
            return center, cone.radius, None
        start = result.x
    cx, cy, edge, slope = result.x
    shift = float(np.hypot(cx - center[0], cy - center[1]))
    if not result.success or shift > width or abs(edge - cone.radius) > width or not settings.cone_min_slope <= slope:
        return center, cone.radius, None
    # the residuals were divided by scale: the covariance is in the parameters' units all the same
    covariance = lsq.covariance(result.jac, result.fun)  # None: singular (no covariance, not a crash)
    return np.array([cx, cy]), float(edge), None if covariance is None else covariance[:3, :3]


class ConeEstimator:
    """A countersink's cone, fitted to the points around the rim (:func:`fit_cone_edge`, then with its
    center free, :func:`_cone_in_the_plane`): the edge is where the cone meets the surface. First in
    precedence: tried on every hole, taken whenever the points look like a cone.

    Its uncertainty is the cone fit's least-squares covariance when there is one."""

    name = ESTIMATOR_CONE  # its precedence: holecli.vocabulary.ESTIMATORS
    # The method terms (a, b) for the in-plane center and the diameter: a h and b sigma_h in
    # quadrature (see holecli.robust.uncertainty for how they were measured).
    method_terms = {"center": (0.002, 0.0), "diameter": (0.01, 0.0)}
    correction_share = 0.0
    bias_corrected = True
    at_least_fit = False
    from_cone_covariance = True  # center and radius u from the cone fit's covariance, when it has one

    def center_floor(self, density, radius):
        """No floor of the center's uncertainty."""
        return 0.0

    def applies(self, scene, partial, settings):
        """Every hole (whether there is a cone is the fit's to say)."""
        return True

    def edge(self, scene, local, rim_xy, center, radius, partial, floor, settings):
        """The cone's edge in the plane, its slope and covariance; None when the points around the
        rim are no cone (:class:`NotACone`)."""
        cone = _countersink(scene, center, radius, settings)
        if not isinstance(cone, Cone):
            return None
        cone_center, cone_radius, covariance = _cone_in_the_plane(scene, center, cone, settings)
        return EdgeEstimate(estimator=self, center=cone_center, radius=cone_radius, bias=radius - cone_radius,
                            cone_slope=cone.slope, cone_covariance=covariance)


CONE = ConeEstimator()
