"""Text tables (``.csv``, ``.txt``, ``.xyz``): reading and writing.

:func:`read_table` finds the delimiter (semicolon, comma, tab or whitespace), an optional header
row naming x, y, z, and the columns from the first lines, then reads the table with numpy, falling
back to a row-by-row reader that names the line of any problem. Called through
:func:`holecli.io.read_cloud`.
"""

from __future__ import annotations

import csv
import re
from dataclasses import dataclass
from typing import Optional

import numpy as np

from holecli.io._common import _BadFile, _loadtxt, _quote


@dataclass(frozen=True)
class _TableLayout:
    header_line: int  # 1-based line number of the header row, 0 when there is none
    delimiter: Optional[str]  # ",", ";", "\t", or None for runs of whitespace
    columns: tuple  # indices of the x, y, z columns


# A row of a point table is at most a few hundred characters. A much longer line is not a table (and
# the csv module refuses a field over 131,072 characters); this limit keeps it a one-line error.
_MAX_LINE_BYTES = 1 << 16
_LINE_BREAK = re.compile(rb"\r\n|\r|\n")


def read_table(name: str) -> np.ndarray:
    """Read x, y, z from a delimited text table (.csv, .txt, .xyz).

    Parameters
    ----------
    name : str
        The file's path; the file exists and is not empty.

    Returns
    -------
    points : (n, 3) float64 ndarray
        One row per non-blank, non-comment data row, n >= 1, non-finite rows included.

    Raises
    ------
    _BadFile
        If the file is not a text table, has fewer than 3 columns or no x, y, z columns, a header
        that does not fit the rows, a short row, a non-numeric value, or no data row.
    """
    with open(name, "rb") as stream:
        raw = stream.read()
    # Checked on the whole file, not only where the slow reader looks, so that both readers agree.
    if b"\0" in raw:
        raise _BadFile("not a text file (contains NUL bytes)")
    _check_line_lengths(raw)
    layout = _scan_table_head(name)
    table = _loadtxt(
        name,
        delimiter=layout.delimiter,
        comments="#",
        skiprows=layout.header_line,
        usecols=layout.columns,
        encoding="utf-8-sig",
        quotechar='"',
    )
    if table is not None and len(table) > 0:
        return np.ascontiguousarray(table)
    return _parse_table_rows(raw, layout)


def _check_line_lengths(raw: bytes) -> None:
    """Refuse a line longer than _MAX_LINE_BYTES, naming it (line breaks: LF, CR LF or CR)."""
    codes = np.frombuffer(raw, dtype=np.uint8)
    breaks = np.flatnonzero((codes == 10) | (codes == 13))
    starts = np.concatenate(([0], breaks + 1))
    ends = np.concatenate((breaks, [len(raw)]))
    long = np.flatnonzero(ends - starts > _MAX_LINE_BYTES)
    if len(long):
        start = int(starts[long[0]])
        number = 1 + len(_LINE_BREAK.findall(raw, 0, start))
        raise _BadFile(f"line {number} is longer than {_MAX_LINE_BYTES} bytes (not a point table)")


def _scan_table_head(name: str) -> _TableLayout:
    """Find the header (if any), the delimiter and the x, y, z columns from the first lines."""
    content = []  # (line number, text) of the first two lines that are neither blank nor comments
    with open(name, encoding="utf-8-sig", errors="replace", newline=None) as stream:
        for number, line in enumerate(stream, start=1):
            text = _strip_comment(line)
            if text:
                content.append((number, text))
                if len(content) == 2:
                    break
    if not content:
        raise _BadFile("empty file")
    first_number, first = content[0]
    if all(_is_number(token) for token in re.split(r"[,;\s]+", first) if token):
        delimiter = _delimiter_of(first)
        fields = _split_fields(first, delimiter)
        if len(fields) < 3:
            raise _BadFile(f"fewer than 3 columns (row {first_number} has {len(fields)})")
        return _TableLayout(0, delimiter, (0, 1, 2))
    if len(content) < 2:
        raise _BadFile("no points (only a header row)")
    data_number, data = content[1]
    delimiter = _delimiter_of(data)
    # The delimiter is taken from the data; a header written with another one ("id,x,y,z" over
    # "1;2;3;4") would be read as one unnamed column and the first three numbers taken as x, y, z.
    named, found = len(_split_fields(first, delimiter)), len(_split_fields(data, delimiter))
    if named != found:
        raise _BadFile(
            f"the header (line {first_number}) has {named} field{'s' if named != 1 else ''} but row "
            f"{data_number} has {found}, split at {_DELIMITER_NAMES[delimiter]}"
        )
    return _TableLayout(first_number, delimiter, _choose_columns(first, data, data_number, delimiter))


