"""Fuzz test of holecli.io: damaged copies of sample and real files are refused, or read as before.

Every source file (cut-down sample clouds in each format and layout the readers handle, and the
small files of the real-file corpus) is damaged in the ways files get damaged: cut short, a byte
flipped in the header or the body, a byte inserted or removed, garbage appended, a header count or
type edited by hand. What :func:`read_cloud` may do then depends on whether the damage can be seen:

- REFUSE: the file no longer agrees with its header (sizes, counts, line counts): LoadError.
- SAME: LoadError, or exactly the points of the undamaged file (a changed comment, a header field
  the reader does not use, a byte in a triangle's indices).
- ROW: LoadError, or as many rows with only the damaged one changed, or dropped when it became NaN
  (a byte of a binary number, a digit of a text number: no reader can tell). Without a known row
  (real files, the LZF stream of a compressed PCD, a relabelled type), only the count is checked.
- LAST: an ascii PLY/PCD cut short: LoadError, or all rows but the last unchanged.
- Tables (CSV, TXT, XYZ) have no count to check: a cut is a shorter table (PREFIX), a damaged
  line can add or remove one row (NEAR), appended rows are more rows (EXTEND). Rows before the
  damage must be unchanged.
- IDENTICAL: appended blank lines to a text file: the same points, never an error.

And always: never another exception type or a warning, and a one-line message naming the file.
The seeds are fixed, so a failure names a mutant that can be made again.
"""

import enum
import os
import re
import struct
import subprocess
import sys
import tempfile
import warnings
import zlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Optional

import numpy as np
import pytest
from test_io import REALDATA

from holecli.errors import LoadError
from holecli.io import load_points, read_cloud, save_points

pytestmark = pytest.mark.slow  # the quick loop: pytest -m "not slow"

SAMPLES = Path(__file__).resolve().parents[2] / "sample_clouds"
SEED = 8  # issue 8
REAL_FILE_MAX_BYTES = 64_000
PCL_PAGE = 4096


class Expect(enum.Enum):
    REFUSE = "refuse"
    SAME = "same"
    ROW = "row"
    LAST = "last"
    PREFIX = "prefix"
    NEAR = "near"
    EXTEND = "extend"
    IDENTICAL = "identical"


@dataclass
class Source:
    """An undamaged file and what the fuzzer needs to know of its layout."""

    name: str
    content: bytes
    kind: str  # "binary", "ascii" (PLY/PCD) or "table" (CSV/TXT/XYZ)
    header_end: int  # offset of the first data byte (tables: the end of the header line, or 0)
    # Body bytes: the expectation of a flipped byte and, when known, the row it belongs to.
    body: Callable[[int], tuple] = field(default=lambda position: (Expect.ROW, None))

    @property
    def extension(self):
        return Path(self.name).suffix


@dataclass
class Mutant:
    description: str
    content: bytes
    expect: Expect
    row: Optional[int] = None  # the damaged row (ROW); tables: the rows before it must be unchanged
    continues_last_line: bool = False  # EXTEND: the tail may change the original's last row


# --- sources ----------------------------------------------------------------------------------

_PLY_TYPES = {"f4": "float", "f8": "double", "u1": "uchar", "i4": "int"}


def _structured(points, coordinate, extras=()):
    records = np.zeros(len(points), dtype=[("x", coordinate), ("y", coordinate), ("z", coordinate), *extras])
    for column, axis in enumerate("xyz"):
        records[axis] = points[:, column]
    for index, (name, _) in enumerate(extras):
        records[name] = (np.arange(len(points)) * (index + 3)) % 251
    return records


def _ply(fmt, records, faces=()):
    lines = ["ply", f"format {fmt} 1.0", "comment fuzz source", f"element vertex {len(records)}"]
    lines += [f"property {_PLY_TYPES[records.dtype[name].str[1:]]} {name}" for name in records.dtype.names]
    if len(faces):
        lines += [f"element face {len(faces)}", "property list uchar int vertex_indices"]
    head = ("\n".join(lines) + "\nend_header\n").encode()
    if fmt == "ascii":
        rows = [" ".join(repr(value) for value in record) for record in records.tolist()]
        rows += [" ".join(str(value) for value in (len(face), *face)) for face in faces]
        return head + ("\n".join(rows) + "\n").encode()
    order = ">" if fmt == "binary_big_endian" else "<"
    body = records.astype(records.dtype.newbyteorder(order)).tobytes()
    body += b"".join(struct.pack(f"{order}B{len(face)}i", len(face), *face) for face in faces)
    return head + body


def _pcd(data, records):
    kinds = {"f": "F", "u": "U", "i": "I"}
    names = records.dtype.names
    head = (
        "# .PCD v0.7 - fuzz source\nVERSION 0.7\n"
        f"FIELDS {' '.join(names)}\n"
        f"SIZE {' '.join(str(records.dtype[n].itemsize) for n in names)}\n"
        f"TYPE {' '.join(kinds[records.dtype[n].kind] for n in names)}\n"
        f"COUNT {' '.join('1' for _ in names)}\n"
        f"WIDTH {len(records)}\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS {len(records)}\nDATA {data}\n"
    ).encode()
    if data == "ascii":
        return head + "".join(" ".join(repr(v) for v in record) + "\n" for record in records.tolist()).encode()
    return head + records.astype(records.dtype.newbyteorder("<")).tobytes()


def _header_end(content):
    match = re.search(rb"^(end_header|DATA[ \t]+\S+)[ \t\r]*\n", content, re.MULTILINE)
    return match.end()


