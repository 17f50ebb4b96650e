"""Sampling-bias correction of a fitted rim radius.

The rim points are material points, all outside the true edge, so a circle through them is too large
by an amount that depends on the sampling pattern (square grid, stripes, jitter, random) and on the
noise. Instead of a fixed correction, the bias is measured on the scan's own points: synthetic holes of
known radius ``r + offset`` are cut at the measured center into the material around the real hole,
their rims extracted and fitted exactly as the real one, and the mean excess of the fitted radius over
the known one is the bias. The synthetic holes share the real hole's center, so they see the same
phase of a periodic pattern (stripes), the same noise and the same extraction.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import numpy as np

from holecli.robust.boundary import hole_rim
from holecli.robust.edge import fit_edge
from holecli.settings import DEFAULT_SETTINGS


@dataclass(frozen=True)
class RimScales:
    """The lengths a rim extraction and its fit work at, file units.

    Attributes
    ----------
    alpha : float
        The empty-circle radius of the rim extraction (:func:`holecli.robust.boundary.hole_rim`).
    reach : float
        Rim points beyond ``radius + reach`` from the center are ignored (where a partial hole opens
        onto the scan's edge).
    margin : float
        Width of the ring of material triangulated beyond the hole's radius.
    clip : float
        Clipping threshold of the circle fit, robust standard deviations.
    floor : float
        Floor of the circle fit's residual scale.
    depth : float or None
        Envelope depth of :func:`holecli.robust.edge.fit_edge`; ``alpha`` when None.
    """

    alpha: float
    reach: float
    margin: float
    clip: float
    floor: float
    depth: Optional[float] = None

    @property
    def envelope(self) -> float:
        """The envelope depth in use: ``depth``, else ``alpha``."""
        return self.alpha if self.depth is None else self.depth


def synthetic_rim_fit(xy, center, radius, scales, allow_open=True, *, settings=DEFAULT_SETTINGS):
    """Fit the rim of a synthetic hole of ``radius`` cut at ``center`` into ``xy``.

    Only the ring of points between ``radius`` and ``radius + margin`` is triangulated; rim points
    farther than ``radius + reach`` from the center (where a partial hole opens onto the scan's
    edge) are ignored.

    Parameters
    ----------
    xy : (n, 2) float
        Surface points around the hole.
    center : (2,) float
    radius : float
        The synthetic hole's radius.
    scales : RimScales
    allow_open : bool
        Whether the synthetic hole may reach the scan's edge.
    settings : RobustSettings
        Source of ``cut_alphas`` (the cut zone at the ring's outer line) and ``bias_min_rim_points``.

    Returns
    -------
    float or None
        The fitted radius, None when the synthetic hole gives no usable rim.
    """
    alpha, margin = scales.alpha, scales.margin
    distance = np.hypot(*(xy - center).T)
    keep = (distance > radius) & (distance < radius + margin)
    local = xy[keep]
    def in_disk(positions):
        return np.hypot(*(positions - center).T) < radius

    rim = hole_rim(local, in_disk, alpha, cut=distance[keep] > radius + margin - settings.cut_alphas * alpha)
    if rim is None or (rim.open and not allow_open):
        return None
    rim_xy = local[rim.index]
    rim_xy = rim_xy[np.hypot(*(rim_xy - center).T) <= radius + scales.reach]
    if len(rim_xy) < settings.bias_min_rim_points:
        return None
    fit, _ = fit_edge(rim_xy, scales.envelope, scales.floor, scales.clip, start=(center, radius))
    return None if fit is None else fit.radius


def sampling_bias(xy, center, radius, offsets, scales, allow_open=True, *, settings=DEFAULT_SETTINGS):
    """Mean excess of the fitted over the true radius of synthetic holes cut into ``xy``.

    Synthetic holes must not be smaller than the real hole (else they would hold its void), so the
    offsets are positive.

    Parameters
    ----------
    xy : (n, 2) float
        Surface points around the hole, reaching at least ``radius + max(offsets) + scales.margin``.
    center : (2,) float
    radius : float
        The current estimate of the true edge radius.
    offsets : sequence of float
        The synthetic radii are ``radius + offset``, file units, each > 0. On a regular pattern they
        are multiples of its period so that each synthetic edge meets the scan lines in the same
        phase as the real one.
    scales : RimScales
        The lengths of the rim extraction and fits, as for the real hole.
    allow_open : bool
        Whether a synthetic hole may reach the scan's edge (true for a partial hole).
    settings : RobustSettings
        Source of ``cut_alphas``, ``bias_min_rim_points`` and ``bias_max_excess_alphas`` (a synthetic
        hole fitted that far off its known radius is left out).

    Returns
    -------
    float or None
        The radial bias (positive: rim fits come out too large), None when no synthetic hole could
        be measured (the material around the hole is too narrow).
    """
    excesses = []
    for offset in offsets:
        synthetic = radius + offset
        fitted = synthetic_rim_fit(xy, center, synthetic, scales, allow_open, settings=settings)
        if fitted is not None and abs(fitted - synthetic) < settings.bias_max_excess_alphas * scales.alpha:
            excesses.append(fitted - synthetic)
    if not excesses:
        return None
    return float(np.mean(excesses))
