"""The rim fit: a circle fitted to the rim points, less its sampling bias.

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
from holecli.robust.estimators import harness
from holecli.robust.estimators.harness import EdgeEstimate, SyntheticErrors, synthetic_errors
from holecli.settings import DEFAULT_SETTINGS
from holecli.vocabulary import ESTIMATOR_RIM_FIT


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
    trim : float
        How much nearer the ring's outer line is drawn first (:func:`synthetic_rim`): ``margin - trim``,
        the cut zone's inner line staying where it is; 0: the full ring only.
    """

    alpha: float
    reach: float
    margin: float
    clip: float
    floor: float
    depth: Optional[float] = None
    trim: float = 0.0

    @property
    def envelope(self) -> float:
        """The envelope depth in use: ``depth``, else ``alpha``."""
        return self.alpha if self.depth is None else self.depth


def synthetic_rim_fit(xy, center, radius, scales, allow_open=True, *, settings=DEFAULT_SETTINGS):
    """The fitted radius of the rim of a synthetic hole of ``radius`` cut at ``center`` into ``xy``
    (:func:`synthetic_rim`'s fit), None when the synthetic hole gives no usable rim."""
    rim = synthetic_rim(xy, center, radius, scales, allow_open, settings=settings)
    return None if rim is None else float(rim.fit.radius)


@dataclass(frozen=True, eq=False)
class SyntheticRim:
    """A synthetic hole's ring of points (``local``), its rim points the fit kept (``rim_xy``) and
    the fit (a :class:`holecli.geometry.circle.CircleFit`)."""

    local: np.ndarray
    rim_xy: np.ndarray
    fit: object


def _ring_rim(xy, distance, center, radius, outer, cut_from, alpha, inside, trim):
    """The rim (:func:`holecli.robust.boundary.hole_rim`) of a synthetic hole of ``radius`` cut at
    ``center`` into the points ``xy`` at ``distance`` from it that lie closer than ``outer``; those
    farther than ``cut_from`` are the cut zone. With ``trim`` > 0 the points closer than
    ``outer - trim`` are triangulated first, and kept where
    :func:`holecli.robust.boundary.hole_rim_within` proves their rim is the whole ring's.
    ``(local points, Rim or None)``."""
    keep = (distance > radius) & (distance < outer)
    local = xy[keep]
    cut = distance[keep] > cut_from
    near = distance[keep] < outer - trim
    if inside is not None and len(inside):
        local = np.vstack([local, inside])
        cut = np.concatenate([cut, np.zeros(len(inside), dtype=bool)])
        near = np.concatenate([near, np.ones(len(inside), dtype=bool)])

    def in_disk(positions):
        return np.hypot(*(positions - center).T) < radius

    def in_narrow_ring(disk_centers, radii):
        return np.hypot(*(disk_centers - center).T) + radii < outer - trim

    window = (near, in_narrow_ring) if trim > 0.0 else None
    return local, hole_rim(local, in_disk, alpha, cut=cut, window=window)


def synthetic_rim(xy, center, radius, scales, allow_open=True, *, settings=DEFAULT_SETTINGS, inside=None):
    """Fit the rim of a synthetic hole of ``radius`` cut at ``center`` into ``xy``.

    Only the ring of points between ``radius`` and ``radius + margin`` is triangulated; rim points
    farther than ``radius + reach`` from the center (where a partial hole opens onto the scan's
    edge) are ignored.

    With ``scales.trim`` (``settings.synthetic_cut_alphas``), the points of the ring reaching only
    ``radius + margin - trim`` are triangulated first, its cut zone starting where the full ring's
    does, and their rim is kept only where :func:`holecli.robust.boundary.hole_rim_within` proves it
    is the full ring's (every point on their outer boundary is cut, every triangle of the hole region
    has its empty circle inside the nearer line); otherwise (a border or another void crossing the
    ring) the full ring is triangulated. A partial hole's synthetic holes (``allow_open``) open onto
    the scan's edge: their full ring is triangulated at once. The local points returned are the full
    ring's either way.

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
    inside : (m, 2) float, optional
        Points added inside the synthetic hole (the reflections the real hole has near its edge,
        :func:`holecli.robust.uncertainty.synthetic_reflections`).

    Returns
    -------
    SyntheticRim or None
        None when the synthetic hole gives no usable rim.
    """
    alpha, margin = scales.alpha, scales.margin
    distance = np.hypot(*(xy - center).T)
    cut_from = radius + margin - settings.cut_alphas * alpha
    trim = 0.0 if allow_open else scales.trim  # a partial hole's rings open onto the scan's edge: whole at once
    local, rim = _ring_rim(xy, distance, center, radius, radius + margin, cut_from, alpha, inside, trim)
    if rim is None or (rim.open and not allow_open):
        return None
    rim_xy = local[rim.index]
    rim_xy = rim_xy[np.hypot(*(rim_xy - center).T) <= radius + scales.reach]
    if len(rim_xy) < settings.bias_min_rim_points:
        return None
    fit, used = fit_edge(rim_xy, scales.envelope, scales.floor, scales.clip, start=(center, radius))
    return None if fit is None else SyntheticRim(local=local, rim_xy=rim_xy[used], fit=fit)


def sampling_bias(xy, center, radius, offsets, scales, allow_open=True, *, settings=DEFAULT_SETTINGS):
    """Mean excess of the fitted over the true radius of synthetic holes cut into ``xy``
    (:func:`sampling_errors`' bias), None when no synthetic hole could be measured."""
    errors = sampling_errors(xy, center, radius, offsets, scales, allow_open, settings=settings)
    return None if errors is None else errors.bias


