"""From rim points to the hole's edge circle: drop points inside the hole, then a clipped circle fit."""

from __future__ import annotations

import numpy as np

from holecli.errors import PointsError
from holecli.geometry.circle import fit_circle_robust
from holecli.robust.boundary import outer_envelope


def fit_edge(rim_xy, depth, floor, clip, start=None):
    """Fit the edge circle of a hole to its rim points.

    Rim points deeper than ``depth`` inside the hole than the outermost rim point of their direction
    are dropped (:func:`holecli.robust.boundary.outer_envelope`), twice, re-centred after each fit; the
    remaining points get a geometric fit with sigma clipping (:func:`holecli.geometry.circle.fit_circle_robust`).

    Returns
    -------
    fit : CircleFit or None
        None when too few points remain or the fit is degenerate.
    used : (m,) bool
        The rim points the final fit kept.
    """
    sectors = max(8, len(rim_xy) // 3)
    used = np.ones(len(rim_xy), dtype=bool)
    try:
        fit = fit_circle_robust(rim_xy, clip=clip, floor=floor, start=start)
        for _ in range(2):
            used = outer_envelope(rim_xy, fit.center, depth, sectors)
            if used.sum() < 5:
                return None, used
            fit = fit_circle_robust(rim_xy[used], clip=clip, floor=floor, start=(fit.center, fit.radius))
    except PointsError:
        return None, used
    final = np.zeros(len(rim_xy), dtype=bool)
    final[np.flatnonzero(used)[fit.kept]] = True
    return fit, final
