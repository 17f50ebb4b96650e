"""The synthetic-error harness every edge estimator shares, and what an estimator returns.

An edge estimate's bias and uncertainty are measured on the scan's own points: synthetic holes of
known center and radius are cut into the material around the real hole and measured by the same
estimator; what it gets wrong on them (:class:`SyntheticErrors`) is a sample of the errors it makes on
the real hole. :func:`synthetic_errors` is that loop, once for every estimator; each estimator gives
it only how it measures one synthetic hole.

Kept apart from the package's ``__init__`` (which lists the estimators) so that the estimator modules
can use it without importing the package that imports them.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import numpy as np

from holecli.robust.uncertainty import synthetic_reflections


@dataclass(frozen=True, eq=False)
class SyntheticErrors:
    """What the fits of synthetic holes of known center and radius got wrong: the sample of errors
    that the sampling-bias correction averages and the uncertainty of a hole is estimated from
    (:mod:`holecli.robust.uncertainty`).

    Attributes
    ----------
    radial : (k,) float
        Fitted minus known radius of each synthetic hole measured.
    center : (k, 2) float
        Fitted minus known center of each.
    """

    radial: np.ndarray
    center: np.ndarray

    @property
    def bias(self) -> float:
        """The mean radial error: the sampling bias."""
        return float(np.mean(self.radial))


def synthetic_errors(measure, center, radii, reflections=None):
    """The errors of an edge estimator on synthetic holes of known ``center`` and ``radii``.

    Parameters
    ----------
    measure : callable
        ``measure(radius, inside) -> (center, radius) or None``: the estimator's edge of the synthetic
        hole of ``radius`` cut at ``center``, with the points ``inside`` (None: none) added inside it;
        None when that hole gives no edge (it is left out).
    center : (2,) float
        The synthetic holes' common center.
    radii : sequence of float
        Their known radii.
    reflections : sequence of (m, 2) float or None, optional
        Per synthetic hole, the points added inside it (None: none).

    Returns
    -------
    SyntheticErrors or None
        None when no synthetic hole could be measured.
    """
    radial, shifts = [], []
    for i, synthetic in enumerate(radii):
        inside = None if reflections is None else reflections[i]
        found = measure(synthetic, inside)
        if found is not None:
            radial.append(found[1] - synthetic)
            shifts.append(np.asarray(found[0]) - center)
    if not radial:
        return None
    return SyntheticErrors(radial=np.array(radial), center=np.array(shifts).reshape(-1, 2))


@dataclass(frozen=True, eq=False)
class EdgeEstimate:
    """A hole's edge as one estimator measured it.

    Attributes
    ----------
    estimator : object
        The :class:`holecli.robust.estimators.EdgeEstimator` that measured it.
    center : (2,) float
        The edge's center, plane frame.
    radius : float
        The edge's radius.
    bias : float
        The rim fit's radius minus the edge's (the radial correction applied).
    synthetic : SyntheticErrors or None
        The estimator's errors on synthetic holes (None: none measured).
    radius_range : (low, high) or None
        The radii every lattice bracket allows (the lattice only).
    cone_slope : float or None
        Depth per radius of the countersink's cone (the cone only).
    cone_covariance : (3, 3) float or None
        Covariance of the cone edge's ``(cx, cy, R)`` (the cone only; None: not measured).
    """

    estimator: object
    center: np.ndarray
    radius: float
    bias: float
    synthetic: Optional[SyntheticErrors] = None
    radius_range: object = None
    cone_slope: Optional[float] = None
    cone_covariance: object = None


def reflections(scene, center, radius, offsets):
    """:func:`holecli.robust.uncertainty.synthetic_reflections` for synthetic holes of ``radius +
    offsets`` at ``center``: the surface points deeper than two gaps inside ``radius`` give the
    density, and a reflection within 1.5 cells of the edge joins the material (a speck farther in
    is removed by the occupancy grid, :func:`holecli.robust.candidates.occupancy_grid`)."""
    inner = radius - 2.0 * scene.sampling.gap
    count = len(scene.within(scene.surface_xy, center, 0.0, inner)) if inner > 0 else 0
    return synthetic_reflections(count, inner, center, [radius + offset for offset in offsets], 1.5 * scene.cell)

