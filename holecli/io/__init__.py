"""Reading and writing point-cloud files.

:func:`load_points` turns a file into an ``(n, 3)`` float64 array of finite points; :func:`read_cloud`
also tells how many rows were dropped because a coordinate was NaN or infinite; :func:`save_points`
writes an array back. Supported formats, chosen by the extension (any case):

========  ==================================================================================
``.ply``  ascii, binary_little_endian, binary_big_endian; any element layout and property types
``.pcd``  DATA ascii, binary, binary_compressed (organized clouds too: their NaN rows are dropped)
``.csv``  comma, semicolon, tab or whitespace separated; optional header naming x, y, z
``.txt``  same as ``.csv``
``.xyz``  same as ``.csv``
========  ==================================================================================

Every problem with a file raises :class:`holecli.errors.LoadError`, never another exception type,
and a file is never half-read: a count that disagrees with its header is refused rather than
padded or cut. Messages name rows and lines by their 1-based line number in the file.

A PLY or PCD file must be exactly as long as its header says: a binary body (every element of a
PLY, the records of a PCD, the sizes and LZF stream of a ``binary_compressed`` PCD) neither
shorter nor longer, an ascii body one non-blank line per record with nothing but blank lines
after the last. The one exception is the NUL padding of old PCL releases (up to about 1.8), whose
binary and binary_compressed writers stretch the file to one memory page plus the data: a PCD
exactly that long and ending in NUL bytes is read. Bytes after the data are otherwise the sign of
a damaged file or a wrong header (a count halved, a type relabelled, DATA ascii marked binary),
and reading on would measure reinterpreted bytes. Nothing is allocated by what a header asks for
before it is checked against what the file holds, so a count of 10^12 is refused at once.

open3d reads PLY and PCD, but not defensively: a missing, truncated or malformed file comes back as
an empty cloud, or as the header's point count filled with zeros or garbage, with at most a warning
on the console. So the headers are parsed and checked here, and the vertex data of PLY and of
uncompressed PCD is read with numpy from the parsed header, which is also faster. open3d is used
only to decompress ``binary_compressed`` PCD (LZF), after the header and the sizes are checked, and
is imported there: importing it costs more than a second, which ``--help`` and CSV input should not
pay.
"""

from __future__ import annotations

import csv
import os
import re
import stat
import struct
import warnings
from dataclasses import dataclass
from typing import Optional

import numpy as np

from holecli.errors import LoadError
from holecli.io.outfile import write_bytes

__all__ = ["SUPPORTED_EXTENSIONS", "Cloud", "load_points", "read_cloud", "save_points"]

SUPPORTED_EXTENSIONS = (".ply", ".pcd", ".csv", ".txt", ".xyz")
_TEXT_EXTENSIONS = (".csv", ".txt", ".xyz")
_EXPECTED = ".ply, .pcd, .csv, .txt or .xyz"

# A PLY or PCD header is a few hundred bytes; one that has not ended after this many is not a header
# (a binary file that happens to start with "ply", say), and searching on would read the whole file.
_MAX_HEADER_BYTES = 1 << 20

# How much of a bad line or value an error message quotes.
_QUOTE_CHARS = 40


class _BadFile(Exception):
    """A problem with the file being read; :func:`read_cloud` adds the path and raises LoadError."""


@dataclass(frozen=True, eq=False)
class Cloud:
    """The points of one file.

    Attributes
    ----------
    points : (n, 3) float64 ndarray
        The finite points, C-contiguous, in file units, in file order; n >= 1.
    dropped : int
        Rows of the file dropped because a coordinate was NaN or infinite (the empty cells of an
        organized cloud, for example).
    path : str
        The file the points were read from.
    """

    points: np.ndarray
    dropped: int
    path: str


def read_cloud(path) -> Cloud:
    """Read the points of a PLY, PCD, CSV, TXT or XYZ file.

    Parameters
    ----------
    path : str or os.PathLike
        The file; its extension (any case) selects the format.

    Returns
    -------
    Cloud
        The finite points of the file and the number of rows dropped as non-finite.

    Raises
    ------
    LoadError
        For any problem with the file: missing, a directory, unsupported extension, empty, garbled
        or truncated, no x, y, z coordinates, a non-numeric value, or no finite point at all.
    """
    name = os.fspath(path)
    try:
        raw = _read_raw(name)
    except _BadFile as exc:
        raise LoadError(name, str(exc)) from None
    except (OSError, ValueError, struct.error, csv.Error, OverflowError, MemoryError) as exc:
        # Every known bad input is reported above with its own message; this is the safety net
        # that keeps an unforeseen one a one-line error instead of a traceback.
        raise LoadError(name, f"unreadable file ({_describe(exc)})") from exc
    return _finite_cloud(raw, name)


def load_points(path) -> np.ndarray:
    """Read the finite points of a point-cloud file.

    Parameters
    ----------
    path : str or os.PathLike
        A ``.ply``, ``.pcd``, ``.csv``, ``.txt`` or ``.xyz`` file.

    Returns
    -------
    points : (n, 3) float64 ndarray
        C-contiguous, in file units; rows with a NaN or infinite coordinate are left out
        (:func:`read_cloud` tells how many).

    Raises
    ------
    LoadError
        See :func:`read_cloud`.
    """
    return read_cloud(path).points


