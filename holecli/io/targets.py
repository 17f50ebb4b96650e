"""Drilling targets (``holecli register --targets``): a strict CSV in, the corrected targets out.

Input: a header row ``name,x,y,z,nx,ny,nz`` exactly, then one row per target: a name (unique, not
empty, no surrounding spaces), the point and its normal in the part (CAD) frame as plain decimals
(:func:`holecli.io.decimal_text.parse_decimal`: no ``inf``, ``nan``, ``1_0``). The normal must not be
zero and is normalised. Blank lines are skipped; anything else that is not such a row is refused with
the line's number. Before the header, one line ``# units = mm`` (``m``, ``in``; quoted or not) may
declare the unit of the points (:attr:`Targets.units`; ``holecli register`` converts them into the
scans' unit).

Output (:func:`format_targets`): the header :data:`TARGET_COLUMNS`, then one row per target in the
measuring frame: ``name,x,y,z,nx,ny,nz,u_x,u_y,u_z,u_normal_deg``. ``u_x, u_y, u_z`` are the standard
uncertainties (coverage factor 1) of the point's coordinates from the transform's covariance,
``u_normal_deg`` that of the normal's direction in degrees; ``inf`` where a degree of freedom the
holes leave free moves the target, ``nan`` where the covariance is not known (as many residual
components as parameters). Numbers are written with full precision (``repr``).
"""

from __future__ import annotations

import csv
import io
import math
import re
from dataclasses import dataclass
from typing import Optional

import numpy as np

from holecli.errors import LoadError
from holecli.io.decimal_text import parse_decimal

__all__ = ["INPUT_COLUMNS", "TARGET_COLUMNS", "Targets", "format_targets", "parse_targets", "read_targets"]

INPUT_COLUMNS = ("name", "x", "y", "z", "nx", "ny", "nz")
TARGET_COLUMNS = ("name", "x", "y", "z", "nx", "ny", "nz", "u_x", "u_y", "u_z", "u_normal_deg")
# A targets file lists the points of one robot program: thousands at most.
MAX_TARGETS_BYTES = 16 << 20


@dataclass(frozen=True, eq=False)
class Targets:
    """Nominal drilling points with their normals, in the part frame.

    Attributes
    ----------
    names : tuple of str
    points : (n, 3) float
        File units.
    normals : (n, 3) float
        Unit vectors.
    units : {"mm", "m", "in"} or None
        The unit the file declares for its points (``# units = mm`` before the header); None: not
        declared (the unit of the spec and the scans).
    """

    names: tuple
    points: np.ndarray
    normals: np.ndarray
    units: Optional[str] = None


def parse_targets(text, source="targets"):
    """The targets of the text of a targets CSV (see the module docstring).

    Parameters
    ----------
    text : str
    source : str
        The file's name, for messages.

    Returns
    -------
    Targets

    Raises
    ------
    LoadError
        ``<source>: line N: <problem>`` for a wrong header, a row of the wrong length, a number that is
        not a plain finite decimal, a zero normal, an empty or repeated name; ``<source>: no target``
        for a file with the header only.
    """
    text, units = _declared_units(text, source)
    rows = csv.reader(io.StringIO(text, newline=""))
    header_seen = False
    names, points, normals, seen = [], [], [], {}
    try:
        for row in rows:
            line = rows.line_num
            if not row or all(not cell.strip() for cell in row):
                continue
            if not header_seen:
                cells = [cell.strip() for cell in row]
                if line == 1 and cells and cells[0].startswith("\ufeff"):
                    cells[0] = cells[0][1:]
                if tuple(cells) != INPUT_COLUMNS:
                    raise LoadError(source, f"line {line}: expected the header {','.join(INPUT_COLUMNS)}, "
                                            f"got {','.join(row)[:80]!r}")
                header_seen = True
                continue
            if len(row) != len(INPUT_COLUMNS):
                raise LoadError(source, f"line {line}: expected {len(INPUT_COLUMNS)} fields "
                                        f"({','.join(INPUT_COLUMNS)}), got {len(row)}")
            name = row[0]
            if not name.strip():
                raise LoadError(source, f"line {line}: empty name")
            if name != name.strip() or not name.isprintable():
                raise LoadError(source, f"line {line}: the name {name!r} starts or ends with spaces or holds "
                                        "control characters")
            if name in seen:
                raise LoadError(source, f"line {line}: the name {name!r} is used twice (first on line {seen[name]})")
            values = []
            for column, cell in zip(INPUT_COLUMNS[1:], row[1:]):
                try:
                    values.append(parse_decimal(cell.strip()))
                except ValueError:
                    raise LoadError(source, f"line {line}: {column} {cell!r} is not a finite decimal number") from None
            normal = np.array(values[3:])
            length = float(np.linalg.norm(normal))
            if not length > 0 or not math.isfinite(length):
                raise LoadError(source, f"line {line}: the normal of {name!r} is zero")
            seen[name] = line
            names.append(name)
            points.append(values[:3])
            normals.append(normal / length)
    except csv.Error as error:
        raise LoadError(source, f"line {rows.line_num}: not valid CSV: {error}") from None
    if not header_seen:
        raise LoadError(source, f"empty: expected the header {','.join(INPUT_COLUMNS)} and one row per target")
    if not names:
        raise LoadError(source, "no target: expected at least one row after the header")
    return Targets(tuple(names), np.array(points, dtype=np.float64), np.array(normals, dtype=np.float64), units)