def sampling_errors(xy, center, radius, offsets, scales, allow_open=True, *, settings=DEFAULT_SETTINGS,
                    reflections=None):
    """The errors of rim fits of synthetic holes cut into ``xy``.

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
    reflections : sequence of (m, 2) float or None, optional
        Per offset, the points added inside that synthetic hole (None: none).

    Returns
    -------
    SyntheticErrors or None
        The radial errors (their mean is the bias; positive: rim fits come out too large) and the
        center errors of the synthetic holes measured, None when none could be measured (the
        material around the hole is too narrow).
    """
    def measure(synthetic, inside):
        rim = synthetic_rim(xy, center, synthetic, scales, allow_open, settings=settings, inside=inside)
        if rim is None or not abs(rim.fit.radius - synthetic) < settings.bias_max_excess_alphas * scales.alpha:
            return None
        return rim.fit.center, rim.fit.radius

    return synthetic_errors(measure, center, [radius + offset for offset in offsets], reflections)


def synthetic_ring(scene, center, radius, offsets, settings, floor):
    """The scales of a synthetic rim and the material points around a hole that synthetic holes of
    ``radius + offsets`` are cut into. The scales' ``trim`` is ``cut_alphas - synthetic_cut_alphas``
    alphas: each synthetic rim is first extracted from the ring that much narrower
    (:func:`synthetic_rim`)."""
    period = scene.sampling.period or 0.5 * scene.alpha
    reach = scene.alpha + 2.0 * scene.cell
    margin = settings.margin_alphas * scene.alpha + scene.cell
    trim = max(settings.cut_alphas - settings.synthetic_cut_alphas, 0.0) * scene.alpha
    ring = scene.material_xy[scene.within(scene.material_xy, center, radius - period,
                                          radius + offsets[-1] + margin + period)]
    scales = RimScales(alpha=scene.alpha, reach=reach, margin=margin, clip=settings.clip_sigmas, floor=floor,
                       depth=scene.envelope, trim=trim)
    return scales, ring


def _sampling_bias(scene, center, radius, settings, floor, partial):
    """Radial sampling bias of a rim fit of ``radius`` at ``center`` and the :class:`SyntheticErrors`
    of its last pass (None when none measured).

    The last pass measures at least ``uncertainty_min_synthetic`` synthetic holes, so that the
    spread of their errors gives the hole's uncertainty (:mod:`holecli.robust.uncertainty`)."""
    period = scene.sampling.period or 0.5 * scene.alpha
    # Enough synthetic holes for about bias_rim_points rim points in all: a large hole's rim alone
    # pins the bias down, a small one needs several.
    rim_points = max(2.0 * np.pi * radius / scene.sampling.spacing, 1.0)
    count = int(np.clip(np.ceil(settings.bias_rim_points / rim_points), 1, len(settings.bias_offsets)))
    final = max(count, min(settings.uncertainty_min_synthetic, len(settings.bias_offsets)))
    offsets = [k * period for k in settings.bias_offsets[:final]]
    scales, ring = synthetic_ring(scene, center, radius, offsets, settings, floor)
    bias, errors = 0.0, None
    allow_open = partial
    for passes in range(settings.bias_passes):
        # Cut the synthetic holes in phase with the current estimate of the true edge.
        last = passes == settings.bias_passes - 1
        used = offsets if last else offsets[:count]
        estimate = sampling_errors(ring, center, radius - bias, used, scales, allow_open=allow_open, settings=settings,
                                   reflections=harness.reflections(scene, center, radius - bias, used))
        if estimate is None and errors is None and not allow_open:
            # A full hole near the scan's border: the synthetic holes cut around it (larger than
            # it) reach the outside and their rims open. Measured as for a partial hole rather than
            # not at all (issue 24: a d3.96 hole 0.23 mm from the border kept +53 um uncorrected).
            allow_open = True
            estimate = sampling_errors(ring, center, radius - bias, used, scales, allow_open=True, settings=settings,
                                       reflections=harness.reflections(scene, center, radius - bias, used))
        if estimate is None:
            break
        bias, errors = estimate.bias, estimate
    return bias, errors


class RimFit:
    """The rim's circle fit, less its sampling bias measured on synthetic holes: the estimator of
    last resort, which applies to every hole.

    Its uncertainty is at least the rim's least-squares circle fit's (a burr or debris on the real
    rim that the synthetic holes do not have widens it)."""

    name = ESTIMATOR_RIM_FIT  # its precedence: holecli.vocabulary.ESTIMATORS
    # The method terms (a, b) for the in-plane center and the diameter: a h and b sigma_h in
    # quadrature (see holecli.robust.uncertainty for how they were measured).
    method_terms = {"center": (0.0, 0.3), "diameter": (0.0, 0.7)}
    correction_share = 0.0      # no Type B term on its correction
    bias_corrected = True       # the synthetic holes' mean error is removed: their spread is the u
    at_least_fit = True         # u at least the rim's least-squares circle fit's
    from_cone_covariance = False

    def center_floor(self, density, radius):
        """No floor of the center's uncertainty."""
        return 0.0

    def applies(self, scene, partial, settings):
        """Every hole."""
        return True

    def edge(self, scene, local, rim_xy, center, radius, partial, floor, settings):
        """The rim fit's edge, corrected by its sampling bias (:func:`_sampling_bias`); never None."""
        bias, synthetic = _sampling_bias(scene, center, radius, settings, floor, partial)
        return EdgeEstimate(estimator=self, center=center, radius=radius - bias, bias=bias, synthetic=synthetic)


RIM_FIT = RimFit()