def save_points(path, points, float32=False) -> None:
    """Write points to a PLY, PCD, CSV, TXT or XYZ file, replacing a regular file atomically.

    PLY is written as binary_little_endian and PCD as ``DATA binary``, both with double x, y, z;
    CSV gets an ``x,y,z`` header, ``.txt`` and ``.xyz`` are space separated without one. Text holds
    the shortest decimal that reads back to the same double. The data go to a temporary file in the
    same folder, which then replaces ``path``: a reader never sees half a file, and on failure the
    temporary file is removed and ``path`` is left as it was. A symbolic link gets its target
    written, a device or FIFO is written directly (see :func:`holecli.io.outfile.write_bytes`).

    Parameters
    ----------
    path : str or os.PathLike
        The file to write; its extension (any case) selects the format.
    points : (n, 3) array_like of float
        The points; NaN and infinite values are written as they are.
    float32 : bool
        Write single-precision values, as laser profilers do (binary PLY ``property float``, PCD
        ``SIZE 4``; text with each value rounded to float32, written so that it reads back exactly).

    Raises
    ------
    ValueError
        If the extension is not supported or ``points`` is not a numeric (n, 3) array.
    OSError
        If the file cannot be written.
    """
    name = os.fspath(path)
    extension = os.path.splitext(name)[1].lower()
    if extension not in SUPPORTED_EXTENSIONS:
        raise ValueError(f"cannot save {name!r}: unsupported extension {extension!r} (expected {_EXPECTED})")
    array = _as_points(points)
    if extension == ".ply":
        payload = _encode_ply(array, float32)
    elif extension == ".pcd":
        payload = _encode_pcd(array, float32)
    else:
        payload = _encode_text(array.astype(np.float32) if float32 else array, header=extension == ".csv")
    write_bytes(name, payload)


# --- dispatch and common checks ---------------------------------------------------------------


def _read_raw(name: str) -> np.ndarray:
    """All coordinate rows of the file, non-finite ones included, as (n, 3) float64."""
    try:
        info = os.stat(name)
    except FileNotFoundError:
        raise _BadFile("file not found") from None
    except PermissionError:
        raise _BadFile("permission denied") from None
    except OSError as exc:
        raise _BadFile(f"cannot open file ({_describe(exc)})") from None
    if stat.S_ISDIR(info.st_mode):
        raise _BadFile("is a directory")
    if not stat.S_ISREG(info.st_mode):
        # Decided before opening: opening a FIFO blocks until a writer comes, and a device never ends.
        raise _BadFile(f"not a regular file ({file_kind(info.st_mode)})")
    extension = os.path.splitext(name)[1].lower()
    if extension not in SUPPORTED_EXTENSIONS:
        shown = repr(extension) if extension else "(none)"
        raise _BadFile(f"unsupported extension {shown} (expected {_EXPECTED})")
    if info.st_size == 0:
        raise _BadFile("empty file")
    if extension in _TEXT_EXTENSIONS:
        return _read_text_table(name)
    with open(name, "rb") as stream:
        data = stream.read()
    if data.isspace():
        raise _BadFile("empty file")
    if extension == ".ply":
        return _read_ply(name, data)
    return _read_pcd(name, data)


def file_kind(mode: int) -> str:
    """What a file that is not a regular file is, for messages: ``"a FIFO"``, ``"a folder"``, ..."""
    for test, kind in (
        (stat.S_ISDIR, "a folder"),
        (stat.S_ISFIFO, "a FIFO"),
        (stat.S_ISCHR, "a character device"),
        (stat.S_ISBLK, "a block device"),
        (stat.S_ISSOCK, "a socket"),
    ):
        if test(mode):
            return kind
    return f"file type {stat.S_IFMT(mode):#o}"


def _finite_cloud(raw: np.ndarray, name: str) -> Cloud:
    """Drop the rows with a non-finite coordinate and refuse a cloud with no point left."""
    finite = np.isfinite(raw).all(axis=1)
    kept = int(np.count_nonzero(finite))
    if kept == 0:
        if len(raw) == 0:
            raise LoadError(name, "no points")
        raise LoadError(name, f"no finite points (all {len(raw)} rows have a NaN or infinite coordinate)")
    points = raw if kept == len(raw) else raw[finite]
    return Cloud(np.ascontiguousarray(points, dtype=np.float64), len(raw) - kept, name)


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


# --- PLY --------------------------------------------------------------------------------------

