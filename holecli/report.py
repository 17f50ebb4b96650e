"""Detection results as machine-readable text: JSON, JSON Lines and CSV, on a stream passed in."""

from __future__ import annotations

import csv
import json

# Columns of the CSV output, in order; the README documents each.
CSV_COLUMNS = (
    "file", "hole", "center_x", "center_y", "center_z", "diameter", "normal_x", "normal_y", "normal_z",
    "rim_points", "fit_rms", "max_residual", "roundness", "bias_correction", "partial", "arc_deg",
    "scan_lines",
)


def to_json(record):
    """One record (a dict) as indented JSON text with a trailing newline; floats at full precision."""
    return json.dumps(record, indent=2, allow_nan=False) + "\n"


def to_json_line(record):
    """One record as a single line of JSON (for JSON Lines output)."""
    return json.dumps(record, separators=(",", ":"), allow_nan=False) + "\n"


def _cell(value):
    if value is None:
        return ""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return repr(value)
    return str(value)


def csv_rows(record):
    """CSV rows (lists of str, one per hole) for one detection record; one row with empty hole fields
    when the record has no hole."""
    rows = []
    for hole in record.get("holes", []):
        values = {
            "file": record.get("file"),
            "hole": hole.get("index"),
            "center_x": hole["center"][0],
            "center_y": hole["center"][1],
            "center_z": hole["center"][2],
            "diameter": hole["diameter"],
            "normal_x": hole["normal"][0],
            "normal_y": hole["normal"][1],
            "normal_z": hole["normal"][2],
        }
        for column in CSV_COLUMNS:
            values.setdefault(column, hole.get(column))
        rows.append([_cell(values[column]) for column in CSV_COLUMNS])
    if not rows:
        rows.append([_cell(record.get("file"))] + [""] * (len(CSV_COLUMNS) - 1))
    return rows


def write_csv(records, stream, header=True):
    """Write the CSV header (optionally) and the rows of every record to ``stream``."""
    writer = csv.writer(stream, lineterminator="\n")
    if header:
        writer.writerow(CSV_COLUMNS)
    for record in records:
        writer.writerows(csv_rows(record))