def _binary_body(start, records, padding_from=None):
    """The body layout of a generated binary file: records, then SAME (faces) or REFUSE (padding)."""
    size, count = records.dtype.itemsize, len(records)
    xyz = set()
    for axis in "xyz":
        offset = records.dtype.fields[axis][1]
        xyz.update(range(offset, offset + records.dtype[axis].itemsize))

    def body(position):
        if position < start + size * count:
            row, within = divmod(position - start, size)
            return (Expect.ROW, row) if within in xyz else (Expect.SAME, None)
        if padding_from is not None and position >= padding_from:
            return Expect.REFUSE, None
        return Expect.SAME, None  # faces

    return body


def _generated_sources():
    table1 = load_points(SAMPLES / "table1.ply")[:1500]
    stripes = load_points(SAMPLES / "stripes_three_holes.ply")[:1200]
    noise = load_points(SAMPLES / "table1_noise30.pcd")[:1500]
    rng = np.random.default_rng(SEED)
    triangles = rng.integers(0, 1200, size=(400, 3)).tolist()
    mixed = [face + [int(rng.integers(0, 1200))] * (i % 2) for i, face in enumerate(triangles[:150])]
    colours = [("red", "u1"), ("green", "u1"), ("blue", "u1"), ("intensity", "f4")]
    sources = []

    def binary(name, content, records, faces=(), padded=False):
        start = _header_end(content)
        data_end = start + records.dtype.itemsize * len(records) + sum(1 + 4 * len(face) for face in faces)
        if padded:
            content = content + b"\0" * (PCL_PAGE - start)
            assert len(content) == PCL_PAGE + data_end - start
        body = _binary_body(start, records, padding_from=data_end if padded else None)
        sources.append(Source(name, content, "binary", start, body))

    def ascii_(name, content):
        # One record per line, the vertices first: a damaged line is the row of that number.
        start = _header_end(content)
        sources.append(Source(name, content, "ascii", start, lambda p: (Expect.ROW, content.count(b"\n", start, p))))

    records = _structured(table1, "f8")
    binary("table1_le_double.ply", _ply("binary_little_endian", records), records)
    records = _structured(stripes, "f4", colours)
    binary("stripes_be_float_colours_triangles.ply", _ply("binary_big_endian", records, triangles), records, triangles)
    records = _structured(stripes, "f8")
    binary("stripes_le_double_mixed_faces.ply", _ply("binary_little_endian", records, mixed), records, mixed)
    ascii_("stripes_ascii_colours_triangles.ply", _ply("ascii", _structured(stripes, "f4", colours), triangles[:100]))
    ascii_("table1_ascii_double.ply", _ply("ascii", _structured(table1, "f8")))
    records = _structured(noise, "f8")
    binary("noise30_binary_double.pcd", _pcd("binary", records), records)
    records = _structured(noise, "f4", [("rgb", "u4")])
    binary("noise30_binary_float_rgb.pcd", _pcd("binary", records), records)
    records = _structured(noise, "f4")
    binary("noise30_binary_pcl_padded.pcd", _pcd("binary", records), records, padded=True)
    ascii_("noise30_ascii_intensity.pcd", _pcd("ascii", _structured(noise, "f4", [("intensity", "f4")])))
    sources += _compressed_sources(noise)
    for name, points, extension in (
        ("no_hole.csv", load_points(SAMPLES / "no_hole.csv")[:600], ".csv"),
        ("countersunk_outliers.xyz", load_points(SAMPLES / "countersunk_outliers.xyz")[:600], ".xyz"),
    ):
        sources.append(_table_source(name, _saved(points, extension)))
    rows = "".join(f"p{i};{x!r};{y!r};{z!r};{i % 7}\n" for i, (x, y, z) in enumerate(noise[:400].tolist()))
    sources.append(_table_source("noise30_semicolon_named.csv", ("id;x;y;z;intensity\n" + rows).encode()))
    return sources


def _saved(points, extension):
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / f"a{extension}"
        save_points(path, points)
        return path.read_bytes()


def _compressed_sources(points):
    try:
        import open3d as o3d
    except ImportError:
        return []
    with tempfile.TemporaryDirectory() as folder:
        path = str(Path(folder) / "a.pcd")
        o3d.io.write_point_cloud(path, o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points)), compressed=True)
        content = Path(path).read_bytes()
    start = _header_end(content)
    sources = []
    for padded in (False, True):
        data = content + (b"\0" * (PCL_PAGE - start) if padded else b"")

        def body(position, padded=padded):
            if position < start + 8:
                return Expect.REFUSE, None  # the compressed and the unpacked size
            if padded and position >= len(content):
                return Expect.REFUSE, None
            return Expect.ROW, None  # inside the LZF stream: any row, or all after, may change

        name = "noise30_compressed_pcl_padded.pcd" if padded else "noise30_compressed_open3d.pcd"
        sources.append(Source(name, data, "binary", start, body))
    return sources


def _table_source(name, content):
    first = content.split(b"\n", 1)[0]
    has_header = not all(_is_number(token) for token in re.split(rb"[,;\s]+", first) if token)
    header_end = len(first) if has_header else 0
    header_lines = 1 if has_header else 0

    def body(position):
        # Rows fully before the damaged line are unchanged.
        return Expect.NEAR, max(content.count(b"\n", 0, position) - header_lines, 0)

    return Source(name, content, "table", header_end, body)


def _is_number(token):
    try:
        float(token)
    except ValueError:
        return False
    return True


