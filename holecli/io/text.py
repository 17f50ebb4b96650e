"""Text tables (``.csv``, ``.txt``, ``.xyz``): reading and writing.

:func:`read_table` finds the delimiter (semicolon, comma, tab or whitespace), an optional header
row naming x, y, z, and the columns from the first lines, then reads the table with numpy, falling
back to a row-by-row reader that names the line of any problem. Called through
:func:`holecli.io.read_cloud`; :func:`read_table_columns` also says which columns were read
(:class:`TableColumns`).

Which columns are x, y, z (:func:`_choose_columns`), in this order:

1. ``columns`` (``--columns``): three header names or 0-based indices, as given;
2. a header that names x, y and z (:data:`AXIS_NAME`, below): those columns, wherever they are;
3. three numeric columns (a header naming none of x, y, z, or none at all): those;
4. no header and more than three numeric columns: the first three, as every common layout without a
   header has them (``x y z`` then intensity, colours or normals: ``.xyz`` of CloudCompare,
   Agisoft, ``.pts``), unless the first column is whole numbers that go up by exactly 1 from row
   to row (``0 1 2 ...``): a point number, or a raster's column index, before x, y, z; refused;
5. a header naming none of x, y, z over more than three numeric columns: refused.

A refused table is named with the columns seen and the hint ``--columns``: a wrong guess measures
the wrong coordinates ("no hole found", or holes that are not there) without a word.

A header name is an axis (:data:`AXIS_NAME`, case ignored, CloudCompare's leading ``//`` and
quotes stripped) when it is ``x``, ``y`` or ``z``, optionally after a prefix ``pos``, ``position``,
``point``, ``coord`` or ``coordinate`` and a separator (``pos_x``, ``Point X``), optionally followed
by a unit (mm, cm, m, um, in, inch) after a separator or in brackets (``x_mm``, ``X [mm]``,
``x(m)``, ``x mm``). Separators: ``_``, ``-``, ``.``, ``:``, a space. When the three axis names
give the same unit, it is the table's declared unit (:attr:`TableColumns.unit`), if it is one
holecli converts (mm, m, in); different units are refused.
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
    header: Optional[tuple] = None  # the header's names, as written (stripped), when there is one
    width: int = 3  # fields of the first data row
    unit: Optional[str] = None  # the unit the header's x, y, z names give, when they all give one
    given: bool = False  # the columns were given (``columns``), not found


@dataclass(frozen=True)
class TableColumns:
    """Which columns of a text table were read as x, y, z, and why.

    Attributes
    ----------
    indices : (3,) tuple of int
        The 0-based column indices of x, y, z.
    names : (3,) tuple of str, or None
        Their header names as written; None when the table has no header.
    header : tuple of str, or None
        Every name of the header row; None when there is none.
    width : int
        The number of fields of the first data row.
    unit : {"mm", "m", "in"} or None
        The unit the header's names give x, y, z (``x_mm, y_mm, z_mm``), when they all give the same
        one and holecli converts it; None otherwise.
    given : bool
        The columns were given (``--columns``) rather than found.
    """

    indices: tuple
    names: Optional[tuple]
    header: Optional[tuple]
    width: int
    unit: Optional[str] = None
    given: bool = False

    def describe(self) -> str:
        """One line for ``-v`` and ``holecli info``: ``x_mm,y_mm,z_mm (1,2,3)``, or ``1,2,3 (no header)``.

        Returns
        -------
        str
        """
        indices = ",".join(str(index) for index in self.indices)
        how = ", given" if self.given else ""
        if self.names is None:
            return f"{indices} (no header{how}; of {self.width})"
        return f"{','.join(self.names)} ({indices}{how}; of {self.width})"

    def to_dict(self) -> dict:
        """The record's ``input_columns``.

        Returns
        -------
        dict
            ``indices``, ``names``, ``header``, ``width``, ``unit``, ``given``.
        """
        return {"indices": list(self.indices), "names": None if self.names is None else list(self.names),
                "header": None if self.header is None else list(self.header), "width": self.width,
                "unit": self.unit, "given": self.given}


# A header name that is an axis: optional prefix, x/y/z, optional unit (see the module docstring).
_SEPARATOR = r"[ _.:\-]"
AXIS_NAME = re.compile(
    rf"(?:(?:pos|position|point|coord|coordinate){_SEPARATOR}+)?(?P<axis>[xyz])"
    rf"(?:{_SEPARATOR}*[\[(]\s*(?P<bracketed>mm|cm|m|um|µm|in|inch)\s*[\])]|{_SEPARATOR}+(?P<unit>mm|cm|m|um|µm|in|inch))?",
    re.IGNORECASE,
)
# The units of header names holecli converts (holecli.units.UNITS), by their spelling.
_HEADER_UNITS = {"mm": "mm", "m": "m", "in": "in", "inch": "in"}
# How many data rows the head scan looks at: the id check of the first column.
_HEAD_ROWS = 50


def axis_of(name: str):
    """The axis and unit a header name gives: ``("x", "mm")`` for ``X [mm]``, ``("x", None)`` for ``//X``.

    Parameters
    ----------
    name : str
        One field of a header row.

    Returns
    -------
    (str, str or None) or None
        The axis (``"x"``, ``"y"`` or ``"z"``) and the unit as written in lower case (or None);
        None when the name is not an axis (:data:`AXIS_NAME`).

    Examples
    --------
    >>> axis_of("x_mm"), axis_of("Pos_Y"), axis_of("Z (m)"), axis_of("//X"), axis_of("index")
    (('x', 'mm'), ('y', None), ('z', 'm'), ('x', None), None)
    """
    match = AXIS_NAME.fullmatch(_plain_name(name))
    if match is None:
        return None
    unit = match.group("bracketed") or match.group("unit")
    return match.group("axis").lower(), None if unit is None else unit.lower()


def _plain_name(name: str) -> str:
    # "//X" is how CloudCompare starts its header line.
    return name.strip().strip("\"'").lstrip("/").strip()


# A row of a point table is at most a few hundred characters. A much longer line is not a table (and
# the csv module refuses a field over 131,072 characters); this limit keeps it a one-line error.
_MAX_LINE_BYTES = 1 << 16
_LINE_BREAK = re.compile(rb"\r\n|\r|\n")


def read_table(name: str, columns=None) -> np.ndarray:
    """Read x, y, z from a delimited text table (.csv, .txt, .xyz).

    Parameters
    ----------
    name : str
        The file's path; the file exists and is not empty.
    columns : sequence of 3 (str or int), optional
        The x, y, z columns: header names (case ignored) or 0-based indices (``--columns``); by
        default found from the header or the data (see the module docstring).

    Returns
    -------
    points : (n, 3) float64 ndarray
        One row per non-blank, non-comment data row, n >= 1, non-finite rows included.

    Raises
    ------
    _BadFile
        If the file is not a text table, has fewer than 3 columns or no x, y, z columns, a header
        that does not fit the rows, a short row, a non-numeric value, or no data row; if its
        columns are ambiguous (see the module docstring); if ``columns`` names a column it does not have.
    """
    return read_table_columns(name, columns)[0]


def read_table_columns(name: str, columns=None):
    """:func:`read_table`, and which columns were read.

    Parameters
    ----------
    name : str
    columns : sequence of 3 (str or int), optional
        As for :func:`read_table`.

    Returns
    -------
    points : (n, 3) float64 ndarray
    read : TableColumns
    """
    with open(name, "rb") as stream:
        raw = stream.read()
    # Checked on the whole file, not only where the slow reader looks, so that both readers agree.
    if b"\0" in raw:
        raise _BadFile("not a text file (contains NUL bytes)")
    _check_line_lengths(raw)
    layout = _scan_table_head(name, columns)
    read = TableColumns(layout.columns, None if layout.header is None else tuple(layout.header[i] for i in layout.columns),
                        layout.header, layout.width, layout.unit, layout.given)
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
        return np.ascontiguousarray(table), read
    return _parse_table_rows(raw, layout), read


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


def _scan_table_head(name: str, columns=None) -> _TableLayout:
    """Find the header (if any), the delimiter and the x, y, z columns from the first lines."""
    content = []  # (line number, text) of the first lines that are neither blank nor comments
    with open(name, encoding="utf-8-sig", errors="replace", newline=None) as stream:
        for number, line in enumerate(stream, start=1):
            text = _strip_comment(line)
            if text:
                content.append((number, text))
                if len(content) == 1 + _HEAD_ROWS:
                    break
    if not content:
        raise _BadFile("empty file")
    first_number, first = content[0]
    if all(_is_number(token) for token in re.split(r"[,;\s]+", first) if token):
        delimiter = _delimiter_of(first)
        fields = _split_fields(first, delimiter)
        if len(fields) < 3:
            raise _BadFile(f"fewer than 3 columns (row {first_number} has {len(fields)})")
        rows = [_split_fields(text, delimiter) for _, text in content]
        if columns is not None:
            return _TableLayout(0, delimiter, _given_columns(columns, None, len(fields)), None, len(fields), None, True)
        if len(fields) > 3 and _looks_like_an_id(rows):
            raise _BadFile(
                f"ambiguous columns: no header, {len(fields)} columns and the first is whole numbers going up "
                f"by 1 ({', '.join(row[0] for row in rows[:3])}, ...): a point number before x, y, z, or x "
                f"itself? (row {first_number}: {_quote(first)}; give --columns 1,2,3 or --columns 0,1,2, "
                f"0-based)")
        return _TableLayout(0, delimiter, (0, 1, 2), None, len(fields))
    if len(content) < 2:
        raise _BadFile("no points (only a header row)")
    data_number, data = content[1]
    delimiter = _delimiter_of(data)
    # The delimiter is taken from the data; a header written with another one ("id,x,y,z" over
    # "1;2;3;4") would be read as one unnamed column and the first three numbers taken as x, y, z.
    header, fields = tuple(_split_fields(first, delimiter)), _split_fields(data, delimiter)
    named, found = len(header), len(fields)
    if named != found:
        raise _BadFile(
            f"the header (line {first_number}) has {named} field{'s' if named != 1 else ''} but row "
            f"{data_number} has {found}, split at {_DELIMITER_NAMES[delimiter]}"
        )
    if columns is not None:
        return _TableLayout(first_number, delimiter, _given_columns(columns, header, found), header, found, None, True)
    indices, unit = _choose_columns(header, data, data_number, delimiter)
    return _TableLayout(first_number, delimiter, indices, header, found, unit)


_DELIMITER_NAMES = {";": "semicolons", ",": "commas", "\t": "tabs", None: "whitespace"}


def _looks_like_an_id(rows) -> bool:
    """The first column of the head's rows is whole numbers, each 1 more than the one before (2 rows at least)."""
    if len(rows) < 2:
        return False
    values = []
    for row in rows:
        token = row[0]
        if not re.fullmatch(r"[+-]?[0-9]+", token):  # "1.0" or "1e3" is a coordinate's way of writing
            return False
        values.append(int(token))
    return all(after - before == 1 for before, after in zip(values, values[1:]))