_DELIMITER_NAMES = {";": "semicolons", ",": "commas", "\t": "tabs", None: "whitespace"}


def _choose_columns(header: str, data: str, data_number: int, delimiter: Optional[str]) -> tuple:
    """The x, y, z columns named by the header, else the first three numeric columns."""
    # "//X" is how CloudCompare starts its header line.
    names = [field.lstrip("/").strip().lower() for field in _split_fields(header, delimiter)]
    named = [axis for axis in "xyz" if axis in names]
    for axis in named:
        if names.count(axis) > 1:
            raise _BadFile(f"header names column {axis!r} twice")
    if len(named) == 3:
        return tuple(names.index(axis) for axis in "xyz")
    if named:
        missing = [axis for axis in "xyz" if axis not in named]
        raise _BadFile(f"header names {', '.join(named)} but no {', '.join(missing)} column")
    numeric = [index for index, field in enumerate(_split_fields(data, delimiter)) if _is_number(field)]
    if len(numeric) < 3:
        raise _BadFile(
            f"no x, y, z columns in the header and fewer than 3 numeric columns (row {data_number})"
        )
    return tuple(numeric[:3])


def _parse_table_rows(raw: bytes, layout: _TableLayout) -> np.ndarray:
    """The slow reference reader of a text table, row by row; names the row of any problem."""
    text = raw.decode("utf-8-sig", errors="replace").replace("\r\n", "\n").replace("\r", "\n")
    needed = max(layout.columns) + 1
    rows = []
    for number, line in enumerate(text.split("\n"), start=1):
        if number <= layout.header_line:
            continue
        content = _strip_comment(line)
        if not content:
            continue
        fields = _split_fields(content, layout.delimiter)
        if len(fields) < needed:
            raise _BadFile(f"row {number} has {len(fields)} values, expected at least {needed}")
        row = []
        for column in layout.columns:
            if not _is_number(fields[column]):
                raise _BadFile(f"non-numeric value {_quote(fields[column])} in row {number}")
            row.append(float(fields[column]))
        rows.append(row)
    if not rows:
        raise _BadFile("no points (only a header row)")
    return np.array(rows, dtype=np.float64)


def _strip_comment(line: str) -> str:
    # Same rule as loadtxt(comments="#"): a '#' starts a comment anywhere on the line.
    return line.split("#", 1)[0].strip()


def _delimiter_of(line: str) -> Optional[str]:
    # A semicolon is looked for first: its files may use a comma as the decimal mark.
    for delimiter in (";", ",", "\t"):
        if delimiter in line:
            return delimiter
    return None


def _split_fields(line: str, delimiter: Optional[str]) -> list:
    """The fields of a line, stripped of spaces and quotes; trailing empty fields dropped."""
    if delimiter is None:
        fields = line.split()
    else:
        # The csv module, so that a quoted field keeps its delimiter ("1,5" is one bad value, not two).
        fields = next(csv.reader([line], delimiter=delimiter, skipinitialspace=True), [])
    fields = [field.strip().strip("\"'").strip() for field in fields]
    while fields and not fields[-1]:
        fields.pop()
    return fields


def _is_number(token: str) -> bool:
    token = token.strip().strip("\"'")
    # float() also takes "1_000"; loadtxt does not, and neither should the two readers differ.
    if "_" in token:
        return False
    try:
        float(token)
    except ValueError:
        return False
    return True


def encode_table(points: np.ndarray, header: bool) -> bytes:
    """The bytes of a text table of ``points``, each value its shortest exact decimal.

    Parameters
    ----------
    points : (n, 3) float64 or float32 ndarray
        The points to write; float32 values are written as the shortest decimal of the float32.
    header : bool
        Write comma-separated rows under an ``x,y,z`` header (``.csv``); else space-separated rows
        without a header (``.txt``, ``.xyz``).

    Returns
    -------
    bytes
        The table, ascii, one line per point.
    """
    # %r of a Python float is the shortest text that reads back to the same double.
    row = "%r,%r,%r\n" if header else "%r %r %r\n"
    body = (row * len(points)) % tuple(points.ravel().tolist())
    return (("x,y,z\n" if header else "") + body).encode("ascii")
