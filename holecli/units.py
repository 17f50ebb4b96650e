"""Length units: the file's (``--units``), the record's (``--output-units``), and the conversion of a record.

holecli measures in the units of the file; it never needs to know them. When they are known (given
with ``--units``, or declared by the format: E57 is in metres), a record can be converted into other
units by :func:`convert_record`, a pure function over the record dict: every length in it is
multiplied by one factor, angles, counts, unit vectors and flags stay as they are, and the record
says its unit in ``"units"``.

The lengths of a record (every other number is not one):

- ``plane.point``, ``plane.rms``;
- the provenance: ``options.min_diameter``, ``.min_diameter_effective``, ``.gauge_depth``;
  ``scales.point_spacing``, ``.gap_scale``, ``.line_pitch``, ``.period``, ``.height_noise``,
  ``.min_diameter`` (and ``scales.triangle_area_bound``, an area: by the factor squared);
- per hole: ``center``, ``diameter``, ``fit_rms``, ``max_residual``, ``roundness``,
  ``bias_correction``; ``countersink.diameter``, ``.depth``, ``.diameter_at_depth``, ``.gauge_depth``,
  ``.rms``; ``counterbore.diameter``, ``.depth``, ``.rms``; ``bore.diameter``, ``.rms``,
  ``.depth_range``, ``.floor_depth``, ``.floor_rms``; the verdict's ``diameter_deviation``,
  ``position_deviation`` (``in_plane``, ``along_normal``), ``countersink_diameter_deviation``,
  ``countersink_depth_deviation``, ``bore_diameter_deviation``; ``value``, ``lower``, ``upper`` and
  ``expanded_uncertainty`` of the ``conformance`` entries of the checks of lengths
  (:data:`LENGTH_CONFORMANCE_CHECKS`: not ``tilt``, ``countersink_angle`` and ``perpendicularity``,
  in degrees);
- per rejected candidate (``--explain``): ``center``, ``diameter``, ``shape.length``,
  ``shape.width``, and ``value`` and ``limit`` of the checks that compare lengths
  (:data:`LENGTH_CHECKS`).

Not converted: ``normal``, ``axis``, ``shape.direction`` (unit vectors), every ``..._deg`` and
``arc_deg`` and ``countersink_angle_deviation`` (degrees), counts, ``elapsed_ms``, and the text of
``warnings[].message`` and ``notes[].message``, which quote their numbers in file units.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass
from typing import Optional

from holecli.vocabulary import UNIT_MISMATCH

__all__ = ["LENGTH_CHECKS", "LENGTH_CONFORMANCE_CHECKS", "UNITS", "UNIT_MISMATCH", "UnitChoice", "convert_length",
           "convert_record", "declared_units", "label_record", "min_diameter_beyond_scan", "scale_factor",
           "table_decimals", "unit_factors", "unit_mistake"]

# Millimetres per unit.
UNITS = {"mm": 1.0, "m": 1000.0, "in": 25.4}

# The rejection checks whose value and limit are lengths (diameters, a scatter of radii); the other
# checks compare counts or degrees.
LENGTH_CHECKS = frozenset({"below_min_diameter", "not_round", "beyond_max_holes"})

# The tolerance checks (holecli.tolerance) whose conformance entries are lengths; the others, tilt,
# countersink_angle and perpendicularity, are in degrees.
LENGTH_CONFORMANCE_CHECKS = frozenset({"diameter", "position", "countersink_diameter", "countersink_depth",
                                       "bore_diameter"})
_CONFORMANCE_LENGTHS = ("value", "lower", "upper", "expanded_uncertainty", "nominal_uncertainty")

# Decimals of a length in ``--format table``: a tenth of a micrometre in mm and m; in inches 0.00001
# (a quarter of a micrometre, a step finer than inch gauges read).
_TABLE_DECIMALS = {"mm": 4, "m": 7, "in": 5}

_HOLE_LENGTHS = ("diameter", "fit_rms", "max_residual", "roundness", "bias_correction", "diameter_deviation",
                 "countersink_diameter_deviation", "countersink_depth_deviation", "bore_diameter_deviation")
# The lengths of a hole's uncertainty (its angles, normal_deg, angle_deg, axis_deg and
# perpendicularity_deg, are not scaled).
_UNCERTAINTY_LENGTHS = ("center_in_plane", "center_along_normal", "diameter")
_UNCERTAINTY_PART_LENGTHS = {
    "countersink": ("diameter", "depth", "diameter_at_depth"),
    "counterbore": ("diameter", "depth"),
    "bore": ("diameter", "floor_depth"),
}
_PART_LENGTHS = {
    "countersink": ("diameter", "depth", "diameter_at_depth", "gauge_depth", "rms"),
    "counterbore": ("diameter", "depth", "rms"),
    "bore": ("diameter", "rms", "depth_range", "floor_depth", "floor_rms"),
    "position_deviation": ("in_plane", "along_normal"),
}
# The provenance of the record (holecli.results.Options, Scales): lengths, and the one area.
_OPTION_LENGTHS = ("min_diameter", "min_diameter_effective", "gauge_depth")
_SCALE_LENGTHS = ("point_spacing", "gap_scale", "line_pitch", "period", "height_noise", "min_diameter")
_SCALE_AREAS = ("triangle_area_bound",)


def scale_factor(from_units, to_units) -> float:
    """The number a length in ``from_units`` is multiplied by to be in ``to_units``.

    Parameters
    ----------
    from_units, to_units : {"mm", "m", "in"}

    Returns
    -------
    float
        E.g. 1000.0 from ``"m"`` to ``"mm"``; exactly 1.0 for the same unit.

    Raises
    ------
    ValueError
        For a unit not in :data:`UNITS`.

    Examples
    --------
    >>> scale_factor("m", "mm"), scale_factor("in", "mm"), scale_factor("mm", "mm")
    (1000.0, 25.4, 1.0)
    """
    for unit in (from_units, to_units):
        if unit not in UNITS:
            raise ValueError(f"unknown unit {unit!r} (expected {', '.join(UNITS)})")
    if from_units == to_units:
        return 1.0
    return UNITS[from_units] / UNITS[to_units]


def convert_length(value, from_units, to_units):
    """One length (or None) from ``from_units`` into ``to_units``.

    Parameters
    ----------
    value : float or None
    from_units, to_units : {"mm", "m", "in"}

    Returns
    -------
    float or None

    Examples
    --------
    >>> convert_length(0.5, "mm", "m"), convert_length(None, "mm", "m")
    (0.0005, None)
    """
    return None if value is None else value * scale_factor(from_units, to_units)


def table_decimals(units) -> int:
    """The decimals ``--format table`` prints a length with, in ``units`` (4 when unknown).

    Parameters
    ----------
    units : {"mm", "m", "in"} or None

    Returns
    -------
    int

    Examples
    --------
    >>> table_decimals("mm"), table_decimals("m"), table_decimals("in"), table_decimals(None)
    (4, 7, 5, 4)
    """
    return _TABLE_DECIMALS.get(units, 4)


def label_record(record, units) -> dict:
    """A copy of ``record`` that says its unit: ``"units"`` after ``"method"`` (at the end when the
    record has no ``method``, an error record of ``holecli batch``).

    Parameters
    ----------
    record : dict
        A ``detect`` record.
    units : {"mm", "m", "in"}

    Returns
    -------
    dict
        The record, its keys in the same order, with ``"units"`` set (replaced when it was there).
    """
    out = {}
    for key, value in record.items():
        if key == "units":
            continue
        out[key] = value
        if key == "method":
            out["units"] = units
    out.setdefault("units", units)
    return out


def convert_record(record, from_units, to_units) -> dict:
    """``record`` with every length in ``to_units``, and ``"units": to_units``.

    A pure function: ``record`` is not changed. A record already holding ``"units"`` must hold
    ``from_units``.

    Parameters
    ----------
    record : dict
        A ``detect`` record (:meth:`holecli.Detection.to_dict`), with or without the tolerance
        verdicts of :func:`holecli.tolerance.check` and ``rejected``.
    from_units : {"mm", "m", "in"}
        The unit its lengths are in (the file's).
    to_units : {"mm", "m", "in"}
        The unit wanted.

    Returns
    -------
    dict
        A new record: the lengths listed in the module's docstring multiplied by
        :func:`scale_factor`, everything else as it was, ``"units"`` after ``"method"``.

    Raises
    ------
    ValueError
        For an unknown unit, or a record that says it is in another unit than ``from_units``.

    Examples
    --------
    >>> record = {"file": "a.ply", "method": "robust",
    ...           "plane": {"point": [1.0, 2.0, 0.5], "normal": [0.0, 0.0, 1.0], "rms": 0.001, "inliers": 9},
    ...           "holes": [], "elapsed_ms": 3.0}
    >>> converted = convert_record(record, "m", "mm")
    >>> converted["units"], converted["plane"]["point"], converted["plane"]["normal"], converted["elapsed_ms"]
    ('mm', [1000.0, 2000.0, 500.0], [0.0, 0.0, 1.0], 3.0)
    """
    factor = scale_factor(from_units, to_units)
    if record.get("units", from_units) != from_units:
        raise ValueError(f"the record is in {record['units']!r}, not {from_units!r}")
    out = copy.deepcopy(record)
    if factor != 1.0:
        plane = out.get("plane")
        if plane is not None:
            plane["point"] = _scaled(plane.get("point"), factor)
            plane["rms"] = _scaled(plane.get("rms"), factor)
        _scale_keys(out.get("options"), _OPTION_LENGTHS, factor)
        _scale_keys(out.get("scales"), _SCALE_LENGTHS, factor)
        _scale_keys(out.get("scales"), _SCALE_AREAS, factor * factor)
        for hole in out.get("holes", ()):
            _scale_hole(hole, factor)
        for rejection in out.get("rejected", ()):
            _scale_rejection(rejection, factor)
    return label_record(out, to_units)


def _scale_keys(mapping, keys, factor):
    """Scale the values of ``keys`` that ``mapping`` (a dict, or None) holds, in place."""
    for key in keys:
        if mapping and key in mapping:
            mapping[key] = _scaled(mapping[key], factor)


def _scale_hole(hole, factor):
    _scale_keys(hole, ("center",) + _HOLE_LENGTHS, factor)
    for part, keys in _PART_LENGTHS.items():
        _scale_keys(hole.get(part), keys, factor)
    uncertainty = hole.get("uncertainty")
    if uncertainty:
        _scale_keys(uncertainty, _UNCERTAINTY_LENGTHS, factor)
        for part, keys in _UNCERTAINTY_PART_LENGTHS.items():
            _scale_keys(uncertainty.get(part), keys, factor)
    for check, entry in (hole.get("conformance") or {}).items():
        if check in LENGTH_CONFORMANCE_CHECKS:
            _scale_keys(entry, _CONFORMANCE_LENGTHS, factor)


def _scale_rejection(rejection, factor):
    rejection["center"] = _scaled(rejection.get("center"), factor)
    rejection["diameter"] = _scaled(rejection.get("diameter"), factor)
    if rejection.get("check") in LENGTH_CHECKS:
        rejection["value"] = _scaled(rejection.get("value"), factor)
        rejection["limit"] = _scaled(rejection.get("limit"), factor)
    _scale_keys(rejection.get("shape"), ("length", "width"), factor)


def _scaled(value, factor):
    """A length, a list of lengths, or None, times ``factor``."""
    if value is None:
        return None
    if isinstance(value, (list, tuple)):
        return [None if item is None else float(item) * factor for item in value]
    return float(value) * factor


@dataclass(frozen=True)
class UnitChoice:
    """The units of a run: the file's, declared with ``--units``, and the record's, ``--output-units``.

    Attributes
    ----------
    file : {"mm", "m", "in"} or None
        The unit of the files' coordinates; None: the unit the format declares (E57: metres), or
        unknown.
    output : {"mm", "m", "in"} or None
        The unit of the records; None: the file's.
    """

    file: Optional[str] = None
    output: Optional[str] = None

    def express(self, record, declared=None) -> dict:
        """``record`` in the run's output unit, saying its unit when it is known.

        Parameters
        ----------
        record : dict
            A ``detect`` record in the file's units, before any tolerance check.
        declared : str or None
            The unit the file's format declares (:attr:`holecli.io.Cloud.units`).

        Returns
        -------
        dict
            :func:`convert_record` into :attr:`output`; else the record with ``"units"`` when the
            file's unit is known (:attr:`file`, else ``declared``); else ``record`` itself.

        Raises
        ------
        ValueError
            When an output unit is asked for but the file's unit is not known.
        """
        source = self.file or declared
        if self.output is not None:
            if source is None:
                raise ValueError("the file's unit is not known (give --units)")
            return convert_record(record, source, self.output)
        return record if source is None else label_record(record, source)

    def to_file_units(self, length):
        """A length given in the output unit (a command-line option) in the file's unit.

        Parameters
        ----------
        length : float or None

        Returns
        -------
        float or None
            ``length`` itself without an output unit.
        """
        if length is None or self.output is None or self.file is None:
            return length
        return convert_length(length, self.output, self.file)


# --------------------------------------------------------------------------------------------------
# Declared units of the files a run reads (spec, panel), and the mistakes of units a result betrays

# The warning a hole gets when its measured diameter is a unit's factor off its nominal
# (:func:`unit_mistake`): in ``holes[].warnings``, on stderr, and a code ``--fail-on-warning`` takes,
# is holecli.vocabulary.UNIT_MISMATCH.

# How close a ratio of a measured to a nominal length must come to a factor of units to be named a
# likely unit mistake: 1 % (a hole is never 25 or 1000 times its nominal size by a drilling error, and a
# diameter 1 % off is far outside any tolerance; within 1 % the factor is unmistakable).
UNIT_MISTAKE_TOLERANCE = 0.01


def declared_units(data, what="spec"):
    """The ``units`` a TOML file declares at its top (``units = "in"``), or None; the key is removed.

    Parameters
    ----------
    data : dict
        The file's data (:func:`holecli.tolerance.load_toml`); ``units`` is popped from it.
    what : str
        What the file is, for the message.

    Returns
    -------
    {"mm", "m", "in"} or None

    Raises
    ------
    ValueError
        For a ``units`` that is not one of :data:`UNITS`.

    Examples
    --------
    >>> data = {"units": "in", "hole": []}
    >>> declared_units(data), data
    ('in', {'hole': []})
    >>> declared_units({"hole": []}) is None
    True
    """
    if "units" not in data:
        return None
    value = data.pop("units")
    if not isinstance(value, str) or value not in UNITS:
        shown = repr(value) if isinstance(value, str) else f"{type(value).__name__} {value!r}"[:80]
        raise ValueError(f"units must be one of {', '.join(repr(unit) for unit in UNITS)} (the unit of every "
                         f"length of the {what}), got {shown}")
    return value


def _unit_pairs():
    """(factor, larger unit, smaller unit) for every pair of units with a factor other than 1."""
    pairs = []
    for big in UNITS:
        for small in UNITS:
            if UNITS[big] > UNITS[small]:
                pairs.append((UNITS[big] / UNITS[small], big, small))
    return sorted(pairs)


def unit_mistake(measured, nominal):
    """The unit mistake that would make ``measured`` of ``nominal``: its ratio a factor of units.

    Parameters
    ----------
    measured, nominal : float
        A measured length and its nominal (> 0), in the units the run took them in.

    Returns
    -------
    (str, str, str) or None
        ``(ratio, scan_unit, spec_unit)``: the ratio as said (``"1/1000"``, ``"25.4x"``) and the units
        that would explain it (the measured value in ``scan_unit``, the nominal in ``spec_unit``), when
        ``measured / nominal`` is within :data:`UNIT_MISTAKE_TOLERANCE` of 1000, 1/1000, 25.4, 1/25.4
        (or 39.37, 1/39.37: m and in); else None.

    Examples
    --------
    >>> unit_mistake(0.006, 6.0)
    ('1/1000', 'm', 'mm')
    >>> unit_mistake(76.2, 3.0)
    ('25.4x', 'mm', 'in')
    >>> unit_mistake(3.01, 3.0) is None
    True
    """
    if not measured or not nominal or measured <= 0 or nominal <= 0:
        return None
    ratio = measured / nominal
    for factor, big, small in _unit_pairs():
        shown = f"{factor:g}"
        if abs(ratio / factor - 1.0) <= UNIT_MISTAKE_TOLERANCE:
            return f"{shown}x", small, big  # measured many times the nominal: the scan in the smaller unit
        if abs(ratio * factor - 1.0) <= UNIT_MISTAKE_TOLERANCE:
            return f"1/{shown}", big, small
    return None


def unit_factors():
    """The factors between the units, both ways (25.4, 1/25.4, 1000, ...), with the pair they convert.

    Returns
    -------
    list of (float, str, str)
        ``(factor, from_unit, to_unit)``: a length in ``from_unit`` times ``factor`` is in ``to_unit``.
    """
    return [(factor, big, small) for factor, big, small in _unit_pairs()] + \
        [(1.0 / factor, small, big) for factor, big, small in _unit_pairs()]


def min_diameter_beyond_scan(min_diameter, points, point_spacing):
    """The scan's size when ``min_diameter`` exceeds it (no hole of that size fits in the scan): a hint
    that ``--min-diameter`` is in another unit than the scan; else None.

    The size is that of a square holding ``points`` points at ``point_spacing`` (the median distance of
    neighbours): ``sqrt(points) * point_spacing``, the side of the scanned area, which a hole, a void in
    it, is smaller than.

    Parameters
    ----------
    min_diameter : float or None
        ``--min-diameter`` as given (in the scan's unit); None: not given.
    points : int
    point_spacing : float or None

    Returns
    -------
    float or None

    Examples
    --------
    >>> round(min_diameter_beyond_scan(2.0, 10000, 0.0002), 6)
    0.02
    >>> min_diameter_beyond_scan(2.0, 10000, 0.2) is None
    True
    """
    if min_diameter is None or not point_spacing or points <= 0:
        return None
    size = math.sqrt(points) * point_spacing
    return size if min_diameter > size else None
