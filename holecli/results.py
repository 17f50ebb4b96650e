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

from holecli.vocabulary import ESTIMATOR_RIM_FIT

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
    facing : holecli.robust.facing.Facing or None
        Which side of the plane the sensor saw and how that was decided (``robust`` only).
    """

    point: Vector
    normal: Vector
    rms: float
    inliers: int
    facing: Optional[object] = None


@dataclass(frozen=True)
class Countersink:
    """The countersink cone of a countersunk hole (file units; see ``countersink`` in docs/reference/output.md).

    Attributes
    ----------
    diameter : float or None
        Diameter of the cone where its axis meets the surface (in the plane perpendicular to the axis).
    angle_deg : float or None
        Included angle of the cone, degrees.
    depth : float or None
        Along the axis, from the surface to the cone's lower edge (where it meets the bore).
    depth_from : str or None
        ``"bore"`` (the lower edge where the cone meets the fitted bore cylinder) or ``"cone_inner_edge"``
        (the innermost cone points, when the bore wall is not seen).
    diameter_at_depth : float or None
        The cone's diameter at ``gauge_depth`` below the surface (what a countersink gauge reads).
    gauge_depth : float or None
        The depth asked for (``--gauge-depth``), None when none was.
    rms : float or None
        Root mean square orthogonal distance of the cone points from the fitted cone.
    points : int
        Points the cone was fitted to.
    arc_deg : float
        Coverage of those points around the axis, degrees.
    """

    diameter: Optional[float]
    angle_deg: Optional[float]
    depth: Optional[float]
    depth_from: Optional[str]
    diameter_at_depth: Optional[float]
    gauge_depth: Optional[float]
    rms: Optional[float]
    points: int
    arc_deg: float


@dataclass(frozen=True)
class Counterbore:
    """The step of a counterbored hole: its diameter (the edge at the surface) and its depth (along
    the axis, from the surface to the step's flat floor), with the floor fit's rms and points."""

    diameter: float
    depth: float
    rms: float
    points: int


@dataclass(frozen=True)
class Bore:
    """The drilled bore below the edge (or below the countersink or counterbore).

    Attributes
    ----------
    diameter : float or None
        Diameter of the cylinder fitted to the bore-wall points; None when too little wall is seen.
    rms : float or None
        Root mean square orthogonal distance of the wall points from the cylinder.
    points : int
        Wall points the cylinder was fitted to (0 when none).
    depth_range : (2,) tuple of float or None
        Shallowest and deepest of those points, along the axis below the surface.
    arc_deg : float or None
        Coverage of the wall points around the axis, degrees.
    floor_depth : float or None
        A blind hole's floor, along the axis below the surface; None for a hole without a floor.
    floor_rms : float or None
        Root mean square distance of the floor's points from its fitted plane.
    """

    diameter: Optional[float]
    rms: Optional[float]
    points: int
    depth_range: Optional[tuple[float, float]]
    arc_deg: Optional[float]
    floor_depth: Optional[float] = None
    floor_rms: Optional[float] = None


@dataclass(frozen=True)
class CountersinkUncertainty:
    """Standard uncertainties of a :class:`Countersink`'s values (file units; degrees for the angle);
    None where the value is None."""

    diameter: Optional[float] = None
    angle_deg: Optional[float] = None
    depth: Optional[float] = None
    diameter_at_depth: Optional[float] = None


@dataclass(frozen=True)
class CounterboreUncertainty:
    """Standard uncertainties of a :class:`Counterbore`'s diameter and depth (file units)."""

    diameter: Optional[float] = None
    depth: Optional[float] = None


@dataclass(frozen=True)
class BoreUncertainty:
    """Standard uncertainties of a :class:`Bore`'s diameter and floor depth (file units); None where
    the value is None."""

    diameter: Optional[float] = None
    floor_depth: Optional[float] = None


@dataclass(frozen=True)
class Uncertainty:
    """Standard uncertainties (coverage factor 1) of a hole's values, file units (degrees for angles).

    How each is computed is in :mod:`holecli.robust.uncertainty` and docs/method/uncertainty.md; the
    interval ``value +- 2u`` holds the true value in about 95 % of cases (validated by
    ``benchmarks/uncertainty.py``).

    Attributes
    ----------
    center_in_plane : float
        Of each coordinate of the center in the hole's plane (the position perpendicular to the normal).
    center_along_normal : float
        Of the center's position along the normal.
    diameter : float
    normal_deg : float
        Of the normal's direction, degrees.
    estimator : str
        What measured the edge: ``rim_fit``, ``lattice``, ``empty_circle`` or ``cone`` (docs/method/uncertainty.md).
    countersink, counterbore, bore : or None
        Of the values below the edge, when the hole has them.
    axis_deg, perpendicularity_deg : float or None
        Of the axis's direction and of the perpendicularity, degrees, when the hole has an axis.
    """

    center_in_plane: float
    center_along_normal: float
    diameter: float
    normal_deg: float
    estimator: str = ESTIMATOR_RIM_FIT
    countersink: Optional[CountersinkUncertainty] = None
    counterbore: Optional[CounterboreUncertainty] = None
    bore: Optional[BoreUncertainty] = None
    axis_deg: Optional[float] = None
    perpendicularity_deg: Optional[float] = None


@dataclass(frozen=True)
class HoleWarning:
    """Something that makes a hole's result doubtful (a value given may be wrong): a short stable
    ``code`` and a sentence (``message``) with the numbers (the codes are listed in docs/reference/warnings.md)."""

    code: str
    message: str


@dataclass(frozen=True)
class HoleNote:
    """Why a value of a hole is null, or a fact that makes no value given doubtful (a scan straight
    down a bore sees no bore wall): a short stable ``code`` and a sentence (``message``) with the
    numbers, as :class:`HoleWarning` (the codes are listed in docs/reference/warnings.md)."""

    code: str
    message: str


@dataclass(frozen=True)
class Hole:
    """One measured hole.

    Attributes
    ----------
    index : int
        Position of the hole in the result, from 0; holes are ordered by their center (see docs/reference/output.md).
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
    type : str or None
        ``"through"``, ``"countersunk"``, ``"counterbored"`` or ``"blind"``, from what the points
        below the edge show (None from the ``paper`` method, which does not look below the surface).
    countersink : Countersink or None
        The countersink of a countersunk hole.
    counterbore : Counterbore or None
        The step of a counterbored hole.
    bore : Bore or None
        The bore (None from the ``paper`` method).
    axis : (3,) tuple of float or None
        The hole's axis (unit, out of the material), from the cone, else the bore's cylinder, else the
        floor of a blind hole or counterbore; None when none of them is seen.
    perpendicularity_deg : float or None
        Angle between :attr:`axis` and :attr:`normal`, degrees.
    warnings : tuple of HoleWarning
        What makes the result doubtful: a value given may be wrong (empty for a clean scan).
    notes : tuple of HoleNote
        Why a value is null (``bore_not_seen``, ``axis_not_measured``, ...): nothing doubtful.
    uncertainty : Uncertainty or None
        The standard uncertainties of the values (None from the ``paper`` method).
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
    type: Optional[str] = None
    countersink: Optional[Countersink] = None
    counterbore: Optional[Counterbore] = None
    bore: Optional[Bore] = None
    axis: Optional[Vector] = None
    perpendicularity_deg: Optional[float] = None
    warnings: tuple[HoleWarning, ...] = ()
    notes: tuple[HoleNote, ...] = ()
    uncertainty: Optional[Uncertainty] = None

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
        out["axis"] = None if self.axis is None else list(self.axis)
        if self.bore is not None and self.bore.depth_range is not None:
            out["bore"]["depth_range"] = list(self.bore.depth_range)
        out["warnings"] = [asdict(warning) for warning in self.warnings]
        out["notes"] = [asdict(note) for note in self.notes]
        return out


@dataclass(frozen=True)
class Rejection:
    """A candidate void that is not reported as a hole, and why (``holecli detect --explain``).

    Attributes
    ----------
    check : str
        The check that refused it: ``no_rim``, ``too_few_rim_points``, ``no_circle_fit``,
        ``below_min_diameter``, ``material_inside``, ``not_round``, ``partial_rim_arc``, ``boss``,
        ``duplicate``, ``partial_left_out`` or ``beyond_max_holes`` (see docs/guide/detect.md, --explain).
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


# The version of the record's layout (``schema_version``): MAJOR.MINOR. MINOR grows when a key is
# added (a reader may ignore keys it does not know); MAJOR when a key is removed, renamed or moved or
# its type or meaning changes. docs/reference/output.md documents the rule; holecli/schema/record.schema.json
# describes this version. 2.2 (issue 24): holes[].notes, the reasons a value is null, out of warnings.
# 2.3 (issue 25): input_columns, the columns of a text table read as x, y, z, and options.columns.
SCHEMA_VERSION = "2.3"


@dataclass(frozen=True)
class Scales:
    """The scales the pipeline measured on the scan and derived its thresholds from (file units).

    Attributes
    ----------
    point_spacing : float or None
        Median nearest-neighbour distance of the surface points (h); None from ``paper``.
    gap_scale : float or None
        90th percentile of the empty-circle radii in the material (g); the robust method's thresholds
        are multiples of it. None from ``paper``.
    line_pitch : float or None
        Distance between neighbouring scan lines; None when the points lie on no stripes.
    period : float or None
        Across-line period of a regular pattern (the line pitch, or the spacing of a square grid);
        None on irregular sampling.
    lattice : bool or None
        True when the points sit on a square grid; None from ``paper``.
    height_noise : float or None
        Robust standard deviation of the surface points' heights above the plane; None from ``paper``.
    min_diameter : float or None
        The smallest diameter reported, as used: the one given, else ``min_diameter_gaps`` (6) gap
        scales; None from ``paper``, which has no minimum.
    triangle_area_bound : float or None
        ``paper`` only: the bound of Eq. (12) above which a Delaunay triangle is a hole triangle
        (file units squared); None from ``robust``.
    """

    point_spacing: Optional[float] = None
    gap_scale: Optional[float] = None
    line_pitch: Optional[float] = None
    period: Optional[float] = None
    lattice: Optional[bool] = None
    height_noise: Optional[float] = None
    min_diameter: Optional[float] = None
    triangle_area_bound: Optional[float] = None


@dataclass(frozen=True)
class Timing:
    """Where the time of one detection went (the record's ``timing``: drop it to diff two runs).

    Attributes
    ----------
    elapsed_ms : float
        Wall time of :func:`holecli.detect`, milliseconds (reading the file not counted).
    stages : tuple of (str, float)
        Milliseconds of each stage of the method, in the order they ran (``robust``: ``validate``,
        ``imports`` (the method's modules, paid by a process's first detection), ``plane``,
        ``frame``, ``sampling``, ``grid``, ``candidates``, ``shape``; ``paper``: ``validate``,
        ``imports``, ``paper``). Together they make up ``elapsed_ms`` but for the bookkeeping.
    read_ms : float or None
        Time to read the file (:func:`holecli.detect_file`); None for points given in memory.
    """

    elapsed_ms: float = 0.0
    stages: tuple[tuple[str, float], ...] = ()
    read_ms: Optional[float] = None

    def to_dict(self) -> dict:
        """``{"elapsed_ms", "read_ms", "stages": {name: ms}}``.

        Returns
        -------
        dict
        """
        return {"elapsed_ms": self.elapsed_ms, "read_ms": self.read_ms, "stages": dict(self.stages)}


@dataclass(frozen=True)
class Options:
    """The options a detection ran with, as given to :func:`holecli.detect` (the record's ``options``).

    Attributes
    ----------
    method : str
        ``"paper"`` or ``"robust"``.
    view_dir : (3,) tuple of float or None
        The viewing direction given (as given, not normalised).
    min_diameter : float or None
        The minimum diameter given (None: the default; the one used is ``Scales.min_diameter``).
    max_holes : int or None
    full_only : bool
    gauge_depth : float or None
    rng : int or None
        The seed of the plane's RANSAC hypotheses; None when a ``numpy.random.Generator`` was passed.
    settings : tuple of (str, object) or None
        The tunables of the robust method that differ from :data:`holecli.settings.DEFAULT_SETTINGS`
        (name and value pairs, in field order; ``()`` for the defaults); None from ``paper``.
    input_format : str or None
        The format the file was read in when it was given (``--input-format``; None: by its extension).
    scan : int or None
        The scan of an E57 file read (``--scan``; None: every scan, merged).
    columns : (3,) tuple of (str or int), or None
        The x, y, z columns of a text table as given (``--columns``: header names or 0-based
        indices); None: found from the header or the data.
    """

    method: str = "robust"
    view_dir: Optional[Vector] = None
    min_diameter: Optional[float] = None
    max_holes: Optional[int] = None
    full_only: bool = False
    gauge_depth: Optional[float] = None
    rng: Optional[int] = 0
    settings: Optional[tuple[tuple[str, object], ...]] = None
    input_format: Optional[str] = None
    scan: Optional[int] = None
    columns: Optional[tuple] = None


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
    timing : Timing
        Wall time of the detection and of its stages (and of reading the file, from
        :func:`holecli.detect_file`).
    rejected : tuple of Rejection
        The candidate voids that are not holes, largest first (``robust`` only; empty for
        ``paper``, which has one candidate).
    units : str or None
        The length unit the file's format declares (``"m"`` for E57, see
        :attr:`holecli.io.Cloud.units`); not in :meth:`to_dict`, whose caller decides what the
        record says (:class:`holecli.units.UnitChoice`).
    scales : Scales
        The scales measured on the scan (point spacing, gap scale, line pitch, ...).
    options : Options
        The options the detection ran with.
    candidates : int
        Candidate voids examined (``robust``: every hole and every rejection; ``paper``: 1).
    input_columns : holecli.io.text.TableColumns or None
        Which columns of a text table were read as x, y, z (:attr:`holecli.io.Cloud.columns`);
        None for other formats and for points not read from a file.
    """

    holes: tuple[Hole, ...]
    plane: Plane
    points: int
    method: str
    file: Optional[str] = None
    dropped_points: int = 0
    timing: Timing = Timing()
    rejected: tuple[Rejection, ...] = ()
    units: Optional[str] = None
    scales: Scales = Scales()
    options: Options = Options()
    candidates: int = 0
    input_columns: Optional[object] = None

    @property
    def elapsed_ms(self) -> float:
        """Wall time of the detection, milliseconds (``timing.elapsed_ms``).

        Returns
        -------
        float
        """
        return self.timing.elapsed_ms

    def to_dict(self, explain=False) -> dict:
        """The JSON record of the command line (see docs/reference/output.md for the contract).

        Parameters
        ----------
        explain : bool
            Also give ``rejected``, the list of :class:`Rejection` (as dicts).

        Returns
        -------
        dict
            ``schema_version``, ``holecli_version``, ``file``, ``points``, ``dropped_points``,
            ``method``, ``options`` (:class:`Options`, with ``min_diameter_effective`` and
            ``tolerances``: None until :func:`holecli.tolerance.check` fills it in), ``scales``
            (:class:`Scales`), ``candidates``, ``plane`` (``point``, ``normal``, ``rms``,
            ``inliers``), ``holes`` (:meth:`Hole.to_dict`) and ``timing`` (:meth:`Timing.to_dict`),
            in that order, then ``rejected`` with ``explain``.
        """
        from holecli import __version__

        given = self.options
        options = {
            "method": given.method,
            "view_dir": None if given.view_dir is None else list(given.view_dir),
            "min_diameter": given.min_diameter,
            "min_diameter_effective": self.scales.min_diameter,
            "max_holes": given.max_holes,
            "full_only": given.full_only,
            "gauge_depth": given.gauge_depth,
            "rng": given.rng,
            "settings": None if given.settings is None else {
                name: list(value) if isinstance(value, tuple) else value for name, value in given.settings},
            "input_format": given.input_format,
            "scan": given.scan,
            "columns": None if given.columns is None else list(given.columns),
            "tolerances": None,
        }
        record = {
            "schema_version": SCHEMA_VERSION,
            "holecli_version": __version__,
            "file": self.file,
            "points": self.points,
            "dropped_points": self.dropped_points,
            "input_columns": None if self.input_columns is None else self.input_columns.to_dict(),
            "method": self.method,
            "options": options,
            "scales": asdict(self.scales),
            "candidates": self.candidates,
            "plane": {
                "point": list(self.plane.point),
                "normal": list(self.plane.normal),
                "rms": self.plane.rms,
                "inliers": self.plane.inliers,
            },
            "holes": [hole.to_dict() for hole in self.holes],
            "timing": self.timing.to_dict(),
        }
        if explain:
            record["rejected"] = [rejection.to_dict() for rejection in self.rejected]
        return record
