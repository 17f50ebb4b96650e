"""Detection results as machine-readable text: JSON, JSON Lines and CSV, on a stream passed in."""

from __future__ import annotations

import csv
import io
import json

# Columns of the CSV output, in order; docs/reference/output.md documents each. The tolerance columns are empty
# unless tolerance options or a spec file were given.
CSV_COLUMNS = (
    "file", "hole", "center_x", "center_y", "center_z", "diameter", "normal_x", "normal_y", "normal_z",
    "rim_points", "fit_rms", "max_residual", "roundness", "bias_correction", "partial", "arc_deg",
    "scan_lines", "type", "countersink_diameter", "countersink_angle_deg", "countersink_depth",
    "countersink_diameter_at_depth", "countersink_rms", "counterbore_diameter", "counterbore_depth",
    "bore_diameter", "bore_rms", "floor_depth", "axis_x", "axis_y", "axis_z", "perpendicularity_deg", "warnings",
    "name", "diameter_deviation", "position_in_plane", "position_along_normal", "tilt_deg",
    "countersink_diameter_deviation", "countersink_angle_deviation", "countersink_depth_deviation",
    "bore_diameter_deviation",
    "in_tolerance", "failed_checks",
) + (
    # The provenance of the row's record (the same in every row of a record): its schema and holecli
    # version, the options in effect, the tolerances' source, the measured scales. Columns rather than
    # a sidecar file or comment lines: every row stays self-contained (a CSV read from stdout, one
    # appended to by batch --resume, one filtered by grep), and a CSV reader needs nothing special.
    "schema_version", "holecli_version", "units", "method", "view_dir", "min_diameter", "min_diameter_effective",
    "max_holes", "full_only", "gauge_depth", "rng", "settings", "input_format", "scan", "spec_file", "spec_sha256", "nominal",
    "point_spacing", "gap_scale", "line_pitch", "period", "lattice", "height_noise", "triangle_area_bound",
    "candidates",
) + (
    # The decision rules (ISO 14253-1), after the older columns, which keep their positions: the
    # undecided checks, the conformance of every check as compact JSON (value, limits, U, decision),
    # and, with the provenance, options.tolerances' decision_rule and coverage_factor.
    "undecided_checks", "conformance", "decision_rule", "coverage_factor",
) + (
    # The notes' codes (schema 2.2: why a value is null, out of warnings), after the older columns too.
    "notes",
) + (
    # The standard uncertainties (k = 1) of the hole's values, the JSON's holes[].uncertainty (issue 25),
    # after the older columns too; uncertainty_estimator says what measured the edge.
    "u_center_in_plane", "u_center_along_normal", "u_diameter", "u_normal_deg",
    "u_countersink_diameter", "u_countersink_angle_deg", "u_countersink_depth", "u_countersink_diameter_at_depth",
    "u_counterbore_diameter", "u_counterbore_depth", "u_bore_diameter", "u_floor_depth", "u_axis_deg",
    "u_perpendicularity_deg", "uncertainty_estimator",
) + (
    # The countersink gauge check's deviation (issue 25), after the older columns too.
    "countersink_gauge_deviation",
)

# The columns of the provenance that come from the record's options and scales.
_OPTION_COLUMNS = ("method", "view_dir", "min_diameter", "min_diameter_effective", "max_holes", "full_only",
                   "gauge_depth", "rng", "settings", "input_format", "scan")
_TOLERANCE_COLUMNS = ("spec_file", "spec_sha256", "nominal", "decision_rule", "coverage_factor")
_SCALE_COLUMNS = ("point_spacing", "gap_scale", "line_pitch", "period", "lattice", "height_noise",
                  "triangle_area_bound")

# ``holecli batch`` adds the message of a file that could not be measured, and the file's resolved
# absolute path (what --resume matches on).
BATCH_CSV_COLUMNS = CSV_COLUMNS + ("error", "path")

