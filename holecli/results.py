"""Frozen result types that flow out of the detection pipeline.

They hold plain Python floats and tuples only, so that :meth:`Detection.to_dict` is JSON-ready and
a result can be compared, hashed and passed between processes.

Sign convention of normals
--------------------------
A plane's normal from an SVD has no sign of its own. holecli orients every normal so that its
z component is positive; when z is zero (a wall parallel to the
z axis) the y component is positive, and when y is zero too, the x component. For a scan taken from
above (sensor on +z, the usual robot base frame) the normal therefore points out of the material,
toward the sensor.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Optional

Vector = tuple[float, float, float]


@dataclass(frozen=True)
class Plane:
    """The fitted surface plane.

    Attributes
    ----------
    point : (3,) tuple of float
        A point on the plane (the centroid of the points it was fitted to), in file units.
    normal : (3,) tuple of float
        Unit normal, oriented by the module's sign convention.
    rms : float
        Root mean square distance of the fitted points from the plane, in file units.
    inliers : int
        Number of points the plane was fitted to (all points for the paper method).
    """

    point: Vector
    normal: Vector
    rms: float
    inliers: int


@dataclass(frozen=True)
class Hole:
    """One measured hole.

    Attributes
    ----------
    index : int
        Position of the hole in the result, from 0; holes are ordered by their center (see the README).
    center : (3,) tuple of float
        Center of the rim circle in 3D, on the surface, in file units.
    diameter : float
        Diameter of the rim circle (after the sampling-bias correction), in file units.
    normal : (3,) tuple of float
        Unit surface normal at the hole (sign convention: see the module docstring).
    rim_points : int
        Number of rim points the circle was fitted to (after outlier rejection).
    fit_rms : float
        Root mean square radial residual of the rim points, in file units.
    max_residual : float
        Largest absolute radial residual of the rim points, in file units.
    roundness : float
        Maximum minus minimum radial distance of the rim points from the center, in file units.
    bias_correction : float
        What was subtracted from the raw fitted diameter to remove the sampling bias (file units).
    partial : bool
        True when the hole is cut by the border of the scan.
    arc_deg : float
        Angular coverage of the rim points around the center, in degrees (360 for a full rim).
    scan_lines : int or None
        Number of scan lines (stripes) crossing the hole, when the scan has a stripe structure.
    """

    index: int
    center: Vector
    diameter: float
    normal: Vector
    rim_points: int
    fit_rms: float
    max_residual: float = 0.0
    roundness: float = 0.0
    bias_correction: float = 0.0
    partial: bool = False
    arc_deg: float = 360.0
    scan_lines: Optional[int] = None

    @property
    def radius(self) -> float:
        """Half the diameter, file units.

        Returns
        -------
        float
        """
        return self.diameter / 2.0

    def to_dict(self) -> dict:
        """The hole as one entry of a record's ``holes``.

        Returns
        -------
        dict
            Every field by name; ``center`` and ``normal`` as lists.
        """
        out = asdict(self)
        out["center"] = list(self.center)
        out["normal"] = list(self.normal)
        return out


@dataclass(frozen=True)
class Rejection:
    """A candidate void that is not reported as a hole, and why (``holecli detect --explain``).

    Attributes
    ----------
    check : str
        The check that refused it: ``no_rim``, ``too_few_rim_points``, ``no_circle_fit``,
        ``below_min_diameter``, ``material_inside``, ``not_round``, ``partial_rim_arc``, ``boss``,
        ``duplicate``, ``partial_left_out`` or ``beyond_max_holes`` (see the README).
    reason : str
        That check in a sentence.
    center : (3,) tuple of float
        Where the candidate is: the center of its fitted circle when it got one, else of its void,
        on the surface plane (file units).
    diameter : float
        Its size: the fitted circle's diameter, else the void's extent (file units).
    value, limit : float or int or None
        The value the check measured and the limit it failed (None for a check without a number).
    shape : dict or None
        For a cut-out that is not round (``not_round``: a slot, an oblong): ``length`` and ``width``
        of its rim along its principal axes (file units, to the sampling) and ``direction``, the unit
        vector of its length; None otherwise.
    """

    check: str
    reason: str
    center: Vector
    diameter: float
    value: Optional[float] = None
    limit: Optional[float] = None
    shape: Optional[dict] = None

    def to_dict(self) -> dict:
        """The rejection as one entry of a record's ``rejected`` (``--explain``).

        Returns
        -------
        dict
            Every field by name; ``center`` as a list.
        """
        out = asdict(self)
        out["center"] = list(self.center)
        return out


@dataclass(frozen=True)
class Detection:
    """Everything one run of the pipeline found in one cloud.

    Attributes
    ----------
    holes : tuple of Hole
        The holes found, in a stable order; empty when none was found.
    plane : Plane
        The fitted surface plane.
    points : int
        Number of points the pipeline used (finite points of the file).
    method : str
        ``"paper"`` or ``"robust"``.
    file : str or None
        The file the points came from, when they came from a file.
    dropped_points : int
        Rows of the file dropped because a coordinate was NaN or infinite.
    elapsed_ms : float
        Wall time of the detection, in milliseconds.
    rejected : tuple of Rejection
        The candidate voids that are not holes, largest first (``robust`` only; empty for
        ``paper``, which has one candidate).
    """

    holes: tuple[Hole, ...]
    plane: Plane
    points: int
    method: str
    file: Optional[str] = None
    dropped_points: int = 0
    elapsed_ms: float = 0.0
    rejected: tuple[Rejection, ...] = ()

    def to_dict(self, explain=False) -> dict:
        """The JSON record of the command line (see the README for the contract).

        Parameters
        ----------
        explain : bool
            Also give ``rejected``, the list of :class:`Rejection` (as dicts).

        Returns
        -------
        dict
            ``file``, ``points``, ``dropped_points``, ``method``, ``plane`` (``point``, ``normal``,
            ``rms``, ``inliers``), ``holes`` (:meth:`Hole.to_dict`) and ``elapsed_ms``, in that order,
            then ``rejected`` with ``explain``.
        """
        record = {
            "file": self.file,
            "points": self.points,
            "dropped_points": self.dropped_points,
            "method": self.method,
            "plane": {
                "point": list(self.plane.point),
                "normal": list(self.plane.normal),
                "rms": self.plane.rms,
                "inliers": self.plane.inliers,
            },
            "holes": [hole.to_dict() for hole in self.holes],
            "elapsed_ms": self.elapsed_ms,
        }
        if explain:
            record["rejected"] = [rejection.to_dict() for rejection in self.rejected]
        return record