def _seen(header, width) -> str:
    """The columns of a table for a message: ``0 point, 1 x_mm, ...``, or ``5 columns, no header``."""
    if header is None:
        return f"{width} columns, no header"
    return "columns " + ", ".join(f"{index} {_quote(name)}" for index, name in enumerate(header))


def _given_columns(columns, header, width) -> tuple:
    """The 0-based indices of ``columns`` (three header names or indices, see :func:`parse_columns`)."""
    indices = []
    for item in columns:
        if isinstance(item, int) or (isinstance(item, str) and re.fullmatch(r"[0-9]+", item.strip())):
            index = int(item)
            if index >= width:
                raise _BadFile(f"--columns {index} is past the last column (0-based: {_seen(header, width)})")
            indices.append(index)
            continue
        wanted = _plain_name(str(item)).lower()
        if header is None:
            raise _BadFile(f"--columns names {_quote(str(item))} but the table has no header row "
                           f"({width} columns: give 0-based indices, e.g. --columns 0,1,2)")
        matches = [index for index, name in enumerate(header) if _plain_name(name).lower() == wanted]
        if not matches:
            raise _BadFile(f"--columns names {_quote(str(item))}, which the header does not have ({_seen(header, width)})")
        if len(matches) > 1:
            raise _BadFile(f"--columns names {_quote(str(item))}, which the header has {len(matches)} times "
                           f"(give its index: {_seen(header, width)})")
        indices.append(matches[0])
    return tuple(indices)