# The u_* columns from holes[].uncertainty: column -> (sub-object or None, key).
_UNCERTAINTY_COLUMNS = {
    "u_center_in_plane": (None, "center_in_plane"), "u_center_along_normal": (None, "center_along_normal"),
    "u_diameter": (None, "diameter"), "u_normal_deg": (None, "normal_deg"),
    "u_countersink_diameter": ("countersink", "diameter"), "u_countersink_angle_deg": ("countersink", "angle_deg"),
    "u_countersink_depth": ("countersink", "depth"),
    "u_countersink_diameter_at_depth": ("countersink", "diameter_at_depth"),
    "u_counterbore_diameter": ("counterbore", "diameter"), "u_counterbore_depth": ("counterbore", "depth"),
    "u_bore_diameter": ("bore", "diameter"), "u_floor_depth": ("bore", "floor_depth"),
    "u_axis_deg": (None, "axis_deg"), "u_perpendicularity_deg": (None, "perpendicularity_deg"),
    "uncertainty_estimator": (None, "estimator"),
}


def csv_fields(text, columns=CSV_COLUMNS):
    """The CSV columns that ``--fields`` names, in its order.

    Parameters
    ----------
    text : str
        Comma-separated column names (:data:`CSV_COLUMNS`, and for a batch ``error`` and ``path``);
        spaces around a name are ignored.
    columns : sequence of str
        The columns that may be named.

    Returns
    -------
    tuple of str

    Raises
    ------
    ValueError
        When a name is not a column, is given twice, or none is given; the message lists the valid names.

    Examples
    --------
    >>> csv_fields("file, hole,diameter,u_diameter")
    ('file', 'hole', 'diameter', 'u_diameter')
    """
    names = [name.strip() for name in text.split(",")]
    unknown = [name for name in names if name not in columns]
    if not any(names) or unknown:
        what = "no field named" if not any(names) else \
            f"unknown field{'s' if len(unknown) > 1 else ''} {', '.join(repr(name) for name in unknown)}"
        raise ValueError(f"{what}; valid fields: {','.join(columns)}")
    twice = sorted({name for name in names if names.count(name) > 1})
    if twice:
        raise ValueError(f"field {twice[0]!r} given twice")
    return tuple(names)


def to_json(record):
    """One record (a dict) as indented JSON text with a trailing newline; floats at full precision.

    Parameters
    ----------
    record : dict
        A JSON-ready record (:meth:`holecli.results.Detection.to_dict`, possibly with verdicts).

    Returns
    -------
    str
        The JSON text, indented by 2, ending in a newline.

    Raises
    ------
    ValueError
        When the record holds a NaN or an infinity (JSON has neither).
    """
    return json.dumps(record, indent=2, allow_nan=False) + "\n"


def to_json_line(record):
    """One record as a single line of JSON (for JSON Lines output).

    Parameters
    ----------
    record : dict
        A JSON-ready record.

    Returns
    -------
    str
        Compact JSON on one line, ending in a newline.

    Raises
    ------
    ValueError
        When the record holds a NaN or an infinity (JSON has neither).
    """
    return json.dumps(record, separators=(",", ":"), allow_nan=False) + "\n"


def csv_cell(value):
    """A value as a CSV cell of holecli: empty for None, ``true``/``false``, a float at full precision
    (``repr``), a list joined by ``;``, a dict as compact JSON."""
    if value is None:
        return ""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return repr(value)
    if isinstance(value, (list, tuple)):
        # failed_checks, warnings, notes, view_dir: a few words or numbers, never holding the separator
        return ";".join(repr(item) if isinstance(item, float) else str(item) for item in value)
    if isinstance(value, dict):
        # settings, nominal, conformance: compact JSON in one cell
        return json.dumps(value, separators=(",", ":"), allow_nan=False)
    return str(value)


def _provenance(record):
    """The provenance cells of a record by column name (:data:`CSV_COLUMNS`)."""
    options = record.get("options") or {}
    tolerances = options.get("tolerances") or {}
    scales = record.get("scales") or {}
    values = {"schema_version": record.get("schema_version"), "holecli_version": record.get("holecli_version"),
              "units": record.get("units"), "candidates": record.get("candidates")}
    values.update((name, options.get(name)) for name in _OPTION_COLUMNS)
    values.update((name, tolerances.get(name)) for name in _TOLERANCE_COLUMNS)
    values.update((name, scales.get(name)) for name in _SCALE_COLUMNS)
    return values


