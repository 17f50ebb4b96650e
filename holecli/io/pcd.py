"""PCD: reading (DATA ascii, binary and binary_compressed, organized clouds too) and writing
(DATA binary, double or float x, y, z).

:func:`read_pcd` parses and checks the header; ascii and binary bodies are read with numpy, and a
``binary_compressed`` body (LZF) is decompressed by open3d, imported only then, once the header
and the sizes before the stream have been checked. The NUL padding of old PCL releases is
accepted (see :func:`_is_pcl_padding`). The coordinates may be named ``X Y Z`` (PDAL writes them so); a
header naming one in both cases (``x`` and ``X``) is refused as ambiguous. Called through
:func:`holecli.io.read_cloud`.
"""

from __future__ import annotations

import re
import struct
from dataclasses import dataclass

import numpy as np

from holecli.io._common import (
    _COUNT,
    _MAX_HEADER_BYTES,
    _BadFile,
    _count_content_lines,
    _describe,
    _loadtxt,
    _missing_xyz,
    _numbered_lines,
    _parse_ascii_records,
    _PlyElement,
    _PlyProperty,
    _quote,
    _record_dtype,
    _refuse_lines_after,
    _xyz_from_records,
)

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
    fields: tuple  # field names, in record order (X, Y, Z as x, y, z)
    original_fields: tuple  # as the header spells them
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


def read_pcd(name: str, data: bytes) -> np.ndarray:
    """Read the x, y, z of every point of a PCD file (DATA ascii, binary or binary_compressed).

    Parameters
    ----------
    name : str
        The file's path; the ascii reader reads it again with numpy, and open3d reads it for
        ``binary_compressed``.
    data : bytes
        The whole file, not empty and not only whitespace.

    Returns
    -------
    points : (n, 3) float64 ndarray
        One row per point, n >= 1, non-finite rows (an organized cloud's empty cells) included.

    Raises
    ------
    _BadFile
        If the header is garbled or has no x, y, z fields, or the data disagree with it.
    """
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
    fields = _lower_case_xyz(fields)
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
        original_fields=tuple(entries["FIELDS"]),
        dtypes=tuple(dtypes),
        counts=tuple(counts),
        points=points,
        data=kind,
        data_offset=end.end(),
        lines=data[: end.end()].count(b"\n"),
        keys=tuple(entries),
    )


def _lower_case_xyz(fields: tuple) -> tuple:
    """``fields`` with ``X``, ``Y``, ``Z`` named ``x``, ``y``, ``z`` (PDAL writes upper-case names).

    Refused: a coordinate named in both cases (``x`` and ``X``): which one holds it is not known.
    """
    for axis in "xyz":
        spellings = [field for field in fields if field.lower() == axis]
        if len(set(spellings)) > 1:
            raise _BadFile(
                f"garbled PCD header (fields {' and '.join(map(repr, sorted(set(spellings))))} both name "
                f"coordinate {axis}: which one holds it is ambiguous)"
            )
    return tuple(field.lower() if field.lower() in ("x", "y", "z") else field for field in fields)


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
    if not {"x", "y", "z"} <= set(header.original_fields):
        raise _BadFile(
            "unsupported binary_compressed PCD with upper-case field names X, Y, Z (open3d reads only "
            "x, y, z); save it as binary or ascii"
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


def encode_pcd(points: np.ndarray, float32: bool = False) -> bytes:
    """The bytes of a ``DATA binary`` PCD file (v0.7, unorganized) holding ``points``.

    Parameters
    ----------
    points : (n, 3) float64 ndarray
        The points to write.
    float32 : bool
        Write ``SIZE 4`` x, y, z instead of ``SIZE 8``.

    Returns
    -------
    bytes
        The header and the point data.
    """
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