def _choose_columns(header, data: str, data_number: int, delimiter: Optional[str]):
    """The x, y, z columns named by the header, else the numeric columns when there are three:
    ``(indices, unit)``, the unit the header's names give (or None)."""
    axes = [axis_of(name) for name in header]
    found = {}
    for index, named in enumerate(axes):
        if named is not None:
            found.setdefault(named[0], []).append(index)
    for axis, indices in found.items():
        if len(indices) > 1:
            if len({_plain_name(header[i]).lower() for i in indices}) == 1:
                raise _BadFile(f"header names column {axis!r} twice")
            raise _BadFile(f"ambiguous columns: the header has {len(indices)} {axis} columns "
                           f"({', '.join(_quote(header[i]) for i in indices)}); give --columns ({_seen(header, len(header))})")
    if len(found) == 3:
        indices = tuple(found[axis][0] for axis in "xyz")
        units = [axes[index][1] for index in indices]
        if len(set(units)) > 1 and all(units):
            raise _BadFile(f"the header gives x, y, z in different units "
                           f"({', '.join(_quote(header[i]) for i in indices)})")
        return indices, _HEADER_UNITS.get(units[0]) if all(units) else None
    if found:
        named = [axis for axis in "xyz" if axis in found]
        missing = [axis for axis in "xyz" if axis not in found]
        raise _BadFile(f"header names {', '.join(named)} but no {', '.join(missing)} column")
    numeric = [index for index, field in enumerate(_split_fields(data, delimiter)) if _is_number(field)]
    if len(numeric) < 3:
        raise _BadFile(
            f"no x, y, z columns in the header and fewer than 3 numeric columns (row {data_number})"
        )
    if len(numeric) > 3:
        raise _BadFile(f"ambiguous columns: the header names no x, y, z and row {data_number} has {len(numeric)} "
                       f"numeric columns ({_seen(header, len(header))}); give --columns, e.g. "
                       f"--columns {','.join(header[i] for i in numeric[:3])}")
    return tuple(numeric), None


def parse_columns(text: str) -> tuple:
    """``--columns`` as given: three comma-separated header names or 0-based indices.

    Parameters
    ----------
    text : str
        E.g. ``"x_mm,y_mm,z_mm"`` or ``"1,2,3"``.

    Returns
    -------
    (3,) tuple of str or int
        Indices as int, names as str (stripped).

    Raises
    ------
    ValueError
        When it is not three non-empty items, or names a column twice.

    Examples
    --------
    >>> parse_columns("x_mm, y_mm ,z_mm"), parse_columns("1,2,3")
    (('x_mm', 'y_mm', 'z_mm'), (1, 2, 3))
    """
    items = [item.strip() for item in text.split(",")]
    if len(items) != 3 or not all(items):
        raise ValueError(f"expected three comma-separated column names or 0-based indices (x,y,z), got {text!r}")
    parsed = tuple(int(item) if re.fullmatch(r"[0-9]+", item) else item for item in items)
    if len({str(item).lower() for item in parsed}) != 3:
        raise ValueError(f"names a column twice: {text!r}")
    return parsed


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