def csv_rows(record, columns=CSV_COLUMNS):
    """CSV rows (lists of str) for one record.

    One row per hole; with tolerance verdicts also one row per missing nominal hole (empty ``hole``,
    ``in_tolerance`` false); one row with only ``file`` (and ``error`` for a failed file of a batch)
    when the record has neither.

    Parameters
    ----------
    record : dict
        A detection record (with tolerance verdicts, a batch's ``error`` and ``path`` when present).
    columns : sequence of str
        The columns to write, in order (:data:`CSV_COLUMNS` or :data:`BATCH_CSV_COLUMNS`).

    Returns
    -------
    list of list of str
        One list of cells per row, in ``columns`` order: empty for None, ``true``/``false`` for
        booleans, floats by ``repr``, lists joined with ``;``.
    """
    file, path = record.get("file"), record.get("path")
    provenance = _provenance(record)
    rows = []
    for hole in record.get("holes", []):
        values = dict(hole, **provenance, file=file, path=path, hole=hole.get("index"))
        for axis, name in enumerate("xyz"):
            values[f"center_{name}"] = hole["center"][axis]
            values[f"normal_{name}"] = hole["normal"][axis]
        countersink, counterbore, bore = (hole.get(key) or {} for key in ("countersink", "counterbore", "bore"))
        values.update({"countersink_diameter": countersink.get("diameter"),
                       "countersink_angle_deg": countersink.get("angle_deg"),
                       "countersink_depth": countersink.get("depth"),
                       "countersink_diameter_at_depth": countersink.get("diameter_at_depth"),
                       "countersink_rms": countersink.get("rms"),
                       "counterbore_diameter": counterbore.get("diameter"), "counterbore_depth": counterbore.get("depth"),
                       "bore_diameter": bore.get("diameter"), "bore_rms": bore.get("rms"),
                       "floor_depth": bore.get("floor_depth"),
                       "warnings": [warning["code"] for warning in hole.get("warnings", [])],
                       "notes": [note["code"] for note in hole.get("notes", [])]})
        for axis, name in enumerate("xyz"):
            values[f"axis_{name}"] = None if hole.get("axis") is None else hole["axis"][axis]
        uncertainty = hole.get("uncertainty") or {}
        for column, (part, key) in _UNCERTAINTY_COLUMNS.items():
            values[column] = (uncertainty if part is None else uncertainty.get(part) or {}).get(key)
        position = hole.get("position_deviation") or {}
        values["position_in_plane"] = position.get("in_plane")
        values["position_along_normal"] = position.get("along_normal")
        rows.append(values)
    for name in record.get("verdict", {}).get("missing", []):
        rows.append({**provenance, "file": file, "path": path, "name": name, "in_tolerance": False})
    if not rows:
        rows.append({**provenance, "file": file, "path": path, "error": record.get("error")})
    return [[csv_cell(values.get(column)) for column in columns] for values in rows]


def csv_text(records, columns=CSV_COLUMNS, header=True):
    """The CSV text of ``records``: the header (optionally) and their rows.

    Parameters
    ----------
    records : iterable of dict
        Detection records, see :func:`csv_rows`.
    columns : sequence of str
        The columns to write, in order.
    header : bool
        Whether the first line names the columns.

    Returns
    -------
    str
        The CSV text, lines ending in ``\\n``.
    """
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    if header:
        writer.writerow(columns)
    for record in records:
        writer.writerows(csv_rows(record, columns))
    return buffer.getvalue()


def write_csv(records, stream, header=True, columns=CSV_COLUMNS):
    """Write the CSV header (optionally) and the rows of every record to ``stream``.

    Parameters
    ----------
    records : iterable of dict
        Detection records, see :func:`csv_rows`.
    stream : text file
        Where to write (anything with ``write(str)``).
    header : bool
        Whether the first line names the columns.
    columns : sequence of str
        The columns to write, in order.

    Returns
    -------
    None
    """
    stream.write(csv_text(records, columns, header))
