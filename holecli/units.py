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
from dataclasses import dataclass
from typing import Optional

__all__ = ["LENGTH_CHECKS", "LENGTH_CONFORMANCE_CHECKS", "UNITS", "UnitChoice", "convert_length", "convert_record",
           "label_record", "scale_factor", "table_decimals"]

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