def _real_sources():
    if not REALDATA.is_dir():
        return []
    sources = []
    for path in sorted(REALDATA.iterdir()):
        if path.suffix.lower() not in (".ply", ".pcd", ".xyz", ".csv", ".txt"):
            continue
        if path.stat().st_size > REAL_FILE_MAX_BYTES:
            continue
        try:
            read_cloud(path)
        except LoadError:
            continue  # the corpus's refused files are checked in test_io
        content = path.read_bytes()
        if path.suffix.lower() in (".xyz", ".csv", ".txt"):
            sources.append(_table_source(f"real:{path.name}", content))
            continue
        start = _header_end(content)
        header = content[:start]
        binary = b"binary" in header.split(b"\nDATA")[-1] if path.suffix == ".pcd" else b"format binary" in header
        source = Source(f"real:{path.name}", content, "binary" if binary else "ascii", start)
        if binary and path.suffix == ".pcd":
            # Past the data is nothing, or old PCL's NUL padding: any change there is refused. So is
            # one in a compressed file's two sizes.
            if b"binary_compressed" in header:
                sizes, end = start + 8, start + 8 + struct.unpack_from("<I", content, start)[0]
            else:
                sizes, end = start, start + _pcd_point_count(header) * _pcd_point_size(header)
            source.body = lambda p, sizes=sizes, end=end: (Expect.REFUSE if p < sizes or p >= end else Expect.ROW, None)
        sources.append(source)
    return sources


def _pcd_words(header, key):
    return re.search(rb"^" + key + rb"[ \t]+(.*)$", header, re.MULTILINE).group(1).split()


def _pcd_point_count(header):
    return int(_pcd_words(header, b"POINTS")[0])


def _pcd_point_size(header):
    sizes, counts = _pcd_words(header, b"SIZE"), _pcd_words(header, b"COUNT")
    return sum(int(size) * int(count) for size, count in zip(sizes, counts))


# --- mutants ----------------------------------------------------------------------------------


def _random_mutants(source, rng):
    content, start = source.content, source.header_end
    binary, table = source.kind == "binary", source.kind == "table"
    mutants = []

    def body_position():
        low = start + 1 if table and start else start  # a table's header line ends at its newline
        return int(rng.integers(low, len(content)))

    def header_position():
        return int(rng.integers(0, start))

    for _ in range(2):
        cut = int(rng.integers(0, len(content)))
        if binary:
            expect = Expect.REFUSE
        elif table:
            expect = Expect.PREFIX
        else:
            expect = Expect.LAST
        row = max(content.count(b"\n", 0, cut) - (1 if start else 0), 0) if table else None
        mutants.append(Mutant(f"cut at {cut}", content[:cut], expect, row))
    for _ in range(2):
        if start == 0:
            break
        position = header_position()
        mutants.append(_flip(content, position, rng, _header_flip_expectation(source, position)))
    for _ in range(3):
        position = body_position()
        expect, row = source.body(position)
        mutants.append(_flip(content, position, rng, (expect, row)))
    for where in ("header", "body"):
        if where == "header" and start == 0:
            continue
        position = header_position() if where == "header" else body_position()
        byte = bytes([int(rng.choice(list(b"0 7\n.x-e\t#\xff")))])
        if where == "header":
            expect, row = Expect.SAME, None
        elif binary:
            expect, row = Expect.REFUSE, None
        else:
            expect, row = source.body(position)
            expect = Expect.NEAR if table else Expect.ROW
        inserted = content[:position] + byte + content[position:]
        mutants.append(Mutant(f"insert {byte!r} at {position}", inserted, expect, row))
        mutants.append(Mutant(f"remove byte {position}", content[:position] + content[position + 1 :], expect, row))
    garbage = [b"\n", b"\r\n \n", b"\0", b"1 2 3\n", rng.bytes(int(rng.integers(1, 40)))]
    for tail in (garbage[int(rng.integers(0, 3))], garbage[int(rng.integers(3, 5))]):
        mutant = Mutant(f"append {tail[:12]!r}", content + tail, _append_expectation(source, tail))
        mutant.continues_last_line = not content.endswith(b"\n")
        mutants.append(mutant)
    return mutants


def _flip(content, position, rng, expectation):
    expect, row = expectation
    old = content[position]
    new = (old + int(rng.integers(1, 256))) % 256
    damaged = content[:position] + bytes([new]) + content[position + 1 :]
    return Mutant(f"byte {position}: {bytes([old])!r} -> {bytes([new])!r}", damaged, expect, row)


def _header_flip_expectation(source, position):
    line_start = source.content.rfind(b"\n", 0, position) + 1
    if source.kind == "binary" and source.content.startswith(b"TYPE", line_start):
        # F, I and U of one size read the same bytes differently: the values change, not the size.
        return Expect.ROW, None
    return Expect.SAME, None


def _append_expectation(source, tail):
    if source.kind == "binary":
        return Expect.REFUSE  # no padding but old PCL's full page of NUL bytes is accepted
    if not tail.strip():
        return Expect.IDENTICAL  # blank lines
    if not source.content.endswith(b"\n"):
        # The tail continues the last line: a digit changes the last number; for a table, the
        # last row may change and more may follow.
        return Expect.EXTEND if source.kind == "table" else Expect.LAST
    return Expect.EXTEND if source.kind == "table" else Expect.REFUSE