_PLY_TYPES = {
    "char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1",
    "short": "i2", "int16": "i2", "ushort": "u2", "uint16": "u2",
    "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
    "float": "f4", "float32": "f4", "double": "f8", "float64": "f8",
}  # fmt: skip
_PLY_BYTEORDER = {"ascii": None, "binary_little_endian": "<", "binary_big_endian": ">"}
_PLY_MAGIC = re.compile(rb"ply[ \t\r]*\n")
# The header ends at the first line that is exactly "end_header"; a CR before the LF belongs to the
# line end, not to the data (open3d reads such a binary file one byte off and returns garbage).
_PLY_END = re.compile(rb"^end_header[ \t\r]*(?:\n|\Z)", re.MULTILINE)
_COUNT = re.compile(r"[0-9]+")


@dataclass(frozen=True)
class _PlyProperty:
    name: str
    dtype: str  # numpy type code of the value, or of a list's items
    length_dtype: Optional[str] = None  # numpy type code of a list's length; None for a scalar


@dataclass(frozen=True)
class _PlyElement:
    name: str
    count: int
    properties: tuple

    @property
    def has_lists(self) -> bool:
        return any(prop.length_dtype for prop in self.properties)

    @property
    def scalar_names(self) -> list:
        return [prop.name for prop in self.properties if not prop.length_dtype]


@dataclass(frozen=True)
class _PlyHeader:
    format: str  # "ascii", "binary_little_endian" or "binary_big_endian"
    elements: tuple
    data_offset: int  # byte offset of the first data byte
    lines: int  # number of header lines, where the ascii data starts


def _read_ply(name: str, data: bytes) -> np.ndarray:
    header = _read_ply_header(data)
    vertex = next((element for element in header.elements if element.name == "vertex"), None)
    if vertex is None:
        raise _BadFile("no vertex element in PLY header")
    if not all(axis in vertex.scalar_names for axis in "xyz"):
        raise _BadFile(_missing_xyz(vertex.scalar_names, "property", "properties", "PLY vertex element"))
    if vertex.count == 0:
        raise _BadFile("no points (PLY header announces 0 vertices)")
    if header.format == "ascii":
        return _read_ply_ascii(name, data, header, vertex)
    return _read_ply_binary(data, header, vertex)


def _read_ply_header(data: bytes) -> _PlyHeader:
    """Parse and check a PLY header (format, elements, properties); the data is not looked at."""
    if not _PLY_MAGIC.match(data):
        raise _BadFile("not a PLY file (the first line is not 'ply')")
    end = _PLY_END.search(data, 0, _MAX_HEADER_BYTES)
    if end is None:
        raise _BadFile("garbled PLY header (no end_header line)")
    text = data[: end.start()].decode("ascii", errors="replace")
    fmt = None
    elements = []  # [name, count, [properties]] while parsing
    for line in text.splitlines()[1:]:
        words = line.split()
        if not words or words[0] in ("comment", "obj_info"):
            continue
        keyword = words[0]
        if keyword == "format":
            if fmt is not None or len(words) != 3 or words[1] not in _PLY_BYTEORDER:
                raise _BadFile(f"garbled PLY header (bad format line {_quote(line)})")
            fmt = words[1]
        elif keyword == "element":
            if len(words) != 3 or not _COUNT.fullmatch(words[2]):
                raise _BadFile(f"garbled PLY header (bad element line {_quote(line)})")
            if any(element[0] == words[1] for element in elements):
                raise _BadFile(f"garbled PLY header (element {words[1]!r} declared twice)")
            elements.append([words[1], int(words[2]), []])
        elif keyword == "property":
            if not elements:
                raise _BadFile(f"garbled PLY header (property before any element: {_quote(line)})")
            prop = _parse_ply_property(words, line)
            if any(other.name == prop.name for other in elements[-1][2]):
                raise _BadFile(f"garbled PLY header (property {prop.name!r} declared twice)")
            elements[-1][2].append(prop)
        else:
            raise _BadFile(f"garbled PLY header (unexpected line {_quote(line)})")
    if fmt is None:
        raise _BadFile("garbled PLY header (no format line)")
    return _PlyHeader(
        format=fmt,
        elements=tuple(_PlyElement(name, count, tuple(props)) for name, count, props in elements),
        data_offset=end.end(),
        lines=data[: end.end()].count(b"\n"),
    )


def _parse_ply_property(words: list, line: str) -> _PlyProperty:
    if len(words) == 3 and words[1] in _PLY_TYPES:
        return _PlyProperty(words[2], _PLY_TYPES[words[1]])
    if (
        len(words) == 5
        and words[1] == "list"
        and words[2] in _PLY_TYPES
        and words[3] in _PLY_TYPES
        and _PLY_TYPES[words[2]][0] in "iu"  # a list's length is an integer
    ):
        return _PlyProperty(words[4], _PLY_TYPES[words[3]], _PLY_TYPES[words[2]])
    raise _BadFile(f"garbled PLY header (bad property line {_quote(line)})")


