"""One candidate void on its way to a hole: what the stages learn of it (:class:`Candidate`), and the two
ways it ends, a :class:`Measured` hole (plane frame) or a :class:`Refusal` (the named check that refused
it, :mod:`holecli.robust.acceptance`)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Optional

import numpy as np

from holecli.geometry.circle import CircleFit
from holecli.geometry.plane import PlaneFit
from holecli.robust.candidates import Grid, Void
from holecli.vocabulary import ESTIMATOR_RIM_FIT

if TYPE_CHECKING:  # (the estimators' types: only named here)
    from holecli.robust.estimators.harness import SyntheticErrors

__all__ = ["Candidate", "FirstCircle", "Measured", "Refusal"]


@dataclass(frozen=True)
class Refusal:
    """A candidate void that is not reported as a hole: the check that refused it (a key of
    :data:`holecli.vocabulary.REJECTION_REASONS`), with its value and limit (None where the check has
    no number), and where the void is (plane frame).

    Attributes
    ----------
    check : str
    value : int, float or None
    limit : int, float or None
    center : (2,) float
    radius : float
    shape : (float, float, (2,) float) or None
        ``(length, width, direction)`` of a cut-out that is not round.
    """

    check: str
    value: object
    limit: object
    center: np.ndarray
    radius: float
    shape: Optional[tuple] = None


@dataclass(frozen=True, eq=False)
class FirstCircle:
    """The circle first fitted to a rim whose points deep inside it were dropped before a refit: the
    material among the dropped points (``inside``, in the interior of the grid's material) and how much
    of it a hole's reflections may give (``allowed``)."""

    inside: int
    allowed: float
    center: np.ndarray
    radius: float
    rim_xy: np.ndarray


@dataclass(frozen=True, eq=False)
class Candidate:
    """One void and what each stage has learned of it (plane frame); ``None``: not learned yet.

    Attributes
    ----------
    void : holecli.robust.candidates.Void
    void_xy : (k, 2) float
        The centers of its cells.
    void_center : (2,) float
    void_radius : float
        Of the void's cells: where a refusal before any circle is placed.
    fewest : int
        Fewest rim points for a circle fit: more for a void open to the scan's outside (a bay).
    local : (m, 2) float
        The material points around the void (the deep ones dropped after a first fit).
    cut : (m,) bool
        Which of ``local`` lie near the line they were cut along.
    rim_xy : (r, 2) float
        The rim points (None: no rim).
    fit : holecli.geometry.circle.CircleFit
        The latest circle fitted to the rim (None: no fit).
    used : (r,) bool
        Which rim points the fit kept.
    first : FirstCircle
        The first circle when its deep points were dropped.
    partial : bool
        The circle is not surrounded by scanned material.
    arc_deg : float
        Degrees of the circle with scanned material just outside it (360 for a full hole).
    """

    void: Void
    void_xy: np.ndarray
    void_center: np.ndarray
    void_radius: float
    fewest: int
    local: Optional[np.ndarray] = None
    cut: Optional[np.ndarray] = None
    rim_xy: Optional[np.ndarray] = None
    fit: Optional[CircleFit] = None
    used: Optional[np.ndarray] = None
    first: Optional[FirstCircle] = None
    partial: Optional[bool] = None
    arc_deg: Optional[float] = None

    @classmethod
    def of(cls, void, grid: Grid, settings):
        """The candidate of ``void``, a void of ``grid``, before any stage."""
        void_xy = grid.center_of(void.cells)
        void_center = void_xy.mean(axis=0)
        void_radius = float(np.max(np.hypot(*(void_xy - void_center).T))) + 0.5 * grid.cell
        # A void open to the scan's outside (a bay) needs the stronger evidence of a partial hole even
        # when its rim closes: dents of a ragged border are bays too.
        fewest = settings.min_partial_rim_points if not void.enclosed else settings.min_rim_points
        return cls(void=void, void_xy=void_xy, void_center=void_center, void_radius=void_radius, fewest=fewest)

    @property
    def place(self):
        """``(center, radius)`` of the latest circle fitted, else of the void."""
        if self.fit is None:
            return self.void_center, self.void_radius
        return self.fit.center, float(self.fit.radius)


@dataclass(frozen=True, eq=False)
class Measured:
    """A hole measured in the plane frame of its scene, before it is taken to the world
    (:func:`holecli.robust.assemble.to_hole`)."""

    center: np.ndarray       # (2,) plane frame
    radius: float            # corrected
    bias: float              # radial
    fit: CircleFit
    rim_xy: np.ndarray
    partial: bool
    arc_deg: float
    surface_plane: Optional[PlaneFit] = None  # of the surface around the hole (None: the global plane)
    cone_slope: Optional[float] = None     # depth per radius of the countersink cone accepted at the edge
    estimator: str = ESTIMATOR_RIM_FIT    # how the edge was measured (holecli.vocabulary.ESTIMATORS)
    synthetic: Optional[SyntheticErrors] = None  # that estimator's errors on synthetic holes (None: none measured)
    cone_covariance: Optional[np.ndarray] = None  # (3, 3) covariance of the cone edge's (cx, cy, R) (estimator cone)
    fringe: tuple = (0.0, 0.0, 0.0)  # the edge's fringe of mixed points: (width, shift, hidden) (_edge_fringe)
    radius_range: Optional[tuple] = None   # (low, high): the radii every lattice bracket allows (estimator lattice)
    surface_uncertainty: tuple = (None, None)  # of the local plane's height at the hole and of its normal (rad)
    around: object = None  # the scene around the hole (holecli.robust.scene.Neighbourhood; None: the scene)
