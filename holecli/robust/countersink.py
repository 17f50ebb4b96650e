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

import numpy as np

# A countersink wall slopes between these (depth per unit radius: 0.2 is 11 degrees from the surface,
# 3.0 is 72; a 100-degree countersink slopes 0.84, a 60-degree one 1.73); a steeper "cone" is a bore
# wall. The cone must hold this many points clearly below the surface.
MIN_SLOPE = 0.2
MAX_SLOPE = 3.0
MIN_POINTS_BELOW = 12
# The points below the surface inside the edge are cut into this many radial bins (between their 1st
# and 99th radius percentiles), each kept with at least this many points.
DEPTH_BINS = 8
MIN_BIN_POINTS = 3
# Default of RobustSettings.cone_depth_slope_ratio (see there).
DEPTH_SLOPE_RATIO = 0.3


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
    ``"slope"`` (the wall's slope is outside [MIN_SLOPE, MAX_SLOPE]: a bore wall or no cone) or
    ``"flat_floor"`` (the depth does not grow toward the center as the cone's slope says: a flat
    hole floor, value and limit as fractions of the fitted slope).
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


def _best_edge(rho, depth, low, high, steps=64):
    edges = np.linspace(low, high, steps)
    errors = np.array([_hinge(rho, depth, edge)[1] for edge in edges])
    best = int(np.argmin(errors))
    # One finer pass around the best coarse edge.
    step = edges[1] - edges[0]
    fine = np.linspace(edges[best] - step, edges[best] + step, steps)
    errors = np.array([_hinge(rho, depth, edge)[1] for edge in fine])
    edge = float(fine[int(np.argmin(errors))])
    return edge, _hinge(rho, depth, edge)[0]


def _depth_slope(rho, depth):
    """Slope of depth against radius (positive: deeper toward the center), or None when unmeasurable.

    The Theil-Sen slope (median over pairs) of the median depths of DEPTH_BINS radial bins spanning
    the points. Bin medians, and the median over pairs of bins, keep the slope of a floor at zero
    whatever a bore wall adds: the wall stands at one radius, so it moves one bin or two. The bins span
    the points themselves, not the range up to the fitted edge: a cone fitted to a floor claims
    points below the surface out to its edge, where there are none.
    """
    if len(rho) < 2 * MIN_BIN_POINTS:
        return None
    low, high = (float(v) for v in np.percentile(rho, [1.0, 99.0]))
    if not high > low:
        return None
    bins = np.clip(np.floor(DEPTH_BINS * (rho - low) / (high - low)), 0, DEPTH_BINS - 1).astype(np.int64)
    medians, centers = [], []
    for b in np.unique(bins):
        members = bins == b
        if np.count_nonzero(members) >= MIN_BIN_POINTS:
            medians.append(float(np.median(depth[members])))
            centers.append(float(np.median(rho[members])))
    if len(medians) < 2:
        return None
    medians, centers = np.array(medians), np.array(centers)
    i, j = np.triu_indices(len(medians), k=1)
    return float(np.median((medians[i] - medians[j]) / (centers[j] - centers[i])))


def fit_cone_edge(rho, depth, radius, width, noise, depth_slope_ratio=DEPTH_SLOPE_RATIO):
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
    depth_slope_ratio : float
        Least slope of depth against radius of the points below the surface inside the edge, as a
        fraction of the cone's slope (the ``"flat_floor"`` check).

    Returns
    -------
    Cone or NotACone
    """
    window = (rho > radius - 2.0 * width) & (rho < radius + width)
    rho, depth = rho[window], depth[window]
    below = np.count_nonzero((depth > 3.0 * noise) & (rho < radius))
    if below < MIN_POINTS_BELOW:
        return NotACone("points_below", float(below), float(MIN_POINTS_BELOW))
    keep = np.ones(len(rho), dtype=bool)
    for _ in range(3):
        # Bore-wall and bottom points (far below the cone) are trimmed as outliers.
        edge, slope = _best_edge(rho[keep], depth[keep], radius - width, radius + width)
        residual = depth - slope * np.maximum(edge - rho, 0.0)
        scale = max(1.4826 * float(np.median(np.abs(residual[keep]))), noise, 1e-12 * radius)
        new_keep = np.abs(residual) < 3.0 * scale
        if np.array_equal(new_keep, keep):
            break
        keep = new_keep
    if not MIN_SLOPE <= slope <= MAX_SLOPE:
        return NotACone("slope", slope, MIN_SLOPE if slope < MIN_SLOPE else MAX_SLOPE)
    # The points below the surface inside the edge must deepen toward the center at about the cone's
    # slope. All of them, not only those the hinge kept: a hinge through a floor keeps the few floor
    # points where its line crosses the floor's depth, and noise gives those any slope.
    inside = (depth > 3.0 * noise) & (rho < edge)
    measured = _depth_slope(rho[inside], depth[inside])
    ratio = 0.0 if measured is None else measured / slope
    if ratio < depth_slope_ratio:
        return NotACone("flat_floor", ratio, depth_slope_ratio)
    return Cone(radius=edge, slope=slope, points=int(keep.sum()))