def _read_ply_binary(data: bytes, header: _PlyHeader, vertex: _PlyElement) -> np.ndarray:
    """The vertices' x, y, z; every element is stepped over, and the data must end with the last."""
    byteorder = _PLY_BYTEORDER[header.format]
    offset = header.data_offset
    points = None
    layout = []  # what each element took, for the message
    for element in header.elements:
        start = offset
        offset, kept, record_size = _walk_binary_records(
            data, offset, element, byteorder, keep=element is vertex, vertices=vertex.count
        )
        if element is vertex:
            points = kept
        if element.count:
            size = f"of {record_size} bytes" if record_size else f"in {offset - start} bytes"
            layout.append(f"{element.count} {_unit(element)} {size}")
    if offset != len(data):
        # No PLY writer is known to pad its binary data; bytes past the last element mean a count or a
        # type in the header does not describe the data (or the file was joined to something).
        raise _BadFile(
            f"garbled binary PLY: {len(data) - header.data_offset} bytes of data but the header declares "
            f"{offset - header.data_offset} ({', '.join(layout)})"
        )
    return points


def _unit(element: _PlyElement) -> str:
    """How messages call the records of an element."""
    return {"vertex": "vertices", "point": "points"}.get(element.name, f"{element.name!r} records")


def _walk_binary_records(
    data: bytes, offset: int, element: _PlyElement, byteorder: str, keep: bool = False, vertices: int = 0
):
    """Step over the records of a binary PLY element; with ``keep``, also collect x, y, z.

    Records without list properties have a fixed size and are skipped by arithmetic. So are records
    whose lists all have the lengths of the first record's (the triangles of a mesh): one numpy pass
    checks every length. Anything else is walked record by record, which is slow but rare.

    The vertex indices of faces are checked too (at least 3 per face, each below ``vertices``):
    binary records have no separators, and a vertex count or a type that is off makes the faces
    read from the wrong offset. That is usually seen as a wrong size at the end, but a misread
    face of length 0 can fall back in step with the next and end the file exactly.

    Returns
    -------
    offset : int
        The offset just past the element's data.
    points : (count, 3) float64 ndarray or None
        The x, y, z of each record when ``keep`` is true.
    record_size : int or None
        The size of every record, None when they differ.
    """
    available = len(data) - offset
    minimum = element.count * _minimum_record_size(element)
    if minimum > available:
        # Checked first so that a count of 10**12 is refused before any work.
        at_least = "at least " if element.has_lists else ""
        raise _BadFile(
            f"truncated binary PLY: header announces {element.count} {_unit(element)} "
            f"({at_least}{minimum} bytes) but only {available} bytes follow"
        )
    faces = _face_list(element)
    layout = _uniform_layout(data, offset, element, byteorder)
    if layout is not None:
        offsets, size, lists = layout
        if faces is not None and element.count:
            _check_uniform_faces(data, offset, element, faces, lists[faces.name], size, byteorder, vertices)
        points = None
        if keep:
            formats = {prop.name: prop.dtype for prop in element.properties}
            dtype = _record_dtype(offsets, formats, size, byteorder)
            points = _xyz_from_records(np.frombuffer(data, dtype, element.count, offset))
        return offset + element.count * size, points, size
    # Per property: struct format and size of the value (or list item), and of a list's length.
    layout = []
    for prop in element.properties:
        value = np.dtype(prop.dtype)
        length = np.dtype(prop.length_dtype) if prop.length_dtype else None
        layout.append((prop.name, byteorder + value.char, value.itemsize, length and byteorder + length.char,
                       length and length.itemsize))  # fmt: skip
    column = {"x": 0, "y": 1, "z": 2}
    rows = []
    index = 0
    try:
        for index in range(element.count):
            row = [0.0, 0.0, 0.0]
            for name, value_format, value_size, length_format, length_size in layout:
                if length_format:
                    (length,) = struct.unpack_from(length_format, data, offset)
                    if length < 0:
                        raise _BadFile(
                            f"malformed binary PLY: negative list length in {element.name} {index + 1}"
                        )
                    if faces is not None and name == faces.name:
                        items = f"{byteorder}{length}{value_format[-1]}"
                        _check_face(index, struct.unpack_from(items, data, offset + length_size), vertices)
                    offset += length_size + length * value_size
                else:
                    if keep and name in column:
                        (row[column[name]],) = struct.unpack_from(value_format, data, offset)
                    offset += value_size
            if offset > len(data):
                raise struct.error("record runs past the end of the file")
            if keep:
                rows.append(row)
    except struct.error:
        raise _BadFile(
            f"truncated binary PLY: data ends in {element.name} {index + 1} "
            f"of the {element.count} the header announces"
        ) from None
    return offset, (np.array(rows, dtype=np.float64).reshape(-1, 3) if keep else None), None


_FACE_LISTS = ("vertex_indices", "vertex_index")


def _face_list(element: _PlyElement) -> Optional[_PlyProperty]:
    """The vertex index list of a face element, or None for any other element."""
    if element.name != "face":
        return None
    return next((prop for prop in element.properties if prop.length_dtype and prop.name in _FACE_LISTS), None)


