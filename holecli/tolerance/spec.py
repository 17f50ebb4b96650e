"""The tolerance spec: its model (:class:`Band`, :class:`NominalHole`, :class:`Spec`) and the validation at
the boundary that builds it (:func:`parse_band`, :func:`nominal_spec`, :func:`parse_spec` of a TOML
file). See :mod:`holecli.tolerance` for the checks and what the keys mean."""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, replace
from typing import Optional

from holecli.errors import SpecError
from holecli.io.decimal_text import parse_decimal
from holecli.units import declared_units
from holecli.vocabulary import DECISION_RULES, DEFAULT_COVERAGE_FACTOR

__all__ = ["DECISION_RULES", "DEFAULT_COVERAGE_FACTOR", "Band", "NominalHole", "Spec", "gauge_checked", "load_toml", "nominal_spec", "parse_band", "parse_spec", "spec_number"]

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

# The decision rules of ISO 14253-1 that check() applies (DECISION_RULES), and the default coverage
# factor (k = 2), are holecli.vocabulary's: the command line reads them without importing this module.

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


def _digits(integer) -> int:
    """The number of decimal digits of ``integer`` (without str(): it refuses more than 4,300)."""
    return len(str(abs(integer))) if integer.bit_length() < 10_000 else int(integer.bit_length() * math.log10(2)) + 1


def _shown(value) -> str:
    """``repr(value)``, short: an integer of hundreds of digits is named by its size."""
    if isinstance(value, int) and not isinstance(value, bool) and spec_number(value) is None:
        return f"an integer of {_digits(value)} digits"
    text = repr(value)
    return text if len(text) <= 80 else text[:77] + "..."
