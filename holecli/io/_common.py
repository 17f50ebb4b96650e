"""Helpers shared by the readers of :mod:`holecli.io`: the error they raise, message pieces, limits.

Kept in one place so that the PLY, PCD and text readers word their messages alike:

- :class:`_BadFile`, the exception every reader raises for a bad file (:func:`holecli.io.read_cloud`
  adds the path and turns it into :class:`holecli.errors.LoadError`), and the phrases that go in
  its messages (:func:`_describe`, :func:`_quote`, :func:`_missing_xyz`);
- the limits on what a header may ask for (:data:`_MAX_HEADER_BYTES`, :data:`_COUNT`);
- the numpy helpers that pick x, y, z out of fixed-size binary records (PLY and PCD);
- the record model and the ascii body reader shared by PLY and PCD: a PCD header is described as
  one PLY-like element (:class:`_PlyElement` of :class:`_PlyProperty`), so that both formats' ascii
  bodies are read, checked and reported by :func:`_parse_ascii_records` and its neighbours.
"""

from __future__ import annotations

import re
import warnings
from dataclasses import dataclass
from typing import Optional

import numpy as np

from holecli.io.formats import format_of

# A PLY or PCD header is a few hundred bytes; one that has not ended after this many is not a header
# (a binary file that happens to start with "ply", say), and searching on would read the whole file.
_MAX_HEADER_BYTES = 1 << 20

# How much of a bad line or value an error message quotes.
_QUOTE_CHARS = 40


class _BadFile(Exception):
    """A problem with the file being read; :func:`holecli.io.read_cloud` adds the path, raises LoadError."""


# A count in a header: digits only (no sign, no exponent).
_COUNT = re.compile(r"[0-9]+")


@dataclass(frozen=True)
class _PlyProperty:
    """One property of a PLY element (or one value of a PCD record): a scalar or a list."""

    name: str
    dtype: str  # numpy type code of the value, or of a list's items
    length_dtype: Optional[str] = None  # numpy type code of a list's length; None for a scalar


@dataclass(frozen=True)
class _PlyElement:
    """The layout of the records of a PLY element, or of a PCD's points (see ``pcd._pcd_as_element``)."""

    name: str
    count: int
    properties: tuple

    @property
    def has_lists(self) -> bool:
        return any(prop.length_dtype for prop in self.properties)

    @property
    def scalar_names(self) -> list:
        return [prop.name for prop in self.properties if not prop.length_dtype]


def _describe(exc: BaseException) -> str:
    """An exception as a short lowercase phrase for an error message."""
    text = getattr(exc, "strerror", None) or str(exc) or type(exc).__name__
    text = text.strip().rstrip(".")
    return text[:1].lower() + text[1:]


def _quote(text) -> str:
    """A value or line for an error message, shortened and with its quotes."""
    if isinstance(text, bytes):
        text = text.decode("latin-1")
    text = text.strip()
    if len(text) > _QUOTE_CHARS:
        text = text[:_QUOTE_CHARS] + "..."
    return repr(text)


def _missing_xyz(names, singular: str, plural: str, where: str) -> str:
    """The message for a header without x, y or z, naming what it has instead."""
    missing = [axis for axis in "xyz" if axis not in names]
    noun = singular if len(missing) == 1 else plural
    return f"no {', '.join(missing)} {noun} in {where} (found {', '.join(names) or 'none'})"


def _xyz_from_records(records: np.ndarray) -> np.ndarray:
    """The x, y, z fields of a structured array as an (n, 3) float64 array."""
    points = np.empty((len(records), 3), dtype=np.float64)
    # A float32 signalling NaN sets the "invalid" flag when widened; it is a NaN like any other here.
    with np.errstate(invalid="ignore"):
        for column, axis in enumerate("xyz"):
            points[:, column] = records[axis]
    return points


def _record_dtype(offsets: dict, formats: dict, itemsize: int, byteorder: str = "<") -> np.dtype:
    """A structured dtype that picks x, y, z out of fixed-size records and skips everything else."""
    return np.dtype(
        {
            "names": list("xyz"),
            "formats": [byteorder + formats[axis] for axis in "xyz"],
            "offsets": [offsets[axis] for axis in "xyz"],
            "itemsize": itemsize,
        }
    )


def _loadtxt(name: str, **options) -> Optional[np.ndarray]:
    """np.loadtxt as a fast path: the table, or None when it fails and the slow reader must decide.

    The slow readers are the reference: they accept what loadtxt cannot (blank lines made of
    spaces, stray characters loadtxt rejects) and name the line of a real error.
    """
    try:
        with warnings.catch_warnings():
            # loadtxt warns about an empty input; the callers report that with a message of their own.
            warnings.simplefilter("ignore")
            return np.loadtxt(name, dtype=np.float64, ndmin=2, **options)
    except ValueError:
        return None