def _check_face(index: int, indices, vertices: int) -> None:
    """Refuse face ``index`` (0-based) unless it has 3 or more indices of existing vertices."""
    if len(indices) < 3:
        raise _BadFile(
            f"garbled binary PLY: face {index + 1} has {len(indices)} vertex indices (a face has at least 3)"
        )
    for value in indices:
        if not 0 <= value < vertices:
            shown = int(value) if float(value).is_integer() else value  # a list of floats is allowed
            raise _BadFile(
                f"garbled binary PLY: face {index + 1} refers to vertex {shown}, but the header declares "
                f"{vertices} vertices"
            )


def _check_uniform_faces(data, offset, element, faces, position, size, byteorder, vertices) -> None:
    """:func:`_check_face` for every face, when all have the first one's length, in one numpy pass."""
    length_position, length = position
    items = np.dtype(faces.dtype).newbyteorder(byteorder)
    if length < 3:
        _check_face(0, [0] * length, vertices)
    start = length_position + np.dtype(faces.length_dtype).itemsize
    dtype = np.dtype({"names": ["v"], "formats": [(items, (length,))], "offsets": [start], "itemsize": size})
    indices = np.frombuffer(data, dtype, element.count, offset)["v"]
    bad = np.flatnonzero(((indices < 0) | (indices >= vertices)).any(axis=1))
    if len(bad):
        _check_face(int(bad[0]), indices[bad[0]].tolist(), vertices)


def _minimum_record_size(element: _PlyElement) -> int:
    """The bytes a binary record takes at least: its scalars and the lengths of its lists."""
    return sum(np.dtype(prop.length_dtype or prop.dtype).itemsize for prop in element.properties)


def _uniform_layout(data: bytes, offset: int, element: _PlyElement, byteorder: str):
    """The layout of the records, if all are laid out like the first; else None.

    Without lists that is always so. With lists, the first record's lengths give a candidate size;
    if every record's length fields, read at that stride, hold the same lengths, then by induction
    every record has that size.

    Returns
    -------
    (scalar offsets by name, record size, {list name: (offset of its length, its length)}), or None.
    """
    scalar_offsets, size = {}, 0
    if element.count == 0:
        return scalar_offsets, 0, {}
    lengths = []  # (offset in the record, numpy format, value) of each list length
    for prop in element.properties:
        if not prop.length_dtype:
            scalar_offsets[prop.name] = size
            size += np.dtype(prop.dtype).itemsize
            continue
        length_type = np.dtype(prop.length_dtype).newbyteorder(byteorder)
        if offset + size + length_type.itemsize > len(data):
            return None
        length = int(np.frombuffer(data, length_type, 1, offset + size)[0])
        if length < 0:
            return None
        lengths.append((size, length_type, length))
        size += length_type.itemsize + length * np.dtype(prop.dtype).itemsize
    lists = {prop.name: (position, length) for prop, (position, _, length) in
             zip([prop for prop in element.properties if prop.length_dtype], lengths)}  # fmt: skip
    if not lengths:
        return scalar_offsets, size, lists
    if size == 0 or offset + element.count * size > len(data):
        return None
    dtype = np.dtype(
        {
            "names": [f"n{i}" for i in range(len(lengths))],
            "formats": [length_type for _, length_type, _ in lengths],
            "offsets": [position for position, _, _ in lengths],
            "itemsize": size,
        }
    )
    records = np.frombuffer(data, dtype, element.count, offset)
    if all((records[f"n{i}"] == length).all() for i, (_, _, length) in enumerate(lengths)):
        return scalar_offsets, size, lists
    return None


def _read_ply_ascii(name: str, data: bytes, header: _PlyHeader, vertex: _PlyElement) -> np.ndarray:
    # Nothing here allocates by the header's counts before checking them against the file: the fast
    # path needs as many lines as records, and the slow path stops at the first line missing.
    records = sum(element.count for element in header.elements)
    if (
        header.elements[0] is vertex
        and not vertex.has_lists
        and _count_content_lines(data, header.data_offset) == records
    ):
        # The usual layout: vertices first, one per line, fixed number of values, and the file has
        # as many lines as the header has records (loadtxt allocates max_rows rows up front).
        table = _loadtxt(name, skiprows=header.lines, max_rows=vertex.count, comments=None, encoding="latin-1")
        if table is not None and table.shape == (vertex.count, len(vertex.properties)):
            names = [prop.name for prop in vertex.properties]
            return np.ascontiguousarray(table[:, [names.index(axis) for axis in "xyz"]])
    lines = _numbered_lines(data, header.data_offset, header.lines + 1)
    points = None
    for element in header.elements:
        parsed = _parse_ascii_records(lines, element, "PLY")
        if element is vertex:
            points = parsed
    _refuse_lines_after(lines, header.elements[-1], "PLY")
    return points


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


# --- PCD --------------------------------------------------------------------------------------

_PCD_TYPES = {
    ("F", 4): "f4", ("F", 8): "f8",
    ("I", 1): "i1", ("I", 2): "i2", ("I", 4): "i4", ("I", 8): "i8",
    ("U", 1): "u1", ("U", 2): "u2", ("U", 4): "u4", ("U", 8): "u8",
}  # fmt: skip
_PCD_KEYS = ("VERSION", "FIELDS", "SIZE", "TYPE", "COUNT", "WIDTH", "HEIGHT", "VIEWPOINT", "POINTS")
_PCD_DATA_KINDS = ("ascii", "binary", "binary_compressed")
_PCD_END = re.compile(rb"^DATA[ \t]+(\S+)[ \t\r]*(?:\n|\Z)", re.MULTILINE)


