"""The edge of a countersunk hole: where the countersink cone meets the surface.

Near the edge the cone is only slightly below the surface, so with noise its outer part falls inside
the surface band and the rim of the surface points lies inside the true edge (by about 0.8 spacing
at 10 % noise). The cone itself is measured instead: around the rim, the depth of every point below
the surface is fitted by the hinge ``depth = s * max(0, R - rho)`` of the radial distance ``rho``
from the center, and ``R`` is the edge.
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


@dataclass(frozen=True)
class Cone:
    """A countersink cone: its edge radius on the surface and its wall slope (depth per radius)."""

    radius: float
    slope: float
    points: int


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


def fit_cone_edge(rho, depth, radius, width, noise):
    """Countersink edge from points around a hole, or None when there is no cone.

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

    Returns
    -------
    Cone or None
    """
    window = (rho > radius - 2.0 * width) & (rho < radius + width)
    rho, depth = rho[window], depth[window]
    below = np.count_nonzero((depth > 3.0 * noise) & (rho < radius))
    if below < MIN_POINTS_BELOW:
        return None
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
        return None
    return Cone(radius=edge, slope=slope, points=int(keep.sum()))