_UNITS_LINE = re.compile(r"#\s*units\s*=\s*(.*?)\s*")


def _declared_units(text, source):
    """``(text, units)``: the text with its ``# units = ...`` line blanked (the line numbers stay), and the
    unit it declares (None without one). Only the first line that is not blank may declare it."""
    from holecli.units import UNITS

    lines = text.splitlines(keepends=True)
    for number, line in enumerate(lines, start=1):
        stripped = line.strip().lstrip("\ufeff")
        if not stripped:
            continue
        match = _UNITS_LINE.fullmatch(stripped)
        if match is None:
            return text, None
        value = match.group(1)
        if len(value) >= 2 and value[0] == value[-1] and value[0] in "\"'":
            value = value[1:-1]
        if value not in UNITS:
            raise LoadError(source, f"line {number}: units must be one of {', '.join(UNITS)}, got {value!r}")
        lines[number - 1] = "\n"
        return "".join(lines), value
    return text, None


def read_targets(path):
    """The targets of a targets CSV file (:func:`parse_targets` of its UTF-8 text).

    Parameters
    ----------
    path : str or os.PathLike

    Returns
    -------
    Targets

    Raises
    ------
    LoadError
        When the file is missing, not a regular file, too large (:data:`MAX_TARGETS_BYTES`), not UTF-8,
        or not a valid targets file.
    """
    import os
    import stat

    name = str(path)
    try:
        status = os.stat(path)
        if not stat.S_ISREG(status.st_mode):
            raise LoadError(name, "not a regular file: a targets file must be a CSV file")
        if status.st_size > MAX_TARGETS_BYTES:
            raise LoadError(name, f"{status.st_size} bytes is too large for a targets file "
                                  f"(at most {MAX_TARGETS_BYTES} bytes)")
        with open(path, "rb") as stream:
            data = stream.read(MAX_TARGETS_BYTES + 1)
    except OSError as error:
        raise LoadError(name, f"cannot read: {error.strerror or error}") from None
    if len(data) > MAX_TARGETS_BYTES:
        raise LoadError(name, f"too large for a targets file (more than {MAX_TARGETS_BYTES} bytes)")
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        raise LoadError(name, "not a UTF-8 text file") from None
    return parse_targets(text, source=name)


def _number(value):
    return repr(float(value))  # full precision; nan, inf and -inf as such


def format_targets(rows, columns=TARGET_COLUMNS):
    """The corrected targets as CSV text (or, with ``columns`` :data:`INPUT_COLUMNS`, nominal ones,
    as :func:`parse_targets` reads them).

    Parameters
    ----------
    rows : iterable of dict
        With the keys of ``columns`` (``x``... as floats), as
        :meth:`holecli.registration.register.Registration.corrected_targets` returns them.
    columns : sequence of str
        ``name`` first, then the numbers.

    Returns
    -------
    str
        The header and one line per row, ``\\n`` line ends.
    """
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(columns)
    for row in rows:
        writer.writerow([row["name"], *(_number(row[column]) for column in columns[1:])])
    return buffer.getvalue()
