"""Tolerance verdicts: nominal holes, tolerance bands, matching of measured holes, pass or fail.

Pure functions over plain values: a :class:`Spec` (built and validated once by :func:`parse_band`,
:func:`nominal_spec` or :func:`parse_spec`) and a detection record (the dict of
:meth:`holecli.results.Detection.to_dict`) go in, a new record with the verdicts comes out
(:func:`check`). No file is opened here and nothing is printed.

Checks
------
diameter
    measured - nominal diameter within the band ``[lower, upper]`` of signed deviations
    (``+0.036/-0`` is ``lower = 0, upper = 0.036``).
position
    the distance of the measured center from the nominal center in the plane of the hole (that is,
    perpendicular to the measured hole normal) at most ``position_tolerance``. The distance along the
    normal is reported, not checked.
tilt
    the angle between the lines of the measured and the nominal normal (the sign of a normal does not
    matter) at most ``max_tilt`` degrees.
countersink_diameter, countersink_angle, countersink_depth, bore_diameter
    measured - nominal value within its band, like the diameter: the hole's ``countersink.diameter``,
    ``countersink.angle_deg`` (degrees), ``countersink.depth`` and ``bore.diameter`` against the
    nominal's ``countersink_diameter`` and ``countersink_diameter_band`` and so on (spec keys
    ``countersink_diameter`` and ``countersink_diameter_tolerance``, ...).
perpendicularity
    the hole's ``perpendicularity_deg`` (the angle between its axis and its surface normal) at most
    ``max_perpendicularity`` degrees.
countersink_gauge
    the countersink gauge reading: the countersink's diameter at the run's gauge depth
    (``countersink.diameter_at_depth``, at ``--gauge-depth`` below the surface, what a gauge whose
    stop is set to that depth reads) minus the nominal ``countersink_gauge_diameter``, within the band
    ``countersink_gauge_tolerance`` (spec keys of those names). Not measured without a gauge depth, or
    when the depth is not within the countersink.

A check whose measured value is null (a hole without a countersink, a bore wall not seen, no axis) is
*not measured*: it fails, with ``<check>_not_measured`` in ``failed_checks`` (``"bore_diameter_not_measured"``)
and a null deviation, so that a value the scan does not show is never taken for one in tolerance.

Decision rules (ISO 14253-1)
----------------------------
Every check of a checked hole gets an entry in the hole's ``conformance``, by check name::

    {"value": v, "lower": L or None, "upper": T, "expanded_uncertainty": U or None,
     "decision": "pass" | "fail" | "undecided", "reason": code}

``value`` is what is compared (the deviation for a band check, the in-plane distance for position,
the angle for tilt and perpendicularity; None when not measured), ``lower`` and ``upper`` the limits
of the zone (``lower`` None for the checks of a largest value), ``expanded_uncertainty`` is
``U = k * u`` with ``u`` the standard uncertainty of the measured value in the hole's ``uncertainty``
(:data:`_UNCERTAINTY_PATHS`) and ``k`` the spec's ``coverage_factor`` (None when ``u`` is not known).

simple (the default)
    the value alone decides: ``pass`` inside the zone, ``fail`` outside it; U is reported, not used.
guarded
    ``pass`` when ``[value - U, value + U]`` lies inside the zone (conformance proved), ``fail`` when
    it lies wholly outside (non-conformance proved), ``undecided`` when it straddles a limit. A check
    whose ``u`` is not known is ``undecided`` (reason ``uncertainty_unknown``): a conformance that
    cannot be proved is not proved.

A check not measured fails under either rule (reason ``not_measured``). The ``reason`` codes:
``inside``, ``outside`` (simple), ``inside_with_uncertainty``, ``outside_with_uncertainty``,
``straddles_lower``, ``straddles_upper``, ``uncertainty_unknown`` (guarded), ``not_measured``.
Every comparison allows :data:`_ROUND_OFF`, as without a decision rule.

Matching
--------
A nominal hole with a center is matched to one measured hole: every pair closer than the nominal's
``match_radius`` is a candidate, and pairs are taken greedily by increasing distance, each hole on
either side at most once. Nominal holes of a spec file have ``match_radius = diameter``; the nominal
of the command line has an unlimited one (it takes the nearest hole). A nominal without a center (the
command line's ``--nominal-diameter`` alone) applies to every measured hole. A nominal hole left
without a measured one is *missing* and fails the verdict; a measured hole left without a nominal one
is reported unchecked and does not fail it.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, replace
from typing import Optional

from holecli.errors import SpecError
from holecli.io.decimal_text import parse_decimal
from holecli.units import UNIT_MISMATCH, declared_units, label_record, scale_factor, unit_factors, unit_mistake
from holecli.vocabulary import DECISION_RULES

__all__ = ["DECISION_RULES", "DEFAULT_COVERAGE_FACTOR", "Band", "NominalHole", "Spec", "check", "describe",
           "load_toml", "nominal_spec", "parse_band", "parse_spec", "spec_in_units", "spec_number", "unit_scale_match"]

Vector = tuple[float, float, float]

# Comparisons allow this much round-off, relative to the size of the compared quantity (the nominal
# diameter, the position tolerance, the angle): far below any real tolerance (ISO IT01 on a 3 mm
# hole is 1e-4 of it) and far above the round-off of a subtraction (1e-16).
_ROUND_OFF = 1e-9


@dataclass(frozen=True)
class _FeatureCheck:
    """A nominal value with a band, checked against one measured value of the hole below its edge.

    ``name`` is the check's name (in ``failed_checks``), the spec key of the nominal value, the prefix
    of the verdict field ``<name>_deviation`` and, with ``_band``, of the band's attribute of
    :class:`NominalHole`; ``<name>_tolerance`` is the spec key of the band. ``path`` is where the
    measured value is in a hole record; ``accept`` and ``expected`` validate the nominal value.
    """

    name: str
    path: tuple[str, str]
    accept: object
    expected: str


_FEATURE_CHECKS = (
    _FeatureCheck("countersink_diameter", ("countersink", "diameter"), lambda v: v > 0, "a number > 0"),
    _FeatureCheck("countersink_angle", ("countersink", "angle_deg"), lambda v: 0 < v < 180,
                  "an angle in degrees between 0 and 180"),
    _FeatureCheck("countersink_depth", ("countersink", "depth"), lambda v: v > 0, "a number > 0"),
    _FeatureCheck("bore_diameter", ("bore", "diameter"), lambda v: v > 0, "a number > 0"),
)
_FEATURE_KEYS = tuple(key for feature in _FEATURE_CHECKS for key in (feature.name, f"{feature.name}_tolerance"))

# The keys of a [[hole]] table of a spec file, and which of them are required.
_SPEC_KEYS = ("name", "center", "diameter", "tolerance", "position_tolerance", "normal", "max_tilt",
              *_FEATURE_KEYS, "max_perpendicularity")
_REQUIRED_KEYS = ("name", "center", "diameter", "tolerance")

# The countersink gauge (issue 25, item 8): the nominal diameter at the gauge depth and its band.
_GAUGE_KEYS = ("countersink_gauge_diameter", "countersink_gauge_tolerance")
_SPEC_KEYS = (*_SPEC_KEYS, *_GAUGE_KEYS)

# How the command line calls the values (for messages); the spec file uses the keys themselves.
_KEY_NAMES = {key: key for key in _SPEC_KEYS}

# The keys that make a nominal hole check something (the others only say what to check against).
_TOLERANCE_KEYS = ("tolerance", "position_tolerance", "max_tilt",
                   *(f"{feature.name}_tolerance" for feature in _FEATURE_CHECKS), "countersink_gauge_tolerance",
                   "max_perpendicularity")

# The note of a hole tied to a spec hole (check's ``tied``) that lies beyond its match radius in a spec
# no registration mapped: the scan is in another frame, so its position and tilt are not checked.
NOT_IN_SPEC_FRAME = "not_in_spec_frame"

# The decision rules of ISO 14253-1 that check() applies, and the default coverage factor (k = 2: about
# 95 % coverage for a normal distribution, the usual choice of a calibration certificate).
DEFAULT_COVERAGE_FACTOR = 2.0

# Where each check's standard uncertainty is in a hole's ``uncertainty`` (its value, or null).
_UNCERTAINTY_PATHS = {
    "diameter": ("diameter",), "position": ("center_in_plane",), "tilt": ("normal_deg",),
    "countersink_diameter": ("countersink", "diameter"), "countersink_angle": ("countersink", "angle_deg"),
    "countersink_depth": ("countersink", "depth"), "bore_diameter": ("bore", "diameter"),
    "perpendicularity": ("perpendicularity_deg",), "countersink_gauge": ("countersink", "diameter_at_depth"),
}


@dataclass(frozen=True)
class Band:
    """Allowed deviations of a diameter from its nominal value, signed, in file units.

    Attributes
    ----------
    lower, upper : float
        Smallest and largest allowed ``measured - nominal``; ``lower <= upper``.
    """

    lower: float
    upper: float

    def __str__(self):
        return f"{self.upper:+g}/{self.lower:+g}"


@dataclass(frozen=True)
class NominalHole:
    """One hole as drawn, with its tolerances. Build it with :func:`nominal_spec` or :func:`parse_spec`.

    Attributes
    ----------
    name : str or None
        Name from the spec file (None for the command line's nominal).
    diameter : float or None
        Nominal diameter, file units; checked against ``band``.
    band : Band or None
        Diameter tolerance band; given exactly when ``diameter`` is.
    center : (3,) tuple of float or None
        Nominal center on the surface, file units. None: the nominal applies to every measured hole.
    position_tolerance : float or None
        Largest allowed in-plane distance of the measured center from ``center``.
    normal : (3,) tuple of float or None
        Nominal surface normal (any length but zero, any sign).
    max_tilt : float or None
        Largest allowed angle between the measured and the nominal normal, degrees; needs ``normal``.
    countersink_diameter, countersink_angle, countersink_depth, bore_diameter : float or None
        Nominal countersink diameter at the surface, included countersink angle (degrees), countersink
        depth and bore diameter; each checked against its band.
    countersink_diameter_band, countersink_angle_band, countersink_depth_band, bore_diameter_band : Band or None
        Their tolerance bands (degrees for the angle); each given exactly when its value is.
    max_perpendicularity : float or None
        Largest allowed angle between the hole's axis and its surface normal, degrees.
    countersink_gauge_diameter : float or None
        Nominal diameter of the countersink at the gauge depth (``--gauge-depth``), what a countersink
        gauge reads; checked against ``countersink_gauge_band``.
    countersink_gauge_band : Band or None
        Its tolerance band; given exactly when ``countersink_gauge_diameter`` is.
    match_radius : float
        A measured hole farther than this from ``center`` is not matched to this nominal.
    center_covariance : (3, 3) tuple of tuples of float, optional
        The covariance of ``center`` itself, file units squared: a nominal mapped into the measuring
        frame by a registration (:func:`holecli.registration.apply.map_spec`) is only as well known as
        the registration. Its part in the hole's plane enters the position check's uncertainty (in
        quadrature with the measured center's); ``inf`` or NaN entries make that uncertainty unknown.
        None: the nominal center is exact (a drawing's).
    normal_uncertainty_deg : float, optional
        The standard uncertainty of ``normal``'s direction, degrees (a registered nominal's), added in
        quadrature to the tilt check's; None: exact.
    """

    name: Optional[str]
    diameter: Optional[float] = None
    band: Optional[Band] = None
    center: Optional[Vector] = None
    position_tolerance: Optional[float] = None
    normal: Optional[Vector] = None
    max_tilt: Optional[float] = None
    countersink_diameter: Optional[float] = None
    countersink_diameter_band: Optional[Band] = None
    countersink_angle: Optional[float] = None
    countersink_angle_band: Optional[Band] = None
    countersink_depth: Optional[float] = None
    countersink_depth_band: Optional[Band] = None
    bore_diameter: Optional[float] = None
    bore_diameter_band: Optional[Band] = None
    max_perpendicularity: Optional[float] = None
    countersink_gauge_diameter: Optional[float] = None
    countersink_gauge_band: Optional[Band] = None
    match_radius: float = math.inf
    center_covariance: Optional[tuple] = None
    normal_uncertainty_deg: Optional[float] = None


@dataclass(frozen=True)
class Spec:
    """What the holes of a record are checked against.

    Attributes
    ----------
    holes : tuple of NominalHole
        The nominal holes; at most one of them without a center, and then it is the only one.
    named : bool
        True for a spec file: every measured hole gets the ``name`` of its nominal (or None).
    source : str or None
        Where the spec came from (the spec file), for messages and the record's provenance.
    sha256 : str or None
        SHA-256 (hex) of the spec file's bytes as read, for the record's provenance (filled in by
        whoever read the file: :func:`parse_spec` sees text only).
    decision_rule : {"simple", "guarded"}
        How a measured value and its uncertainty decide a check (ISO 14253-1, see the module's
        docstring): ``simple`` by the value alone, ``guarded`` by the value +- its expanded uncertainty.
    coverage_factor : float
        ``k`` of the expanded uncertainty ``U = k * u``; a finite number > 0.
    registration : dict, optional
        When the nominal holes were mapped into the measuring frame by a registration
        (:func:`holecli.registration.apply.map_spec`): what it was (its file, SHA-256, ...), for the
        record's ``options.tolerances.registration``. None: the holes are as drawn.
    units : {"mm", "m", "in"} or None
        The unit the spec file declares (``units = "in"`` at its top): :func:`check` converts its
        lengths into the record's unit, or takes them in it when the record's unit is not known. None:
        the spec's lengths are in the record's unit, whatever it is.

    Raises
    ------
    SpecError
        For a ``decision_rule`` not in :data:`DECISION_RULES` or a ``coverage_factor`` that is not a
        finite number > 0 (the dataclass validates them on construction, and on ``replace``).
    """

    holes: tuple[NominalHole, ...]
    named: bool = False
    source: Optional[str] = None
    sha256: Optional[str] = None
    decision_rule: str = "simple"
    coverage_factor: float = DEFAULT_COVERAGE_FACTOR
    registration: Optional[dict] = None
    units: Optional[str] = None

    def __post_init__(self):
        if self.decision_rule not in DECISION_RULES:
            raise SpecError(f"decision_rule must be one of {', '.join(DECISION_RULES)}, got {self.decision_rule!r}")
        k = self.coverage_factor
        if spec_number(k) is None or k <= 0:
            raise SpecError(f"coverage_factor must be a finite number > 0, got {_shown(k)}")
        object.__setattr__(self, "coverage_factor", spec_number(k))


# --------------------------------------------------------------------------------------------------
# Validation at the boundary


def parse_band(value) -> Band:
    """The tolerance band of ``value``: a number ``T`` (symmetric, +-T) or a string.

    Accepted strings: ``"0.05"``, ``"±0.05"``, ``"+/-0.05"``, ``"+-0.05"`` (symmetric) and
    ``"UPPER/LOWER"``, the signed upper then lower deviation as on a drawing: ``"+0.036/-0"``,
    ``"+0.036/0"``, ``"0.036/-0.010"``, ``"-0.014/-0.035"`` (a P7 hole). The lower deviation needs
    its sign unless it is zero, so that ``"0.05/0.05"`` is refused rather than read as ``+0.05/+0.05``.

    Parameters
    ----------
    value : float, int or str
        The tolerance as a number or as text in one of the forms above.

    Returns
    -------
    Band
        The lower and upper deviations (``lower <= upper``; ``-T`` and ``+T`` for a symmetric one).

    Raises
    ------
    SpecError
        For anything else: a negative symmetric tolerance, upper below lower, text that is not one
        of the forms, a value that is not finite.
    """
    if isinstance(value, bool) or not isinstance(value, (int, float, str)):
        raise SpecError(f"expected a number >= 0 or a string like \"+0.036/-0\", got {_shown(value)}")
    if not isinstance(value, str):
        checked = spec_number(value)
        return _symmetric(float("inf") if checked is None else checked, value)
    text = value.strip()
    for prefix in ("±", "+/-", "+-"):
        if text.startswith(prefix):
            return _symmetric(_float(text[len(prefix):].strip(), value), value)
    if "/" not in text:
        return _symmetric(_float(text, value), value)
    upper_text, _, lower_text = (part.strip() for part in text.partition("/"))
    upper, lower = _float(upper_text, value), _float(lower_text, value)
    if lower != 0.0 and lower_text[0] not in "+-":
        raise SpecError(f"write the lower deviation of {value!r} with its sign "
                        f"(+{lower_text} or -{lower_text})")
    if upper < lower:
        raise SpecError(f"in {value!r} the upper deviation (first) is below the lower one (second); "
                        f"did you mean {lower_text}/{upper_text}?")
    return Band(lower=lower + 0.0, upper=upper + 0.0)  # + 0.0: no -0.0 in the output


def nominal_spec(*, diameter=None, tolerance=None, center=None, position_tolerance=None, normal=None,
                 max_tilt=None, countersink_diameter=None, countersink_diameter_tolerance=None,
                 countersink_angle=None, countersink_angle_tolerance=None, countersink_depth=None,
                 countersink_depth_tolerance=None, bore_diameter=None, bore_diameter_tolerance=None,
                 max_perpendicularity=None, names=None, countersink_gauge_diameter=None,
                 countersink_gauge_tolerance=None) -> Spec:
    """A spec of one nominal hole from separate values (the command-line options).

    Parameters
    ----------
    diameter : float, optional
        Nominal diameter; needs ``tolerance``.
    tolerance : float, str or Band, optional
        Diameter tolerance, see :func:`parse_band`; needs ``diameter``.
    center : (3,) float, optional
        Nominal center: the checks then apply to the measured hole nearest to it only, and
        ``position_deviation`` is reported for it. Without a center they apply to every hole.
    position_tolerance : float, optional
        Largest in-plane distance from ``center``; needs ``center``.
    normal : (3,) float, optional
        Nominal normal: ``tilt_deg`` is reported.
    max_tilt : float, optional
        Largest angle from ``normal``, degrees in [0, 90]; needs ``normal``.
    countersink_diameter, countersink_angle, countersink_depth, bore_diameter : float, optional
        Nominal countersink diameter at the surface (> 0), included countersink angle (degrees, in
        (0, 180)), countersink depth (> 0) and bore diameter (> 0); each needs its tolerance.
    countersink_diameter_tolerance, countersink_angle_tolerance, countersink_depth_tolerance, \
bore_diameter_tolerance : float, str or Band, optional
        Their tolerances, in the forms of :func:`parse_band` (degrees for the angle: ``1`` or
        ``"+/-1"`` for 100 +- 1, ``"+1/-0.5"``); each needs its value.
    max_perpendicularity : float, optional
        Largest angle between the hole's axis and its surface normal, degrees in [0, 90].
    names : dict, optional
        How messages call each parameter (the CLI passes its option names).
    countersink_gauge_diameter : float, optional
        Nominal countersink diameter at the gauge depth (> 0); needs ``countersink_gauge_tolerance``.
    countersink_gauge_tolerance : float, str or Band, optional
        Its tolerance, in the forms of :func:`parse_band`; needs ``countersink_gauge_diameter``.

    Returns
    -------
    Spec
        A spec of the one nominal hole, not named (``named`` False).

    Raises
    ------
    SpecError
        When a value is out of range, a value lacks its partner, or no tolerance is given at all.
    """
    names = {**_KEY_NAMES, **(names or {})}
    entry = {"diameter": diameter, "tolerance": tolerance, "center": center,
             "position_tolerance": position_tolerance, "normal": normal, "max_tilt": max_tilt,
             "countersink_diameter": countersink_diameter,
             "countersink_diameter_tolerance": countersink_diameter_tolerance,
             "countersink_angle": countersink_angle, "countersink_angle_tolerance": countersink_angle_tolerance,
             "countersink_depth": countersink_depth, "countersink_depth_tolerance": countersink_depth_tolerance,
             "bore_diameter": bore_diameter, "bore_diameter_tolerance": bore_diameter_tolerance,
             "max_perpendicularity": max_perpendicularity,
             "countersink_gauge_diameter": countersink_gauge_diameter,
             "countersink_gauge_tolerance": countersink_gauge_tolerance}
    entry = {key: value for key, value in entry.items() if value is not None}
    hole = _nominal_hole(entry, name=None, names=names, where="")
    if not any(key in entry for key in _TOLERANCE_KEYS):
        raise SpecError(f"give a tolerance: {names['tolerance']} (with {names['diameter']}), "
                        + ", ".join(names[key] for key in _TOLERANCE_KEYS[1:-1])
                        + f" or {names[_TOLERANCE_KEYS[-1]]}")
    return Spec(holes=(hole,), named=False)


def spec_number(value):
    """``value`` as a finite float, or None when it is not a number or no float holds it.

    The one conversion every number of a spec goes through: ``float()`` of a TOML integer beyond
    about 1.8e308 raises OverflowError (a traceback, where one line is owed), and ``bool`` is an
    ``int`` that no spec means as a number.

    Parameters
    ----------
    value : object

    Returns
    -------
    float or None

    Examples
    --------
    >>> spec_number(3), spec_number(2.5), spec_number(True), spec_number(10 ** 400), spec_number(float("nan"))
    (3.0, 2.5, None, None, None)
    """
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return None
    try:
        number = float(value)
    except OverflowError:
        return None
    return number if math.isfinite(number) else None


def load_toml(text, what="spec", first_index=1) -> dict:
    """The data of a spec-like TOML file (a spec, a panel spec), with its numbers checked.

    A UTF-8 byte order mark at the start (Windows editors write one) is skipped. An integer that no
    float holds (``diameter = 1000...0`` of 400 digits) is refused here, naming its key, so that no
    later ``float()`` meets it; so is one of more than 4,300 digits, which Python's ``int`` refuses
    to read (a ValueError, not a TOML error).

    Parameters
    ----------
    text : str
    what : str
        What the file is, for messages (``"spec"``, ``"panel"``).
    first_index : int
        How messages count the tables of an array (``hole 1`` for a spec, ``feature[0]`` for a panel).

    Returns
    -------
    dict

    Raises
    ------
    SpecError
    """
    if text.startswith("\ufeff"):
        text = text[1:]
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as error:
        raise SpecError(f"invalid TOML: {error}") from None
    except RecursionError:
        # tomllib parses nested arrays and inline tables recursively; a spec nests two levels.
        raise SpecError(f"invalid TOML: arrays or tables nested too deeply for a {what} file") from None
    except ValueError:  # int() of more than 4,300 digits (sys.get_int_max_str_digits)
        raise SpecError("invalid TOML: a number of more than 4300 digits") from None
    _refuse_huge_integers(data, "", first_index)
    return data


def _refuse_huge_integers(value, where, first_index):
    if isinstance(value, dict):
        for key, item in value.items():
            _refuse_huge_integers(item, f"{where}.{key}" if where else str(key), first_index)
    elif isinstance(value, list):
        for index, item in enumerate(value, start=first_index):
            _refuse_huge_integers(item, f"{where}[{index}]", first_index)
    elif isinstance(value, int) and not isinstance(value, bool) and spec_number(value) is None:
        raise SpecError(f"{where}: an integer of {_digits(value)} digits is too large for a number")


def parse_spec(text, source="spec") -> Spec:
    """The nominal holes of a part from the text of a TOML spec file.

    The file may declare the unit of its lengths at its top, ``units = "mm"`` (``"m"``, ``"in"``:
    :attr:`Spec.units`), and holds one ``[[hole]]`` table per hole with ``name``, ``center = [x, y, z]``,
    ``diameter`` and ``tolerance`` (see :func:`parse_band`), and optionally ``position_tolerance``,
    ``normal = [x, y, z]``, ``max_tilt`` (degrees, needs ``normal``), the pairs
    ``countersink_diameter`` and ``countersink_diameter_tolerance``, ``countersink_angle`` and
    ``countersink_angle_tolerance`` (degrees), ``countersink_depth`` and ``countersink_depth_tolerance``,
    ``bore_diameter`` and ``bore_diameter_tolerance`` (each value with its tolerance, the tolerance in
    the forms of :func:`parse_band`), and ``max_perpendicularity`` (degrees). Each hole is matched
    within its nominal diameter of its center.

    Parameters
    ----------
    text : str
        The TOML text.
    source : str
        The file's name, for :attr:`Spec.source`.

    Returns
    -------
    Spec
        The named nominal holes, in the file's order (``named`` True).

    Raises
    ------
    SpecError
        For invalid TOML, no ``[[hole]]``, an unknown or missing key, a value out of range or of the
        wrong type, a repeated name. The message names the hole (its position and name) and the key;
        it does not repeat ``source``.
    """
    data = load_toml(text, "spec")
    try:
        units = declared_units(data, "spec")
    except ValueError as error:
        raise SpecError(str(error)) from None
    unknown = sorted(set(data) - {"hole"})
    if unknown:
        raise SpecError(f"unknown top-level key {unknown[0]!r} (expected units and [[hole]] tables only)")
    tables = data.get("hole")
    if not isinstance(tables, list) or not tables or not all(isinstance(table, dict) for table in tables):
        raise SpecError("expected at least one [[hole]] table")
    holes, seen = [], set()
    for number, table in enumerate(tables, start=1):
        name = table.get("name")
        where = f"hole {number}" + (f" ({name!r})" if isinstance(name, str) else "")
        unknown = sorted(set(table) - set(_SPEC_KEYS))
        if unknown:
            raise SpecError(f"{where}: unknown key {unknown[0]!r} (expected {', '.join(_SPEC_KEYS)})")
        missing = [key for key in _REQUIRED_KEYS if key not in table]
        if missing:
            raise SpecError(f"{where}: missing key {missing[0]!r}")
        if not isinstance(name, str) or not name.strip():
            raise SpecError(f"{where}: 'name' must be a non-empty string, got {name!r}")
        if name != name.strip() or not name.isprintable():
            # "A1" and "A1 " would be two holes to the matching and one to a reader of the report.
            raise SpecError(f"{where}: 'name' must not start or end with spaces or hold control characters, "
                            f"got {name!r}")
        if name in seen:
            raise SpecError(f"{where}: the name {name!r} is used twice")
        seen.add(name)
        entry = {key: value for key, value in table.items() if key != "name"}
        hole = _nominal_hole(entry, name=name, names=_KEY_NAMES, where=f"{where}: ")
        holes.append(replace(hole, match_radius=hole.diameter))
    return Spec(holes=tuple(holes), named=True, source=source, units=units)


def _nominal_hole(entry, name, names, where) -> NominalHole:
    partners = [("diameter", "tolerance"), ("tolerance", "diameter"),
                ("position_tolerance", "center"), ("max_tilt", "normal"),
                ("countersink_gauge_diameter", "countersink_gauge_tolerance"),
                ("countersink_gauge_tolerance", "countersink_gauge_diameter")]
    for feature in _FEATURE_CHECKS:
        partners += [(feature.name, f"{feature.name}_tolerance"), (f"{feature.name}_tolerance", feature.name)]
    for key, partner in partners:
        if key in entry and partner not in entry:
            raise SpecError(f"{where}{names[key]} needs {names[partner]}")

    def number(key, accept, expected):
        value = entry[key]
        checked = spec_number(value)
        if checked is None or not accept(checked):
            raise SpecError(f"{where}{names[key]} must be {expected}, got {_shown(value)}")
        return checked

    def vector(key, expected):
        value = entry[key]
        checked = [spec_number(v) for v in value] if isinstance(value, (list, tuple)) and len(value) == 3 else None
        if checked is None or None in checked:
            raise SpecError(f"{where}{names[key]} must be {expected}, got {_shown(value)}")
        return tuple(checked)

    values = {}
    if "diameter" in entry:
        values["diameter"] = number("diameter", lambda v: v > 0, "a number > 0")
        tolerance = entry["tolerance"]
        try:
            values["band"] = tolerance if isinstance(tolerance, Band) else parse_band(tolerance)
        except SpecError as error:
            raise SpecError(f"{where}{names['tolerance']}: {error}") from None
    if "center" in entry:
        values["center"] = vector("center", "3 finite numbers [x, y, z]")
    if "position_tolerance" in entry:
        values["position_tolerance"] = number("position_tolerance", lambda v: v >= 0, "a number >= 0")
    if "normal" in entry:
        values["normal"] = vector("normal", "3 finite numbers [x, y, z], not all zero")
        if math.hypot(*values["normal"]) == 0.0:
            raise SpecError(f"{where}{names['normal']} must not be the zero vector")
    if "max_tilt" in entry:
        values["max_tilt"] = number("max_tilt", lambda v: 0 <= v <= 90, "an angle in degrees from 0 to 90")
    for feature in _FEATURE_CHECKS:
        if feature.name not in entry:
            continue
        tolerance_key = f"{feature.name}_tolerance"
        if isinstance(entry[feature.name], str):
            # "100 +/- 1" in one value: say where its tolerance goes.
            raise SpecError(f"{where}{names[feature.name]} must be {feature.expected} (its tolerance goes "
                            f"in {names[tolerance_key]}), got {entry[feature.name]!r}")
        values[feature.name] = number(feature.name, feature.accept, feature.expected)
        tolerance = entry[tolerance_key]
        try:
            values[f"{feature.name}_band"] = tolerance if isinstance(tolerance, Band) else parse_band(tolerance)
        except SpecError as error:
            raise SpecError(f"{where}{names[tolerance_key]}: {error}") from None
    if "max_perpendicularity" in entry:
        values["max_perpendicularity"] = number("max_perpendicularity", lambda v: 0 <= v <= 90,
                                                "an angle in degrees from 0 to 90")
    values.update(_gauge_values(entry, names, where, number))
    return NominalHole(name=name, **values)


def _gauge_values(entry, names, where, number) -> dict:
    """The countersink gauge's :class:`NominalHole` values of a spec entry (none when not given)."""
    if "countersink_gauge_diameter" not in entry:
        return {}
    if isinstance(entry["countersink_gauge_diameter"], str):
        raise SpecError(f"{where}{names['countersink_gauge_diameter']} must be a number > 0 (its tolerance goes in "
                        f"{names['countersink_gauge_tolerance']}), got {entry['countersink_gauge_diameter']!r}")
    diameter = number("countersink_gauge_diameter", lambda v: v > 0, "a number > 0")
    tolerance = entry["countersink_gauge_tolerance"]
    try:
        band = tolerance if isinstance(tolerance, Band) else parse_band(tolerance)
    except SpecError as error:
        raise SpecError(f"{where}{names['countersink_gauge_tolerance']}: {error}") from None
    return {"countersink_gauge_diameter": diameter, "countersink_gauge_band": band}


def gauge_checked(spec) -> list:
    """The holes of ``spec`` with a countersink gauge check (they need a gauge depth to be measured).

    Parameters
    ----------
    spec : Spec

    Returns
    -------
    list of NominalHole
    """
    return [hole for hole in spec.holes if hole.countersink_gauge_diameter is not None]


def _float(text, given) -> float:
    try:
        number = parse_decimal(text)
    except ValueError:
        raise SpecError(f"expected a number >= 0 or a string like \"+0.036/-0\" (upper/lower deviation), "
                        f"got {given!r}") from None
    return number


def _symmetric(tolerance, given) -> Band:
    if not math.isfinite(tolerance) or tolerance < 0:
        raise SpecError(f"a symmetric tolerance must be a number >= 0, got {_shown(given)}")
    return Band(lower=-tolerance + 0.0, upper=tolerance + 0.0)


# --------------------------------------------------------------------------------------------------
# Verdicts


def describe(spec) -> dict:
    """What a record's ``options.tolerances`` says of ``spec``: enough to check the record again.

    Parameters
    ----------
    spec : Spec

    Returns
    -------
    dict
        ``spec_file`` and ``spec_sha256`` for a spec file (the file and the SHA-256 of its bytes; the
        nominal holes are in the file), ``nominal`` None; for the command line's tolerance options,
        ``spec_file`` and ``spec_sha256`` None and ``nominal`` the one nominal hole: every
        :class:`NominalHole` value by name (bands as ``{"lower", "upper"}``, None where not given).
        Either way ``decision_rule`` and ``coverage_factor``, how the checks were decided, and
        ``registration`` when the nominal holes were mapped by one (:attr:`Spec.registration`).
    """
    decision = {"decision_rule": spec.decision_rule, "coverage_factor": spec.coverage_factor}
    if spec.registration is not None:
        decision["registration"] = spec.registration
    if spec.named:
        return {"spec_file": spec.source, "spec_sha256": spec.sha256, "nominal": None, **decision}
    hole = spec.holes[0]
    nominal = {}
    for name, value in hole.__dict__.items():
        if name in ("name", "match_radius", "center_covariance", "normal_uncertainty_deg"):
            continue
        if isinstance(value, Band):
            value = {"lower": value.lower, "upper": value.upper}
        elif isinstance(value, tuple):
            value = list(value)
        nominal[name] = value
    return {"spec_file": None, "spec_sha256": None, "nominal": nominal, **decision}


def check(record, spec, tied=None) -> dict:
    """A copy of ``record`` with the tolerance verdicts of ``spec`` added.

    Parameters
    ----------
    record : dict
        A detection record (:meth:`holecli.results.Detection.to_dict`): ``holes`` with ``center``,
        ``diameter`` and ``normal``, and ``countersink``, ``bore`` and ``perpendicularity_deg`` for the
        checks of those (missing counts as null); optionally each hole's ``uncertainty``, the
        standard uncertainties (k = 1) of its values (missing or null: not known).
    spec : Spec
        From :func:`nominal_spec` or :func:`parse_spec`; its ``decision_rule`` and
        ``coverage_factor`` say how a value and its uncertainty decide a check.
    tied : dict, optional
        ``{measured hole index: nominal name}``: holes tied to spec holes by name (``--name``, a
        one-hole scan named after a hole). Each is checked against its nominal wherever it lies; no
        other hole is matched and only the tied nominals are expected (a scan of one hole does not
        miss the spec's other holes). A tied hole farther from its nominal's center than the
        nominal's ``match_radius``, with a spec that no registration mapped into the scan's frame
        (:attr:`Spec.registration` None), is in another frame: its position and tilt are not checked
        (null, and the note ``not_in_spec_frame`` says so).

    Returns
    -------
    dict
        The record, every hole with ``diameter_deviation``, ``position_deviation``
        (``{"in_plane", "along_normal"}``), ``tilt_deg``, ``countersink_diameter_deviation``,
        ``countersink_angle_deviation``, ``countersink_depth_deviation``, ``bore_diameter_deviation``,
        ``in_tolerance``, ``failed_checks``, ``undecided_checks`` and ``conformance`` (None where the
        check does not apply or its value is not measured, all None for a hole no nominal applies
        to; a check not measured is in ``failed_checks`` as ``<check>_not_measured``; ``conformance``
        the decision of every check, see the module's docstring; ``in_tolerance`` true only when
        every check passes), and with ``name`` when ``spec.named``; and ``verdict``: ``{"checked",
        "out_of_tolerance", "undecided", "missing", "in_tolerance", "decision_rule",
        "coverage_factor"}`` after ``holes`` (``out_of_tolerance`` the holes with a failed check,
        ``undecided`` those with an undecided check and none failed). A record with ``options`` gets
        its ``tolerances`` (:func:`describe`). A spec that declares its unit (:attr:`Spec.units`) is
        converted into the record's ``units``; a record without ``units`` takes the spec's (its
        lengths are assumed to be in it); the verdict then also says ``spec_units`` and
        ``spec_units_assumed``. A hole whose measured diameter is a unit's factor of its nominal
        (1000, 25.4, ... within 1 %) gets the warning ``unit_mismatch`` in its ``warnings``.

    Raises
    ------
    ValueError
        When a hole's ``uncertainty`` holds a value that is not a finite number >= 0, or ``tied``
        names a hole or a nominal that is not there.
    """
    declared = spec.units
    spec, record, assumed = _spec_in_record_units(spec, record)
    holes = record["holes"]
    expected = spec.holes
    if tied is None:
        assigned = _match(holes, spec.holes)
    else:
        assigned = _tie(holes, spec.holes, tied)
        expected = tuple(assigned.values())
    checked_holes = []
    checked = failed = undecided = 0
    for index, hole in enumerate(holes):
        nominal = assigned.get(index)
        result = dict(hole)
        if spec.named:
            result["name"] = nominal.name if nominal else None
        in_frame = (tied is None or nominal is None or spec.registration is not None or nominal.center is None
                    or math.dist(hole["center"], nominal.center) <= nominal.match_radius)
        result.update(_verdict(hole, nominal, spec.decision_rule, spec.coverage_factor, in_frame))
        mistake = _unit_mismatch_warning(hole, nominal, record.get("units"), declared)
        if mistake is not None:
            result["warnings"] = [*hole.get("warnings", ()), mistake]
        if not in_frame:
            distance = math.dist(hole["center"], nominal.center)
            result["notes"] = [*hole.get("notes", ()), {"code": NOT_IN_SPEC_FRAME, "message": (
                f"tied to spec hole {nominal.name} but {distance:.4g} from its center (match radius "
                f"{nominal.match_radius:g}): the scan is in another frame, position and tilt not checked "
                f"(--registration maps the spec into the scan's frame)")}]
        if spec.decision_rule == "guarded" and result.get("conformance"):
            zone_notes = uncertainty_zone_notes(result["conformance"])
            if zone_notes:
                result["notes"] = [*(result.get("notes") or ()), *zone_notes]
        if nominal is not None:
            checked += 1
            failed += bool(result["failed_checks"])
            undecided += not result["failed_checks"] and bool(result["undecided_checks"])
        checked_holes.append(result)
    matched = {id(nominal) for nominal in assigned.values()}
    missing = [nominal.name for nominal in expected if id(nominal) not in matched]
    verdict = {"checked": checked, "out_of_tolerance": failed, "undecided": undecided, "missing": missing,
               "in_tolerance": failed == 0 and undecided == 0 and not missing,
               "decision_rule": spec.decision_rule, "coverage_factor": spec.coverage_factor}
    if declared is not None:  # (a spec without units: the verdict as before)
        verdict["spec_units"] = declared
        verdict["spec_units_assumed"] = assumed
    out = {}
    for key, value in record.items():
        out[key] = checked_holes if key == "holes" else value
        if key == "holes":
            out["verdict"] = verdict
        elif key == "options" and isinstance(value, dict):
            out[key] = {**value, "tolerances": describe(spec)}
    return out


# The note of a check whose expanded uncertainty leaves no value a guarded decision could pass.
UNCERTAINTY_NOTE = "uncertainty_exceeds_tolerance"


def uncertainty_exceeds_zone(entry):
    """Whether a check's expanded uncertainty ``U`` is too wide for its tolerance zone: no measured value
    could pass it under the guarded rule (``2U`` wider than a band ``upper - lower``; ``U`` above a
    largest value's ``upper``).

    Parameters
    ----------
    entry : dict
        A conformance entry (``lower``, ``upper``, ``expanded_uncertainty``).

    Returns
    -------
    bool
        False when ``U`` is not known.

    Examples
    --------
    >>> uncertainty_exceeds_zone({"lower": -0.02, "upper": 0.02, "expanded_uncertainty": 0.046})
    True
    >>> uncertainty_exceeds_zone({"lower": None, "upper": 0.1, "expanded_uncertainty": 0.004})
    False
    """
    expanded = entry.get("expanded_uncertainty")
    if expanded is None:
        return False
    if entry.get("lower") is None:
        return expanded > entry["upper"]
    return 2.0 * expanded > entry["upper"] - entry["lower"]


def uncertainty_zone_message(check, entry):
    """Why ``check`` can never pass under the guarded rule (:func:`uncertainty_exceeds_zone`), in words.

    Examples
    --------
    >>> uncertainty_zone_message("diameter", {"lower": -0.02, "upper": 0.02, "expanded_uncertainty": 0.046})
    'diameter: 2U = 0.092 is wider than its tolerance zone 0.04: a guarded decision can never pass it'
    """
    expanded = entry["expanded_uncertainty"]
    if entry.get("lower") is None:
        what = f"U = {expanded:.2g} exceeds its largest value {entry['upper']:.4g}"
    else:
        what = f"2U = {2.0 * expanded:.2g} is wider than its tolerance zone {entry['upper'] - entry['lower']:.4g}"
    return f"{check}: {what}: a guarded decision can never pass it"


def uncertainty_zone_notes(conformance):
    """The notes (:data:`UNCERTAINTY_NOTE`) of a hole's checks whose U exceeds their tolerance zone.

    Parameters
    ----------
    conformance : dict
        A checked hole's ``conformance``.

    Returns
    -------
    list of dict
        ``{"code", "message"}``, one per such check.
    """
    return [{"code": UNCERTAINTY_NOTE, "message": uncertainty_zone_message(check, entry)}
            for check, entry in conformance.items() if uncertainty_exceeds_zone(entry)]


def far_from_spec(record, spec):
    """``(distance, name)``: how far the nearest measured hole lies from the nearest spec hole, when holes
    were measured, every spec hole has a center and none of them was matched (all beyond their match
    radii: a scan in another frame or unit than the spec); else None.

    Parameters
    ----------
    record : dict
        A detect record, checked against ``spec`` (:func:`check`).
    spec : Spec

    Returns
    -------
    (float, str) or None
    """
    holes, verdict = record.get("holes") or [], record.get("verdict") or {}
    nominals = spec.holes
    if not holes or not nominals or verdict.get("checked") or any(n.center is None for n in nominals):
        return None
    distance, name = min((math.dist(hole["center"], nominal.center), nominal.name)
                         for hole in holes for nominal in nominals)
    return distance, name


def _tie(holes, nominals, tied) -> dict:
    """{measured index: nominal} of ``tied`` ({measured index: nominal name})."""
    by_name = {nominal.name: nominal for nominal in nominals}
    assigned = {}
    for index, name in tied.items():
        if not 0 <= index < len(holes):
            raise ValueError(f"tied hole {index} is not a measured hole (there are {len(holes)})")
        if name not in by_name:
            raise ValueError(f"tied to {name!r}, which is not a hole of the spec")
        assigned[index] = by_name[name]
    return assigned
def unit_scale_match(record, spec):
    """``(factor, scan_unit, spec_unit)`` when no measured hole lies near a spec hole (:func:`far_from_spec`)
    but every one of them would, the measured centers multiplied by a factor of units (1000, 25.4, ...,
    and their inverses): the scan and the spec in different units; else None.

    "Every one": as many pairs as the fewer of the measured and the spec holes (a scan may show part of
    the part) match within the spec holes' match radii, and at least one.

    Parameters
    ----------
    record : dict
        A detect record, checked against ``spec`` (:func:`check`).
    spec : Spec

    Returns
    -------
    (float, str, str) or None
        The factor the measured centers were multiplied by, the unit the scan would then be in and the
        spec's (e.g. ``(1000.0, "m", "mm")``).
    """
    if far_from_spec(record, spec) is None:
        return None
    holes = record["holes"]
    spec, _, _ = _spec_in_record_units(spec, record)
    wanted = min(len(holes), len(spec.holes))
    for factor, scan_unit, spec_unit in unit_factors():
        scaled = [{**hole, "center": [c * factor for c in hole["center"]]} for hole in holes]
        if len(_match(scaled, spec.holes)) == wanted:
            return factor, scan_unit, spec_unit
    return None


def spec_in_units(spec, units):
    """``spec`` with its lengths in ``units``, when it declares its own (:attr:`Spec.units`) and ``units``
    is known; else ``spec`` itself (a spec without units is in the scan's unit, whatever it is; a known
    spec unit against an unknown scan unit is taken as the scan's).

    Parameters
    ----------
    spec : Spec
    units : {"mm", "m", "in"} or None
        The scan's unit.

    Returns
    -------
    Spec
        Its ``units`` still the declared one (what the file said); angles, normals and names unchanged.
    """
    if spec.units is None or units is None:
        return spec
    factor = scale_factor(spec.units, units)
    if factor == 1.0:
        return spec
    return replace(spec, holes=tuple(_scaled_nominal(hole, factor) for hole in spec.holes))


def _spec_in_record_units(spec, record):
    """``(spec, record, assumed)``: ``spec`` with its lengths in the record's unit when it declares its own
    and the record says one; the record labelled with the spec's unit when it says none (``assumed``
    True: the spec's lengths are taken in the scan's unit, which is then said to be the spec's)."""
    if spec.units is None:
        return spec, record, False
    if record.get("units") is None:
        return spec, label_record(record, spec.units), True
    return spec_in_units(spec, record["units"]), record, False


# The lengths of a nominal hole (the others are angles, a direction and the name).
_NOMINAL_LENGTHS = ("diameter", "position_tolerance", "countersink_diameter", "countersink_depth", "bore_diameter",
                    "match_radius")
_NOMINAL_BANDS = ("band", "countersink_diameter_band", "countersink_depth_band", "bore_diameter_band")


def _scaled_nominal(hole, factor) -> NominalHole:
    """``hole`` with every length multiplied by ``factor`` (angles, the normal and the name as they are)."""
    values = {key: getattr(hole, key) * factor for key in _NOMINAL_LENGTHS if getattr(hole, key) is not None}
    values.update({key: Band(lower=getattr(hole, key).lower * factor, upper=getattr(hole, key).upper * factor)
                   for key in _NOMINAL_BANDS if getattr(hole, key) is not None})
    if hole.center is not None:
        values["center"] = tuple(c * factor for c in hole.center)
    return replace(hole, **values)


def _unit_mismatch_warning(hole, nominal, units=None, declared=None):
    """The ``unit_mismatch`` warning of a hole whose measured diameter is a unit's factor of its nominal
    (:func:`holecli.units.unit_mistake`), or None. ``units``: the record's unit (the tolerances are
    taken in it, unless the spec declared its own, ``declared``), which the advice then names."""
    if nominal is None or nominal.diameter is None:
        return None
    mistake = unit_mistake(hole.get("diameter"), nominal.diameter)
    if mistake is None:
        return None
    ratio, scan_unit, spec_unit = mistake
    if units is None:
        advice = (f"give --units {scan_unit} --output-units {spec_unit} (tolerances are in the output unit), or "
                  f"units = \"{spec_unit}\" in the spec file with --units {scan_unit}")
    elif declared is None:
        advice = (f"the record is in {units} and the tolerances are taken in it: give them in {units}, or "
                  f"--output-units {spec_unit} with --units {scan_unit} when the scan is in {scan_unit} "
                  f"(or units = \"{spec_unit}\" in the spec file)")
    else:
        advice = f"the spec says {declared} and the record is in {units}: check --units"
    return {"code": UNIT_MISMATCH,
            "message": f"measured diameter {hole['diameter']:.4g} is {ratio} of the nominal {nominal.diameter:.4g}: "
                       f"the scan may be in {scan_unit} and the tolerances in {spec_unit}; {advice}"}


def _match(holes, nominals) -> dict:
    """{measured index: nominal}: one-to-one by increasing distance for nominals with a center; a
    nominal without a center takes every hole."""
    assigned = {}
    pairs = []
    for n, nominal in enumerate(nominals):
        if nominal.center is None:
            return {index: nominal for index in range(len(holes))}
        for index, hole in enumerate(holes):
            distance = math.dist(hole["center"], nominal.center)
            if distance <= nominal.match_radius:
                pairs.append((distance, n, index))
    taken = set()
    for _, n, index in sorted(pairs):
        if n not in taken and index not in assigned:
            assigned[index] = nominals[n]
            taken.add(n)
    return assigned


def _verdict(hole, nominal, rule="simple", coverage_factor=DEFAULT_COVERAGE_FACTOR, in_frame=True) -> dict:
    """The verdict fields of ``hole`` against ``nominal``; without ``in_frame`` (a tied hole of a scan
    in another frame than the nominal's) no position and no tilt."""
    out = {"diameter_deviation": None, "position_deviation": None, "tilt_deg": None,
           **{f"{feature.name}_deviation": None for feature in _FEATURE_CHECKS}, "countersink_gauge_deviation": None,
           "in_tolerance": None, "failed_checks": None, "undecided_checks": None, "conformance": None}
    if nominal is None:
        return out
    uncertainty = hole.get("uncertainty") or {}
    conformance = {}

    def decide(name, value, lower, upper, size, nominal_u=None):
        expanded = _expanded_uncertainty(uncertainty, name, coverage_factor, hole.get("index"))
        if nominal_u is not None:  # the nominal's own (a registration's), in quadrature with the measurement's
            known = expanded is not None and math.isfinite(nominal_u)
            expanded = math.hypot(expanded, coverage_factor * nominal_u) if known else None
        conformance[name] = _decision(value, lower, upper, expanded, size, rule)
        if nominal_u is not None:
            conformance[name]["nominal_uncertainty"] = nominal_u if math.isfinite(nominal_u) else None

    if nominal.diameter is not None:
        deviation = hole["diameter"] - nominal.diameter
        out["diameter_deviation"] = deviation
        decide("diameter", deviation, nominal.band.lower, nominal.band.upper, nominal.diameter)
    normal = _unit(hole["normal"])
    if nominal.center is not None and in_frame:
        offset = [m - c for m, c in zip(hole["center"], nominal.center)]
        along = sum(o * n for o, n in zip(offset, normal))
        in_plane = math.hypot(*(o - along * n for o, n in zip(offset, normal)))
        out["position_deviation"] = {"in_plane": in_plane, "along_normal": along}
        if nominal.position_tolerance is not None:
            decide("position", in_plane, None, nominal.position_tolerance, nominal.position_tolerance,
                   _in_plane_uncertainty(nominal.center_covariance, normal))
    if nominal.normal is not None and in_frame:
        tilt = _line_angle_deg(normal, _unit(nominal.normal))
        out["tilt_deg"] = tilt
        if nominal.max_tilt is not None:
            decide("tilt", tilt, None, nominal.max_tilt, nominal.max_tilt, nominal.normal_uncertainty_deg)
    for feature in _FEATURE_CHECKS:
        nominal_value = getattr(nominal, feature.name)
        if nominal_value is None:
            continue
        part, key = feature.path
        measured = (hole.get(part) or {}).get(key)
        deviation = None if measured is None else measured - nominal_value
        out[f"{feature.name}_deviation"] = deviation
        band = getattr(nominal, f"{feature.name}_band")
        decide(feature.name, deviation, band.lower, band.upper, nominal_value)
    if nominal.countersink_gauge_diameter is not None:
        measured = (hole.get("countersink") or {}).get("diameter_at_depth")
        deviation = None if measured is None else measured - nominal.countersink_gauge_diameter
        out["countersink_gauge_deviation"] = deviation
        band = nominal.countersink_gauge_band
        decide("countersink_gauge", deviation, band.lower, band.upper, nominal.countersink_gauge_diameter)
    if nominal.max_perpendicularity is not None:
        decide("perpendicularity", hole.get("perpendicularity_deg"), None, nominal.max_perpendicularity,
               nominal.max_perpendicularity)
    out["failed_checks"] = [name + ("_not_measured" if entry["value"] is None else "")
                            for name, entry in conformance.items() if entry["decision"] == "fail"]
    out["undecided_checks"] = [name for name, entry in conformance.items() if entry["decision"] == "undecided"]
    out["in_tolerance"] = not out["failed_checks"] and not out["undecided_checks"]
    out["conformance"] = conformance
    return out


def _in_plane_uncertainty(covariance, normal):
    """The standard uncertainty of each coordinate, in the plane of unit ``normal``, of a point of 3x3
    ``covariance`` (as a hole's ``uncertainty.center_in_plane``): ``sqrt(trace(P C P) / 2)`` with
    ``P = I - n n^T``; None without a covariance, ``inf`` when it is not finite."""
    if covariance is None:
        return None
    values = [float(value) for row in covariance for value in row]
    if not all(math.isfinite(value) for value in values):
        return math.inf
    trace = values[0] + values[4] + values[8]
    along = sum(normal[i] * values[3 * i + j] * normal[j] for i in range(3) for j in range(3))
    return math.sqrt(max(trace - along, 0.0) / 2.0)


def _decision(value, lower, upper, expanded, size, rule) -> dict:
    """The conformance entry of one check: ``value`` against the zone ``[lower, upper]`` (``lower``
    None: no lower limit) by ``rule``, with the expanded uncertainty ``expanded`` (None: not known) and
    the round-off of a quantity of ``size``."""
    entry = {"value": value, "lower": lower, "upper": upper, "expanded_uncertainty": expanded}
    slack = _ROUND_OFF * size
    low = -math.inf if lower is None else lower - slack
    high = upper + slack
    if value is None:
        decision, reason = "fail", "not_measured"
    elif rule == "simple":
        decision, reason = ("pass", "inside") if low <= value <= high else ("fail", "outside")
    elif expanded is None:
        decision, reason = "undecided", "uncertainty_unknown"
    elif value - expanded > high or value + expanded < low:
        decision, reason = "fail", "outside_with_uncertainty"
    elif low <= value - expanded and value + expanded <= high:
        decision, reason = "pass", "inside_with_uncertainty"
    else:
        below, above = value - expanded < low, value + expanded > high
        decision = "undecided"
        reason = "straddles_both" if below and above else ("straddles_lower" if below else "straddles_upper")
    return {**entry, "decision": decision, "reason": reason}


def _expanded_uncertainty(uncertainty, check_name, coverage_factor, index):
    """``k * u`` of a check from a hole's ``uncertainty`` (a dict), or None when ``u`` is not known."""
    value = uncertainty
    path = _UNCERTAINTY_PATHS[check_name]
    for key in path:
        value = value.get(key) if isinstance(value, dict) else None
    if value is None:
        return None
    if spec_number(value) is None or value < 0:
        raise ValueError(f"hole {index}: uncertainty.{'.'.join(path)} must be a finite number >= 0, "
                         f"got {_shown(value)}")
    return coverage_factor * spec_number(value)


def _unit(vector):
    # Scaled first: the length of (1e308, 1e308, 0) overflows, and v / inf made it (0, 0, 0).
    largest = max(abs(v) for v in vector)
    scaled = [v / largest for v in vector]
    length = math.hypot(*scaled)
    return tuple(v / length for v in scaled)


def _digits(integer) -> int:
    """The number of decimal digits of ``integer`` (without str(): it refuses more than 4,300)."""
    return len(str(abs(integer))) if integer.bit_length() < 10_000 else int(integer.bit_length() * math.log10(2)) + 1


def _shown(value) -> str:
    """``repr(value)``, short: an integer of hundreds of digits is named by its size."""
    if isinstance(value, int) and not isinstance(value, bool) and spec_number(value) is None:
        return f"an integer of {_digits(value)} digits"
    text = repr(value)
    return text if len(text) <= 80 else text[:77] + "..."


def _line_angle_deg(a, b) -> float:
    """Angle between the lines of unit vectors ``a`` and ``b`` in [0, 90] degrees."""
    # atan2 of |cross| and |dot| stays accurate near 0 and 90 degrees, where acos and asin do not.
    cross = (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])
    return math.degrees(math.atan2(math.hypot(*cross), abs(sum(x * y for x, y in zip(a, b)))))
