"""PLY: reading (ascii, binary_little_endian, binary_big_endian; any elements and property types)
and writing (binary_little_endian, double or float x, y, z).

:func:`read_ply` parses and checks the header, then reads the vertices' x, y, z with numpy. Every
element of a binary file is stepped over (faces' vertex indices are checked too), and the data
must end with the last one; an ascii body is one non-blank line per record. Called through
:func:`holecli.io.read_cloud`, which has already checked that the file exists and is not empty.
"""

from __future__ import annotations

import re
import struct
from dataclasses import dataclass
from typing import Optional

import numpy as np

from holecli.io._common import (
    _COUNT,
    _MAX_HEADER_BYTES,
    _BadFile,
    _count_content_lines,
    _loadtxt,
    _missing_xyz,
    _numbered_lines,
    _parse_ascii_records,
    _PlyElement,
    _PlyProperty,
    _quote,
    _record_dtype,
    _refuse_lines_after,
    _unit,
    _xyz_from_records,
)

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


@dataclass(frozen=True)
class _PlyHeader:
    format: str  # "ascii", "binary_little_endian" or "binary_big_endian"
    elements: tuple
    data_offset: int  # byte offset of the first data byte
    lines: int  # number of header lines, where the ascii data starts


def read_ply(name: str, data: bytes) -> np.ndarray:
    """Read the x, y, z of every vertex of a PLY file.

    Parameters
    ----------
    name : str
        The file's path; the ascii reader reads it again with numpy.
    data : bytes
        The whole file, not empty and not only whitespace.

    Returns
    -------
    points : (n, 3) float64 ndarray
        One row per vertex, n >= 1, non-finite rows included.

    Raises
    ------
    _BadFile
        If the header is garbled or has no vertex x, y, z, or the data disagree with it.
    """
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


def encode_ply(points: np.ndarray, float32: bool = False) -> bytes:
    """The bytes of a binary_little_endian PLY file holding ``points`` as its vertices.

    Parameters
    ----------
    points : (n, 3) float64 ndarray
        The points to write.
    float32 : bool
        Write ``property float`` x, y, z instead of ``property double``.

    Returns
    -------
    bytes
        The header and the vertex data.
    """
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