def _header_edits(source):
    """Hand edits of a PLY or PCD header: counts, types, the data kind or byte order."""
    head, body = source.content[: source.header_end], source.content[source.header_end :]
    binary = source.kind == "binary"
    edits = []

    def edit(description, pattern, replace, expect):
        new, done = re.subn(pattern, replace, head, count=1, flags=re.MULTILINE)
        if done and new != head:
            edits.append(Mutant(description, new + body, expect))

    if head.startswith(b"ply"):
        for element in (b"vertex", b"face"):
            match = re.search(rb"^element " + element + rb" (\d+)", head, re.MULTILINE)
            if match:
                for label, count in _changed_counts(int(match.group(1))):
                    pattern = rb"^(element " + element + rb") \d+"
                    edit(f"element {element.decode()} {label}", pattern, rb"\g<1> %d" % count, Expect.REFUSE)
        match = re.search(rb"^property (\w+) x\b", head, re.MULTILINE)
        if match:
            kind = match.group(1)
            sizes = {b"char": 1, b"uchar": 1, b"int8": 1, b"uint8": 1, b"short": 2, b"ushort": 2, b"int16": 2,
                     b"uint16": 2, b"int": 4, b"uint": 4, b"int32": 4, b"uint32": 4, b"float": 4, b"float32": 4,
                     b"double": 8, b"float64": 8}  # fmt: skip
            for target in ({b"float": b"double", b"float32": b"float64"}.get(kind, b"float"), b"int"):
                if target == kind:
                    continue
                same_size = sizes.get(kind) == sizes[target]
                expect = Expect.SAME if not binary else (Expect.ROW if same_size else Expect.REFUSE)
                edit(f"x relabelled {target.decode()}", rb"^property \w+ x\b", b"property " + target + b" x", expect)
        little, big = b"binary_little_endian", b"binary_big_endian"
        for old, new in ((little, big), (big, little)):
            # Same sizes, every number byte-swapped: only the count can be checked.
            edit(f"format {new.decode()}", rb"^format " + old, b"format " + new, Expect.ROW)
        edit("format ascii -> binary", rb"^format ascii", b"format binary_little_endian", Expect.REFUSE)
        edit("format binary -> ascii", rb"^format binary_\w+", b"format ascii", Expect.REFUSE)
        return edits
    points = _pcd_point_count(head)
    organized = re.search(rb"^HEIGHT[ \t]+(\d+)", head, re.MULTILINE)
    for label, count in _changed_counts(points):
        changed = re.sub(rb"^POINTS[ \t]+\d+", b"POINTS %d" % count, head, count=1, flags=re.MULTILINE)
        if not organized or organized.group(1) == b"1":
            changed = re.sub(rb"^WIDTH[ \t]+\d+", b"WIDTH %d" % count, changed, count=1, flags=re.MULTILINE)
        edits.append(Mutant(f"POINTS {label}", changed + body, Expect.REFUSE))
    fields = _pcd_words(head, b"FIELDS")
    x = fields.index(b"x")
    sizes, types = _pcd_words(head, b"SIZE"), _pcd_words(head, b"TYPE")
    if types[x] == b"F":
        swapped = [b"8" if size == b"4" else b"4" for size in sizes[x : x + 1]]
        new_sizes = b" ".join(sizes[:x] + swapped + sizes[x + 1 :])
        expect = Expect.REFUSE if binary else Expect.SAME
        edit(f"SIZE of x {sizes[x].decode()} -> {swapped[0].decode()}", rb"^SIZE .*$", b"SIZE " + new_sizes, expect)
        new_types = b" ".join(types[:x] + [b"I"] + types[x + 1 :])
        edit("TYPE of x F -> I", rb"^TYPE .*$", b"TYPE " + new_types, Expect.ROW if binary else Expect.SAME)
    kind = re.search(rb"^DATA[ \t]+(\S+)", head, re.MULTILINE).group(1)
    for new in (b"ascii", b"binary", b"binary_compressed"):
        if new != kind:
            edit(f"DATA {kind.decode()} -> {new.decode()}", rb"^DATA[ \t]+\S+", b"DATA " + new, Expect.REFUSE)
    return edits