@dataclass(frozen=True)
class _PcdHeader:
    fields: tuple  # field names, in record order
    dtypes: tuple  # numpy type code of each field
    counts: tuple  # number of values of each field
    points: int
    data: str  # "ascii", "binary" or "binary_compressed"
    data_offset: int  # byte offset of the first data byte
    lines: int  # number of header lines, where the ascii data starts
    keys: tuple  # the header keywords in the order of the file

    @property
    def point_size(self) -> int:
        return sum(np.dtype(t).itemsize * c for t, c in zip(self.dtypes, self.counts))


def _read_pcd(name: str, data: bytes) -> np.ndarray:
    header = _read_pcd_header(data)
    if header.data == "ascii":
        return _read_pcd_ascii(name, data, header)
    if header.data == "binary":
        return _read_pcd_binary(data, header)
    return _read_pcd_compressed(name, data, header)


def _read_pcd_header(data: bytes) -> _PcdHeader:
    """Parse and check a PCD header (fields, sizes, types, counts, point count, data kind)."""
    end = _PCD_END.search(data, 0, _MAX_HEADER_BYTES)
    if end is None:
        raise _BadFile("garbled PCD header (no DATA line)")
    entries = {}
    for line in data[: end.start()].decode("ascii", errors="replace").splitlines():
        words = line.split()
        if not words or words[0].startswith("#"):
            continue
        if words[0] not in _PCD_KEYS:
            raise _BadFile(f"garbled PCD header (unexpected line {_quote(line)})")
        if words[0] in entries:
            raise _BadFile(f"garbled PCD header ({words[0]} given twice)")
        entries[words[0]] = words[1:]
    kind = end.group(1).decode("ascii", errors="replace")
    if kind not in _PCD_DATA_KINDS:
        raise _BadFile(f"unsupported PCD data kind {kind!r} (expected ascii, binary or binary_compressed)")
    if "FIELDS" not in entries:
        raise _BadFile("garbled PCD header (no FIELDS line)")
    fields = tuple(entries["FIELDS"])
    sizes = _pcd_integers(entries, "SIZE", None)
    types = entries.get("TYPE")
    counts = _pcd_integers(entries, "COUNT", [1] * len(fields))
    if sizes is None or types is None:
        raise _BadFile("garbled PCD header (no SIZE or TYPE line)")
    if not len(fields) == len(sizes) == len(types) == len(counts):
        raise _BadFile(
            f"garbled PCD header (FIELDS, SIZE, TYPE and COUNT have {len(fields)}, {len(sizes)}, "
            f"{len(types)} and {len(counts)} entries)"
        )
    dtypes = []
    for field, size, kind_letter in zip(fields, sizes, types):
        if (kind_letter, size) not in _PCD_TYPES:
            raise _BadFile(
                f"garbled PCD header (field {field!r} has unsupported TYPE {kind_letter} SIZE {size})"
            )
        dtypes.append(_PCD_TYPES[(kind_letter, size)])
    if not all(axis in fields for axis in "xyz"):
        raise _BadFile(_missing_xyz(list(fields), "field", "fields", "PCD header"))
    for axis in "xyz":
        if fields.count(axis) != 1 or counts[fields.index(axis)] != 1:
            raise _BadFile(f"garbled PCD header (field {axis!r} is repeated or has a COUNT other than 1)")
    points = _pcd_point_count(entries)
    if points == 0:
        raise _BadFile("no points (PCD header announces 0 points)")
    return _PcdHeader(
        fields=fields,
        dtypes=tuple(dtypes),
        counts=tuple(counts),
        points=points,
        data=kind,
        data_offset=end.end(),
        lines=data[: end.end()].count(b"\n"),
        keys=tuple(entries),
    )


def _pcd_integers(entries: dict, key: str, default):
    if key not in entries:
        return default
    words = entries[key]
    if not all(_COUNT.fullmatch(word) for word in words):
        raise _BadFile(f"garbled PCD header ({key} {_quote(' '.join(words))} is not a list of counts)")
    return [int(word) for word in words]


def _pcd_point_count(entries: dict) -> int:
    """POINTS, checked against WIDTH x HEIGHT when both are given."""
    values = {}
    for key in ("WIDTH", "HEIGHT", "POINTS"):
        if key in entries:
            words = entries[key]
            if len(words) != 1 or not _COUNT.fullmatch(words[0]):
                raise _BadFile(f"garbled PCD header (bad {key} line)")
            values[key] = int(words[0])
    grid = values["WIDTH"] * values.get("HEIGHT", 1) if "WIDTH" in values else None
    if "POINTS" in values:
        if grid is not None and grid != values["POINTS"]:
            raise _BadFile(
                f"garbled PCD header (POINTS {values['POINTS']} but WIDTH x HEIGHT is {grid})"
            )
        return values["POINTS"]
    if grid is None:
        raise _BadFile("garbled PCD header (neither POINTS nor WIDTH)")
    return grid