def _unit(element: _PlyElement) -> str:
    """How messages call the records of an element."""
    return {"vertex": "vertices", "point": "points"}.get(element.name, f"{element.name!r} records")


# A blank line after a newline: spaces only (bytes.split's whitespace but LF), up to the next newline.
_BLANK_LINE = re.compile(rb"\n[ \t\r\f\v]*(?=\n)")


def _count_content_lines(data: bytes, offset: int) -> int:
    """The number of non-blank lines from ``offset`` on, which is just past the header's newline.

    Counted without splitting the body: all lines, less the blank ones (rare, so the regex is fast).
    """
    if offset >= len(data):
        return 0
    lines = data.count(b"\n", offset) + 1
    blank = len(_BLANK_LINE.findall(data, offset - 1))
    last = data[max(data.rfind(b"\n", offset), offset - 1) + 1 :]
    return lines - blank - (not last.strip())


def _numbered_lines(data: bytes, offset: int, first_number: int):
    """An iterator over (line number, tokens) of the non-blank lines of an ascii body."""
    for number, line in enumerate(data[offset:].split(b"\n"), start=first_number):
        tokens = line.split()
        if tokens:
            yield number, tokens


def _parse_ascii_records(lines, element: _PlyElement, what: str) -> np.ndarray:
    """Parse the records of one element from an ascii body, one record per line.

    The slow reference path: it handles list properties and names the line of every problem.

    Parameters
    ----------
    lines : iterator of (int, list of bytes)
        From :func:`_numbered_lines`; consumed up to the element's last record.
    element : _PlyElement
        The layout of each record (a PCD header is described as one element too).
    what : str
        ``"PLY"`` or ``"PCD"``, for the messages.

    Returns
    -------
    points : (count, 3) float64 ndarray
        The x, y, z of each record (zeros where the element has no such property).
    """
    column = {"x": 0, "y": 1, "z": 2}
    unit = _unit(element)
    rows = []
    while len(rows) < element.count:
        item = next(lines, None)
        if item is None:
            follow = "1 line follows" if len(rows) == 1 else f"{len(rows)} lines follow"
            raise _BadFile(f"truncated ascii {what}: header announces {element.count} {unit} but only {follow}")
        number, tokens = item
        row = [0.0, 0.0, 0.0]
        position = 0
        for prop in element.properties:
            if position >= len(tokens):
                raise _BadFile(
                    f"malformed ascii {what}: line {number} has {len(tokens)} values, "
                    f"too few for the {element.name} properties in the header"
                )
            if prop.length_dtype:
                length = tokens[position].decode("latin-1")
                if not _COUNT.fullmatch(length):
                    raise _BadFile(
                        f"malformed ascii {what}: list length {_quote(length)} of {prop.name!r} "
                        f"in line {number} is not a count"
                    )
                position += 1 + int(length)
            else:
                value = _ascii_value(tokens[position], number, what)
                if prop.name in column:
                    row[column[prop.name]] = value
                position += 1
        if position != len(tokens):
            raise _BadFile(
                f"malformed ascii {what}: line {number} has {len(tokens)} values, "
                f"the header declares {position}"
            )
        rows.append(row)
    return np.array(rows, dtype=np.float64).reshape(-1, 3)


def _refuse_lines_after(lines, last: _PlyElement, what: str) -> None:
    """Refuse a non-blank line after the last record: the counts in the header are not the file's."""
    extra = next(lines, None)
    if extra is not None:
        raise _BadFile(
            f"malformed ascii {what}: line {extra[0]} is past the {last.count} {_unit(last)} "
            "the header announces"
        )


def _ascii_value(token: bytes, number: int, what: str) -> float:
    try:
        return float(token)
    except ValueError:
        raise _BadFile(
            f"malformed ascii {what}: non-numeric value {_quote(token)} in line {number}"
        ) from None


def _need_extra(extension: str) -> _BadFile:
    """The error for a format whose optional extra is not installed (``pip install 'holecli[e57]'``).

    Parameters
    ----------
    extension : str
        The file's extension, lowercase with its dot (``".e57"``); its extra is the one the table of
        formats gives (:attr:`holecli.io.formats.Format.extra`: ``"e57"``, ``"las"``).

    Returns
    -------
    _BadFile
        To raise: ``reading .e57 needs the optional extra: pip install 'holecli[e57]'``.
    """
    return _BadFile(f"reading {extension} needs the optional extra: pip install 'holecli[{format_of(extension).extra}]'")