def _changed_counts(count):
    changes = {
        "+1": count + 1,
        "-1": count - 1,
        "+10%": count + max(1, count // 10),
        "-10%": count - max(1, count // 10),
        "halved": count // 2,
        "doubled": count * 2,
    }
    seen = set()
    for label, value in changes.items():
        if value != count and value >= 0 and value not in seen:
            seen.add(value)
            yield label, value


# --- checking ---------------------------------------------------------------------------------


def _mutants(source):
    rng = np.random.default_rng([SEED, zlib.crc32(source.name.encode())])
    mutants = _random_mutants(source, rng)
    if source.kind != "table":
        mutants += _header_edits(source)
    return mutants


def _read(path):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        return read_cloud(path)


def _verdict(mutant, path, original):
    """None if the outcome is allowed, else what is wrong."""
    try:
        cloud = _read(path)
    except LoadError as exc:
        if str(exc) != f"{path}: {exc.problem}" or "\n" in str(exc):
            return f"message not one line naming the file: {str(exc)!r}"
        if mutant.expect is Expect.IDENTICAL:
            return f"refused: {exc.problem}"
        return None
    except Exception as exc:  # noqa: BLE001 - any other exception is the failure being looked for
        return f"{type(exc).__name__}: {exc}"
    points, reference = cloud.points, original.points
    rows, reference_rows = len(points) + cloud.dropped, len(reference) + original.dropped
    if points.dtype != np.float64 or points.ndim != 2 or points.shape[1] != 3 or not np.isfinite(points).all():
        return f"bad points array {points.dtype} {points.shape}"
    same = rows == reference_rows and cloud.dropped == original.dropped and np.array_equal(points, reference)
    expect = mutant.expect
    if expect is Expect.REFUSE:
        return f"read {len(points)} points (+{cloud.dropped} dropped), expected a LoadError"
    if expect in (Expect.SAME, Expect.IDENTICAL):
        return None if same else f"read different points ({len(points)} +{cloud.dropped} dropped)"
    if expect is Expect.ROW:
        if rows != reference_rows:
            return f"read {rows} rows, expected {reference_rows}"
        if mutant.row is None or original.dropped:
            return None
        if cloud.dropped == 0:
            changed = np.flatnonzero((points != reference).any(axis=1))
            return None if set(changed.tolist()) <= {mutant.row} else f"rows {changed[:5].tolist()} changed"
        kept = np.delete(reference, mutant.row, axis=0) if mutant.row < len(reference) else reference
        if cloud.dropped == 1 and np.array_equal(points, kept):
            return None
        return "rows other than the damaged one changed"
    if expect is Expect.LAST:
        if rows != reference_rows or cloud.dropped != original.dropped:
            return f"read {rows} rows, expected {reference_rows}"
        return None if np.array_equal(points[:-1], reference[:-1]) else "rows before the last changed"
    # Tables: the rows before the damaged line are unchanged.
    before = mutant.row if mutant.row is not None else 0
    if original.dropped == 0 and not np.array_equal(points[:before], reference[:before]):
        return f"rows before row {before} changed"
    if expect is Expect.PREFIX:
        return None if rows <= reference_rows else f"a cut table has {rows} rows, more than {reference_rows}"
    if expect is Expect.NEAR:
        return None if abs(rows - reference_rows) <= 1 else f"{rows} rows, expected {reference_rows} +- 1"
    if expect is Expect.EXTEND:
        keep = reference_rows - 1 if mutant.continues_last_line else reference_rows
        if rows < keep or (original.dropped == 0 and not np.array_equal(points[:keep], reference[:keep])):
            return "the original rows changed"
        return None
    raise AssertionError(expect)


SOURCES = {}


def _source(name):
    """The source of that name, or None for a real file that does not load undamaged."""
    if not SOURCES:
        for source in _generated_sources() + _real_sources():
            SOURCES[source.name] = source
    return SOURCES.get(name)


def _source_names():
    names = [
        "table1_le_double.ply", "stripes_be_float_colours_triangles.ply", "stripes_le_double_mixed_faces.ply",
        "stripes_ascii_colours_triangles.ply", "table1_ascii_double.ply", "noise30_binary_double.pcd",
        "noise30_binary_float_rgb.pcd", "noise30_binary_pcl_padded.pcd", "noise30_ascii_intensity.pcd",
        "noise30_compressed_open3d.pcd", "noise30_compressed_pcl_padded.pcd", "no_hole.csv",
        "countersunk_outliers.xyz", "noise30_semicolon_named.csv",
    ]  # fmt: skip
    if REALDATA.is_dir():
        names += [
            f"real:{path.name}"
            for path in sorted(REALDATA.iterdir())
            if path.suffix.lower() in (".ply", ".pcd", ".xyz") and path.stat().st_size <= REAL_FILE_MAX_BYTES
        ]
    return names


@pytest.mark.parametrize("name", _source_names())
def test_damaged_files_are_refused_or_read_unchanged(tmp_path, name):
    if name.startswith("noise30_compressed"):
        pytest.importorskip("open3d")
    source = _source(name)
    if source is None:
        pytest.skip(f"{name} does not load undamaged (test_io checks that it is refused)")
    path = tmp_path / f"mutant{source.extension}"
    path.write_bytes(source.content)
    original = _read(path)
    failures = []
    for mutant in _mutants(source):
        path.write_bytes(mutant.content)
        problem = _verdict(mutant, path, original)
        if problem:
            failures.append(f"{mutant.description} [{mutant.expect.value}]: {problem}")
    assert not failures, f"{len(failures)} mutants of {name}:\n" + "\n".join(failures)


# --- E57 ----------------------------------------------------------------------------------------
#
# Every byte of an E57 file is under a page's CRC-32C, so a flipped, cut or appended byte is refused
# by the checksum. The mutants that matter lie with valid checksums (e57_edit recomputes every
# page's CRC): a count or an offset the data does not hold, a prototype that changes the size of a
# record, XML nested too deep, a pose not finite or not numbers. Each must be refused; a pose written
# in another order and blank space in the XML must read the same points.

E57_DATA = Path(__file__).resolve().parents[1] / "data" / "e57"


def _e57_sources():
    pye57 = pytest.importorskip("pye57")
    from test_e57 import write_scaled_e57

    sources = {}
    rng = np.random.default_rng(SEED)
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "a.e57"
        first, second = rng.uniform(-1, 1, (300, 3)), rng.uniform(-1, 1, (200, 3))
        invalid = (np.arange(300) % 37 == 0).astype(np.int8) * 2
        with pye57.E57(str(path), mode="w") as e57:
            for points, flags, rotation, translation in ((first, invalid, [1, 0, 0, 0], [0, 0, 0]),
                                                         (second, None, [0.8, 0, 0.6, 0], [1, -2, 0.5])):
                data = {name: np.ascontiguousarray(points[:, axis])
                        for axis, name in enumerate(("cartesianX", "cartesianY", "cartesianZ"))}
                if flags is not None:
                    data["cartesianInvalidState"] = flags
                e57.write_scan_raw(data, rotation=np.asarray(rotation, float), translation=np.asarray(translation, float))
        sources["pye57_two_scans_pose_flags.e57"] = path.read_bytes()
        write_scaled_e57(path, rng.uniform(-2, 2, (700, 3)))
        sources["libe57_scaled_integers.e57"] = path.read_bytes()
    for path in sorted(E57_DATA.glob("*.e57")):
        sources[f"real:{path.name}"] = path.read_bytes()
    return sources


def _e57_mutants(name, content):
    from e57_edit import first_packet, logical, points_section, to_physical, with_logical, with_xml, xml_of

    rng = np.random.default_rng([SEED, zlib.crc32(name.encode())])
    mutants = []
    for position in rng.integers(0, len(content), size=8):
        mutants.append(_flip(content, int(position), rng, (Expect.REFUSE, None)))
    for cut in (int(rng.integers(1, len(content))), len(content) - 1024, len(content) - 1):
        mutants.append(Mutant(f"cut at {cut}", content[:cut], Expect.REFUSE))
    mutants.append(Mutant("append a zero byte", content + b"\0", Expect.REFUSE))
    mutants.append(Mutant("append a page with a valid CRC", content + physical_page(), Expect.REFUSE))

    def xml_edit(description, edit, expect):
        xml = xml_of(content)
        new = edit(xml)
        if new != xml:
            mutants.append(Mutant(description, with_xml(content, lambda _: new), expect))

    counts = [int(value) for value in re.findall(rb'recordCount="(\d+)"', xml_of(content))]
    for scan, count in enumerate(counts):
        for label, new in [*_changed_counts(count), ("10^8", 10 ** 8), ("0", 0)]:
            def recount(xml, scan=scan, new=new):
                matches = list(re.finditer(rb'recordCount="\d+"', xml))
                where = matches[scan]
                return xml[: where.start()] + b'recordCount="%d"' % new + xml[where.end():]
            xml_edit(f"scan {scan} recordCount {label}", recount, Expect.REFUSE)
    for change in (4, -4, 1024, 10 ** 7):
        xml_edit(f"fileOffset {change:+d}", lambda xml, c=change: re.sub(
            rb'fileOffset="(\d+)"', lambda m: b'fileOffset="%d"' % (int(m.group(1)) + c), xml, count=1), Expect.REFUSE)
    section, packet = points_section(content), first_packet(content)
    for change in (4, -4, 1020):
        moved = (to_physical(packet) + change).to_bytes(8, "little")
        mutants.append(Mutant(f"dataPhysicalOffset {change:+d}", with_logical(content, section + 16, moved), Expect.REFUSE))
    body = logical(content)
    streams = int.from_bytes(body[packet + 4: packet + 6], "little")
    lengths = [int.from_bytes(body[packet + 6 + 2 * i: packet + 8 + 2 * i], "little") for i in range(streams)]
    for i in range(streams - 1):
        if lengths[i] >= 4:
            swapped = (lengths[i] - 4).to_bytes(2, "little") + (lengths[i + 1] + 4).to_bytes(2, "little")
            mutants.append(Mutant(f"bytestreams {i}, {i + 1}: 4 bytes moved", with_logical(content, packet + 6 + 2 * i, swapped), Expect.REFUSE))
    mutants.append(Mutant("first packet's length + 4", with_logical(
        content, packet + 2, (int.from_bytes(body[packet + 2: packet + 4], "little") + 4).to_bytes(2, "little")), Expect.REFUSE))
    xml_edit("precision single -> double", lambda xml: xml.replace(b'precision="single"', b'precision="double"', 1), Expect.REFUSE)
    xml_edit("cartesianX single -> Integer", lambda xml: re.sub(
        rb'<cartesianX type="Float"[^>]*>[^<]*</cartesianX>', b'<cartesianX type="Integer" minimum="0" maximum="65535"/>', xml), Expect.REFUSE)
    xml_edit("a ScaledInteger's scale NaN", lambda xml: re.sub(rb'scale="[^"]*"', b'scale="NaN"', xml, count=1), Expect.REFUSE)
    xml_edit("pose rotation w NaN", lambda xml: re.sub(rb'<w type="Float">[^<]*</w>', b'<w type="Float">NaN</w>', xml, count=1), Expect.REFUSE)
    xml_edit("pose translation x INF", lambda xml: re.sub(
        rb'(<translation type="Structure">\s*)<x type="Float"[^>]*?(/>|>[^<]*</x>)', rb'\1<x type="Float">INF</x>', xml, count=1), Expect.REFUSE)
    xml_edit("pose translation x a String", lambda xml: re.sub(
        rb'(<translation type="Structure">\s*)<x type="Float"[^>]*?(/>|>[^<]*</x>)', rb'\1<x type="String"><![CDATA[1]]></x>', xml, count=1), Expect.REFUSE)
    xml_edit("points a Vector", lambda xml: xml.replace(b'<points type="CompressedVector"', b'<points type="Vector"', 1), Expect.REFUSE)
    xml_edit("XML nested 100 deep", lambda xml: xml.replace(
        b"</e57Root>", b'<a type="Structure">' * 100 + b"</a>" * 100 + b"</e57Root>"), Expect.REFUSE)
    xml_edit("a DOCTYPE", lambda xml: xml.replace(b"<e57Root", b"<!DOCTYPE e57Root>\n<e57Root", 1), Expect.REFUSE)
    xml_edit("blank space after the XML", lambda xml: xml + b"\n\n   ", Expect.IDENTICAL)
    xml_edit("rotation written z, y, x, w", lambda xml: re.sub(
        rb'<rotation type="Structure">\s*(<w [^>]*?(?:/>|>[^<]*</w>))\s*(<x [^>]*?(?:/>|>[^<]*</x>))\s*'
        rb'(<y [^>]*?(?:/>|>[^<]*</y>))\s*(<z [^>]*?(?:/>|>[^<]*</z>))',
        rb'<rotation type="Structure">\4\3\2\1', xml), Expect.IDENTICAL)
    xml_edit("translation written z, y, x", lambda xml: re.sub(
        rb'<translation type="Structure">\s*(<x [^>]*?(?:/>|>[^<]*</x>))\s*(<y [^>]*?(?:/>|>[^<]*</y>))\s*'
        rb'(<z [^>]*?(?:/>|>[^<]*</z>))', rb'<translation type="Structure">\3\2\1', xml), Expect.IDENTICAL)
    return mutants


def physical_page():
    from e57_edit import physical

    return physical(b"\0" * 1020)


E57_SOURCE_NAMES = ["pye57_two_scans_pose_flags.e57", "libe57_scaled_integers.e57"] + [
    f"real:{path.name}" for path in sorted(E57_DATA.glob("*.e57"))]


@pytest.mark.parametrize("name", E57_SOURCE_NAMES)
def test_damaged_and_lying_e57_files_are_refused_or_read_unchanged(tmp_path, name, capfd):
    sources = _e57_sources()
    content = sources[name]
    path = tmp_path / "mutant.e57"
    path.write_bytes(content)
    original = _read(path)
    failures = []
    mutants = _e57_mutants(name, content)
    assert len(mutants) >= 30
    for mutant in mutants:
        path.write_bytes(mutant.content)
        problem = _verdict(mutant, path, original)
        if problem:
            failures.append(f"{mutant.description} [{mutant.expect.value}]: {problem}")
    assert not failures, f"{len(failures)} mutants of {name}:\n" + "\n".join(failures)
    assert capfd.readouterr().err == ""  # nothing of libE57 on the console


# --- LAS and LAZ ----------------------------------------------------------------------------------
# LAS has no checksum: a damaged byte of a point's x, y or z is a changed row (ROW), unless it leaves the
# header's bounds. Everything else must be refused or change nothing (SAME): cuts, inserted and removed
# bytes, the header's and the VLRs' bytes (but the scales' and offsets' low bytes: ROW, every row), and
# hand edits of the header that keep it consistent (every count, the points by return, the point
# offset, the VLR and EVLR counts, the LAZ chunk table's offset): REFUSE. LAZ mutants could make
# lazrs abort the process: each source's mutants are read in a child process.

LAS_SOURCES = ("las12_format3.las", "las14_format6_evlr.las", "laz12_format3.laz", "laz14_format6_evlr.laz",
               "real:laspy_simple.copc.laz")
LAS_REAL = Path(__file__).resolve().parents[1] / "data" / "las"


def _las_source(name):
    if name.startswith("real:"):
        return (LAS_REAL / name[5:]).read_bytes()
    import laspy
    from laspy.vlrs.vlrlist import VLRList

    version, point_format = ("1.4", 6) if "14" in name else ("1.2", 3)
    points = load_points(SAMPLES / "table1.ply")[:700]
    header = laspy.LasHeader(point_format=point_format, version=version)
    header.scales, header.offsets = [0.0001] * 3, np.floor(points.min(axis=0))
    las = laspy.LasData(header)
    las.x, las.y, las.z = points.T
    las.return_number[:], las.number_of_returns[:] = 1, 1
    las.vlrs.append(laspy.VLR(user_id="holecli", record_id=1, description="fuzz", record_data=b"v" * 30))
    if "evlr" in name:
        las.evlrs = VLRList([laspy.VLR(user_id="holecli", record_id=2, description="fuzz", record_data=b"e" * 80)])
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / name
        las.write(str(path))
        return path.read_bytes()


def _las_mutants(content, compressed):
    rng = np.random.default_rng([SEED, len(content)])
    header_size, offset, vlrs = struct.unpack_from("<HII", content, 94)
    record = struct.unpack_from("<H", content, 105)[0]
    minor = content[25]
    count = struct.unpack_from("<Q", content, 247)[0] if minor >= 4 else struct.unpack_from("<I", content, 107)[0]
    data_end = offset + count * record
    mutants = []

    def edited(description, expect, *edits):
        data = bytearray(content)
        for where, fmt, value in edits:
            struct.pack_into(fmt, data, where, value)
        mutants.append(Mutant(description, bytes(data), expect))

    def expectation(position):
        if 131 <= position < 179:
            return Expect.ROW, None  # a scale's or an offset's bytes: every row may change, never their number
        if compressed and offset + 8 <= position:
            return Expect.ROW, None  # compressed points, the chunk table, the EVLRs: only the number is sure
        if not compressed and offset <= position < data_end:
            row, within = divmod(position - offset, record)
            return (Expect.ROW, row) if within < 12 else (Expect.SAME, None)
        return Expect.SAME, None

    cuts = [4, 100, header_size - 1, offset - 1, offset + 5, (offset + len(content)) // 2, len(content) - 1]
    mutants += [Mutant(f"cut at {cut}", content[:cut], Expect.REFUSE) for cut in cuts]
    positions = list(range(94, min(offset + 8, 400))) + rng.integers(offset, len(content), size=40).tolist()
    for position in positions:
        mutants.append(_flip(content, position, rng, expectation(position)))
    for position in rng.integers(4, len(content), size=8).tolist():
        mutants.append(Mutant(f"insert at {position}", content[:position] + b"\x07" + content[position:], Expect.SAME))
        mutants.append(Mutant(f"remove byte {position}", content[:position] + content[position + 1 :], Expect.SAME))
    evlrs = minor >= 4 and struct.unpack_from("<I", content, 243)[0]
    for tail in (b"\0", rng.bytes(int(rng.integers(1, 200)))):
        # After the points of an uncompressed file without EVLRs: refused; after EVLRs or a chunk table: not points.
        expect = Expect.SAME if compressed or evlrs else Expect.REFUSE
        mutants.append(Mutant(f"append {len(tail)} bytes", content + tail, expect))
    # Hand edits that lie consistently.
    by_return = [(111 + 4 * i, "<I", 0) for i in range(5)]
    if minor >= 4:
        by_return += [(255 + 8 * i, "<Q", 0) for i in range(15)]
    for label, new in _changed_counts(count):
        counts = [(247, "<Q", new)] + ([(107, "<I", new)] if content[107:111] != b"\0\0\0\0" else []) if minor >= 4 \
            else [(107, "<I", new)]
        edited(f"count {label} (only)", Expect.REFUSE, *counts)
        # A LAZ of point formats 0 to 5 stores no count per chunk: a count changed within the last chunk, with
        # its points by return, shows only when the bounds do (documented); one that changes the number of
        # chunks is refused by the chunk table.
        chunks_changed = -(-new // 50_000) != -(-count // 50_000)
        if not compressed or content[104] & 0x3F >= 6 or chunks_changed:
            edited(f"count {label} with its points by return", Expect.REFUSE, *counts, *by_return)
    for shift in (1, -1, 8):
        edited(f"point offset {shift:+d}", Expect.REFUSE, (96, "<I", offset + shift))
    edited("VLR count +1", Expect.REFUSE, (100, "<I", vlrs + 1))
    edited("VLR count 2**31", Expect.REFUSE, (100, "<I", 1 << 31))
    if minor >= 4 and struct.unpack_from("<I", content, 243)[0]:
        evlr_start = struct.unpack_from("<Q", content, 235)[0]
        edited("EVLR count +1", Expect.REFUSE, (243, "<I", struct.unpack_from("<I", content, 243)[0] + 1))
        for shift in (1, -1):
            edited(f"EVLR start {shift:+d}", Expect.REFUSE, (235, "<Q", evlr_start + shift))
    if compressed:
        table = struct.unpack_from("<q", content, offset)[0]
        for label, value in (("+1", table + 1), ("-1", table - 1), ("bit 40", table ^ (1 << 40)),
                             ("bit 12", table ^ (1 << 12)), ("into the points", offset + 20)):
            edited(f"chunk table offset {label}", Expect.REFUSE, (offset, "<q", value))
    return mutants


def _las_verdicts(folder):
    """Run in a child process: read every mutant of the folder, return the failures."""
    folder = Path(folder)
    mutants = [line.split("\t") for line in (folder / "manifest").read_text().splitlines()]
    original = _read(folder / mutants[0][0])
    failures = []
    for name, description, expect, row in mutants[1:]:
        print("mutant:", description, file=sys.stderr, flush=True)  # the last line names a mutant that killed the process
        mutant = Mutant(description, b"", Expect(expect), None if row == "-" else int(row))
        problem = _verdict(mutant, folder / name, original)
        if problem:
            failures.append(f"{description} [{expect}]: {problem}")
    return failures


@pytest.mark.parametrize("name", LAS_SOURCES)
def test_damaged_las_files_are_refused_or_read_unchanged(tmp_path, name):
    pytest.importorskip("laspy")
    content = _las_source(name)
    extension = Path(name).suffix
    lines = [f"original{extension}\t\tsame\t-"]
    (tmp_path / f"original{extension}").write_bytes(content)
    for number, mutant in enumerate(_las_mutants(content, extension == ".laz")):
        (tmp_path / f"m{number}{extension}").write_bytes(mutant.content)
        row = "-" if mutant.row is None else str(mutant.row)
        lines.append(f"m{number}{extension}\t{mutant.description}\t{mutant.expect.value}\t{row}")
    (tmp_path / "manifest").write_text("\n".join(lines) + "\n")
    code = ("import resource, sys; resource.setrlimit(resource.RLIMIT_AS, (3 << 30, 3 << 30)); "
            f"sys.path.insert(0, {str(Path(__file__).parent)!r}); import test_io_fuzz; "
            "print('\\n'.join(test_io_fuzz._las_verdicts(sys.argv[1])))")
    env = dict(os.environ, PYTHONPATH=str(Path(__file__).resolve().parents[2]))
    try:
        run = subprocess.run([sys.executable, "-c", code, str(tmp_path)], capture_output=True, text=True, env=env,
                             timeout=120)
    except subprocess.TimeoutExpired as exc:
        last = (exc.stderr or b"").decode(errors="replace").strip().splitlines()[-1:]
        pytest.fail(f"{name}: reading the mutants did not end within 120 s (last: {last})")
    last = [line for line in run.stderr.splitlines() if line.startswith("mutant:")][-1:]
    assert run.returncode == 0, f"{name}: the reading process died (exit {run.returncode}) at mutant {last}"
    failures = [line for line in run.stdout.splitlines() if line]
    assert not failures, f"{len(failures)} of {len(lines) - 1} mutants of {name}:\n" + "\n".join(failures)