def _pcd_as_element(header: _PcdHeader) -> _PlyElement:
    """The PCD record layout as a PLY-like element: one scalar property per value."""
    properties = []
    for field, dtype, count in zip(header.fields, header.dtypes, header.counts):
        properties += [_PlyProperty(field, dtype)] * count
    return _PlyElement("point", header.points, tuple(properties))


def _read_pcd_ascii(name: str, data: bytes, header: _PcdHeader) -> np.ndarray:
    # The record layout has one entry per value, and COUNT can ask for 10**9 of them: check first
    # that one record fits in the file (a value takes a digit and a separator, the last no separator).
    # Missing or extra records are found line by line below, without allocating by the count.
    values = sum(header.counts)
    available = len(data) - header.data_offset
    if 2 * values - 1 > available:
        raise _BadFile(
            f"truncated ascii PCD: header announces points of {values} values (at least {2 * values - 1} "
            f"bytes each) but only {available} bytes follow"
        )
    element = _pcd_as_element(header)
    # loadtxt takes more characters for blanks than the line parser does (form feeds, NBSP, ...);
    # it is trusted only where both see the same lines.
    table = None
    if _count_content_lines(data, header.data_offset) == header.points:
        table = _loadtxt(name, skiprows=header.lines, comments=None, encoding="latin-1")
    if table is not None and table.shape == (header.points, len(element.properties)):
        names = [prop.name for prop in element.properties]
        return np.ascontiguousarray(table[:, [names.index(axis) for axis in "xyz"]])
    lines = _numbered_lines(data, header.data_offset, header.lines + 1)
    points = _parse_ascii_records(lines, element, "PCD")
    _refuse_lines_after(lines, element, "PCD")
    return points


def _read_pcd_binary(data: bytes, header: _PcdHeader) -> np.ndarray:
    offsets, formats, size = {}, {}, 0
    for field, dtype, count in zip(header.fields, header.dtypes, header.counts):
        if field in ("x", "y", "z"):
            offsets[field], formats[field] = size, dtype
        size += np.dtype(dtype).itemsize * count
    needed = header.points * size
    available = max(len(data) - header.data_offset, 0)
    if available < needed:
        raise _BadFile(
            f"truncated binary PCD: header announces {header.points} points ({needed} bytes) "
            f"but only {available} bytes follow"
        )
    if available > needed and not _is_pcl_padding(data, header.data_offset + needed, needed):
        raise _BadFile(
            f"garbled binary PCD: {available} bytes of data but the header declares {needed} "
            f"({header.points} points of {size} bytes)"
        )
    records = np.frombuffer(data, _record_dtype(offsets, formats, size), header.points, header.data_offset)
    return _xyz_from_records(records)


def _read_pcd_compressed(name: str, data: bytes, header: _PcdHeader) -> np.ndarray:
    # open3d's PCD reader trusts its input. Its header parser leaves the point count uninitialized
    # without a POINTS (or HEIGHT) line and computes offsets in line order, and it decodes 8-byte
    # values as 0.0 without a word (open3d 0.20). Hand it only what it reads right.
    standard_order = tuple(key for key in _PCD_KEYS if key in header.keys)
    if "POINTS" not in header.keys or header.keys != standard_order:
        raise _BadFile(
            "unsupported binary_compressed PCD header (needs a POINTS line and the lines in the "
            "standard order VERSION, FIELDS, SIZE, TYPE, COUNT, WIDTH, HEIGHT, VIEWPOINT, POINTS)"
        )
    wide = [axis for axis in "xyz" if np.dtype(header.dtypes[header.fields.index(axis)]).itemsize > 4]
    if wide:
        raise _BadFile(
            f"unsupported binary_compressed PCD: 8-byte {', '.join(wide)} (open3d would read zeros); "
            "save it as binary or ascii"
        )
    # The data are two little-endian uint32 (compressed and uncompressed size) and an LZF stream.
    # Check what can be checked here: open3d would return an empty or short cloud without raising.
    available = len(data) - header.data_offset
    if available < 8:
        raise _BadFile("truncated binary_compressed PCD: no data after the header")
    compressed, uncompressed = struct.unpack_from("<II", data, header.data_offset)
    needed = header.points * header.point_size
    if uncompressed != needed:
        raise _BadFile(
            f"garbled binary_compressed PCD: data unpack to {uncompressed} bytes, but "
            f"{header.points} points take {needed}"
        )
    if available - 8 < compressed:
        raise _BadFile(
            f"truncated binary_compressed PCD: {compressed} compressed bytes announced "
            f"but only {available - 8} follow"
        )
    end = header.data_offset + 8 + compressed
    if available - 8 > compressed and not _is_pcl_padding(data, end, 8 + compressed):
        raise _BadFile(
            f"garbled binary_compressed PCD: {available - 8} bytes of data after the sizes but "
            f"{compressed} compressed bytes announced"
        )
    if uncompressed > _LZF_MAX_EXPANSION * compressed:
        # open3d would allocate the unpacked size (up to 4 GiB) before finding the stream too short.
        raise _BadFile(
            f"garbled binary_compressed PCD: {compressed} compressed bytes cannot unpack to "
            f"{uncompressed} (LZF expands at most {_LZF_MAX_EXPANSION} times)"
        )
    return _read_with_open3d(name, header.points)


