"""The edge estimators: how a hole's edge circle is measured once its rim is fitted, and the choice.

Four estimators, in precedence order (:data:`ESTIMATORS`), the first that applies and finds an edge
measures the hole:

* ``cone`` (:mod:`.cone`): a countersink's cone, fitted to the points around the rim; its edge is
  where the cone meets the surface;
* ``lattice`` (:mod:`.lattice`): on regular sampling, the circle separating present from missing
  lattice positions;
* ``empty_circle`` (:mod:`.empty_circle`): on quiet irregular sampling, the largest circle empty of
  surface points, less its overshoot;
* ``rim_fit`` (:mod:`.rim_fit`): the rim's circle fit less its sampling bias; it always applies.

Each is measured on synthetic holes cut into the scan's own points by the one harness of
:mod:`.harness` (:func:`synthetic_errors`); their errors give its bias and its uncertainty
(:func:`holecli.robust.uncertainty.edge_uncertainty`, which reads the estimator's
:attr:`EdgeEstimator.method_terms` and the other attributes below).
"""

from __future__ import annotations

from typing import Protocol

from holecli import vocabulary
from holecli.robust.estimators.cone import CONE
from holecli.robust.estimators.empty_circle import EMPTY_CIRCLE
from holecli.robust.estimators.harness import EdgeEstimate, SyntheticErrors, synthetic_errors
from holecli.robust.estimators.lattice import LATTICE
from holecli.robust.estimators.rim_fit import RIM_FIT

__all__ = ["CONE", "EMPTY_CIRCLE", "ESTIMATORS", "ESTIMATOR_NAMED", "EdgeEstimate", "EdgeEstimator", "LATTICE",
           "METHOD_TERMS", "RIM_FIT", "SyntheticErrors", "estimate_edge", "synthetic_errors"]


class EdgeEstimator(Protocol):
    """An edge estimator: what :func:`estimate_edge` and
    :func:`holecli.robust.uncertainty.edge_uncertainty` ask of it.

    Attributes
    ----------
    name : str
        Its name in the record (``uncertainty.estimator``).
    method_terms : dict
        ``{"center": (a, b), "diameter": (a, b)}``: the method terms ``a h`` and ``b sigma_h`` added
        in quadrature to its uncertainties (see :mod:`holecli.robust.uncertainty`).
    correction_share : float
        The Type B share of its bias correction added to the diameter's uncertainty (0: none).
    bias_corrected : bool
        Whether its synthetic holes' mean error is removed (then their spread is the uncertainty;
        else their root mean square).
    at_least_fit : bool
        Whether its uncertainty is at least the rim's least-squares circle fit's.
    from_cone_covariance : bool
        Whether a cone fit's covariance, when there is one, gives its center's and radius's
        uncertainty.
    """

    name: str
    method_terms: dict
    correction_share: float
    bias_corrected: bool
    at_least_fit: bool
    from_cone_covariance: bool

    def center_floor(self, density, radius) -> float:
        """The least uncertainty of the center, given the surface's points per unit area and the
        edge's radius."""

    def applies(self, scene, partial, settings) -> bool:
        """Whether it is tried on a hole (``partial``: the hole is cut by the scan's border or missing
        data) of ``scene``."""

    def edge(self, scene, local, rim_xy, center, radius, partial, floor, settings):
        """The hole's :class:`EdgeEstimate`, or None when it finds no edge (the next estimator is
        tried)."""


#: The estimators in precedence order (that of their names in :data:`holecli.vocabulary.ESTIMATORS`): the
#: first that applies and finds an edge measures a hole.
ESTIMATORS = tuple({estimator.name: estimator for estimator in (CONE, LATTICE, EMPTY_CIRCLE, RIM_FIT)}[name]
                   for name in vocabulary.ESTIMATORS)

#: The estimators by their record name.
ESTIMATOR_NAMED = {estimator.name: estimator for estimator in ESTIMATORS}

#: Each estimator's method terms, by name (a view of their :attr:`EdgeEstimator.method_terms`).
METHOD_TERMS = {estimator.name: estimator.method_terms for estimator in ESTIMATORS}


def estimate_edge(scene, local, rim_xy, center, radius, partial, floor, settings):
    """The edge of a hole whose rim is fitted: that of the first of :data:`ESTIMATORS` that applies
    and finds one.

    Parameters
    ----------
    scene : holecli.robust.scene.Scene
        What the measurement knows of the whole scan.
    local : (n, 2) float
        The material points around the hole (plane frame).
    rim_xy : (m, 2) float
        The rim points the circle fit kept.
    center : (2,) float
    radius : float
        The rim's fitted circle.
    partial : bool
        Whether the hole is partial.
    floor : float
        Floor of the circle fit's residual scale.
    settings : holecli.settings.RobustSettings

    Returns
    -------
    EdgeEstimate
        Never None: the rim fit always gives one.
    """
    for estimator in ESTIMATORS:
        if estimator.applies(scene, partial, settings):
            found = estimator.edge(scene, local, rim_xy, center, radius, partial, floor, settings)
            if found is not None:
                return found
    raise AssertionError("the rim fit gives every hole an edge")  # pragma: no cover