# An LZF back-reference of 3 bytes copies at most 264; literal runs never expand.
_LZF_MAX_EXPANSION = 88

# PCL up to about 1.8 writes binary and binary_compressed PCD through a memory map of a file it
# first stretches to getpagesize() + the data size: such a file ends in NUL bytes filling the page
# the header took (12 of the 14 binary and binary_compressed PCD files of the real-file corpus;
# the other two, from a later PCL, end with their data).
_PCL_PAGE_SIZES = (4096, 16384, 65536)


def _is_pcl_padding(data: bytes, end: int, data_size: int) -> bool:
    """Whether the bytes from ``end`` on are an old PCL writer's padding of a ``data_size`` body."""
    return len(data) - data_size in _PCL_PAGE_SIZES and data.count(b"\0", end) == len(data) - end


def _read_with_open3d(name: str, expected: int) -> np.ndarray:
    """Read a PCD with open3d and refuse anything but the announced number of points."""
    import open3d as o3d  # deferred: importing it costs over a second

    # open3d reports a bad file as a console warning, not an exception; the count check is the test.
    try:
        with o3d.utility.VerbosityContextManager(o3d.utility.VerbosityLevel.Error):
            cloud = o3d.io.read_point_cloud(
                name, format="pcd", remove_nan_points=False, remove_infinite_points=False
            )
    except (RuntimeError, MemoryError) as exc:
        raise _BadFile(f"garbled binary_compressed PCD (open3d: {_describe(exc)})") from None
    points = np.array(cloud.points, dtype=np.float64).reshape(-1, 3)
    if len(points) != expected:
        raise _BadFile(
            f"garbled binary_compressed PCD: decoded {len(points)} of the {expected} points "
            "the header announces"
        )
    return points


# --- CSV, TXT, XYZ ----------------------------------------------------------------------------


@dataclass(frozen=True)
class _TableLayout:
    header_line: int  # 1-based line number of the header row, 0 when there is none
    delimiter: Optional[str]  # ",", ";", "\t", or None for runs of whitespace
    columns: tuple  # indices of the x, y, z columns


# A row of a point table is at most a few hundred characters. A much longer line is not a table (and
# the csv module refuses a field over 131,072 characters); this limit keeps it a one-line error.
_MAX_LINE_BYTES = 1 << 16
_LINE_BREAK = re.compile(rb"\r\n|\r|\n")


def _read_text_table(name: str) -> np.ndarray:
    """Read x, y, z from a delimited text table (.csv, .txt, .xyz)."""
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


# --- writing ----------------------------------------------------------------------------------


def _as_points(points) -> np.ndarray:
    array = np.asarray(points)
    if array.dtype.kind not in "iuf":
        raise ValueError(f"points must be a numeric array, got dtype {array.dtype}")
    if array.ndim != 2 or array.shape[1] != 3:
        raise ValueError(f"points must have shape (n, 3), got {array.shape}")
    return np.ascontiguousarray(array, dtype=np.float64)


def _encode_ply(points: np.ndarray, float32: bool = False) -> bytes:
    kind, dtype = ("float", "<f4") if float32 else ("double", "<f8")
    header = (
        "ply\n"
        "format binary_little_endian 1.0\n"
        "comment written by holecli\n"
        f"element vertex {len(points)}\n"
        f"property {kind} x\n"
        f"property {kind} y\n"
        f"property {kind} z\n"
        "end_header\n"
    )
    return header.encode("ascii") + points.astype(dtype).tobytes()


def _encode_pcd(points: np.ndarray, float32: bool = False) -> bytes:
    size, dtype = (4, "<f4") if float32 else (8, "<f8")
    header = (
        "# .PCD v0.7 - Point Cloud Data file format\n"
        "VERSION 0.7\n"
        "FIELDS x y z\n"
        f"SIZE {size} {size} {size}\n"
        "TYPE F F F\n"
        "COUNT 1 1 1\n"
        f"WIDTH {len(points)}\n"
        "HEIGHT 1\n"
        "VIEWPOINT 0 0 0 1 0 0 0\n"
        f"POINTS {len(points)}\n"
        "DATA binary\n"
    )
    return header.encode("ascii") + points.astype(dtype).tobytes()


def _encode_text(points: np.ndarray, header: bool) -> bytes:
    # %r of a Python float is the shortest text that reads back to the same double.
    row = "%r,%r,%r\n" if header else "%r %r %r\n"
    body = (row * len(points)) % tuple(points.ravel().tolist())
    return (("x,y,z\n" if header else "") + body).encode("ascii")
