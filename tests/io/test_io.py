"""Tests of holecli.io: round trips, every format variant, every bad input, and real files."""

import os
import re
import stat
import struct
import subprocess
import sys
import threading
import tracemalloc
import warnings
from pathlib import Path

import numpy as np
import pytest

from holecli.errors import LoadError
from holecli.io import WRITE_EXTENSIONS, Cloud, load_points, read_cloud, save_points


def _realdata_folder():
    """The shared real-file corpus: $HOLECLI_REALDATA, else ../shared beside the checkout, else the
    workplace's /work/shared (CI runs in a clean clone elsewhere)."""
    if os.environ.get("HOLECLI_REALDATA"):
        return Path(os.environ["HOLECLI_REALDATA"])
    for base in (Path(__file__).resolve().parents[3], Path("/work")):
        folder = base / "shared" / "realdata" / "formats"
        if folder.is_dir():
            return folder
    return Path(__file__).resolve().parents[3] / "shared" / "realdata" / "formats"


REALDATA = _realdata_folder()

_PLY_TYPE_NAMES = {
    "f4": "float", "f8": "double", "u1": "uchar", "i1": "char",
    "i2": "short", "u2": "ushort", "i4": "int", "u4": "uint",
}  # fmt: skip


def _points(n=50, seed=0):
    return np.random.default_rng(seed).normal(size=(n, 3)) * 100.0


def _as_float32(points):
    return np.asarray(points, dtype=np.float32).astype(np.float64)


def _vertices(points, coordinate="f4", extras=()):
    """A structured vertex array: x, y, z of the given type, then the extra (name, type) fields."""
    dtype = [("x", coordinate), ("y", coordinate), ("z", coordinate), *extras]
    vertices = np.zeros(len(points), dtype=dtype)
    for column, axis in enumerate("xyz"):
        vertices[axis] = points[:, column]
    for name, kind in extras:
        vertices[name] = np.arange(len(points)) % 200
    return vertices


def _ply_bytes(fmt, vertices, faces=None, *, eol="\n", before=None, list_on_vertex=False):
    """A PLY file of a structured vertex array, optionally with triangles and a leading element.

    ``before`` puts a 'camera' element of one record (two floats) ahead of the vertices;
    ``list_on_vertex`` gives every vertex a list property of two uchar values after its scalars.
    """
    byteorder = {"ascii": "<", "binary_little_endian": "<", "binary_big_endian": ">"}[fmt]
    lines = ["ply", f"format {fmt} 1.0", "comment made by test_io"]
    if before:
        lines += ["element camera 1", "property float view_px", "comment a comment among properties"]
        lines.append("property float view_py")
    lines.append(f"element vertex {len(vertices)}")
    lines += [f"property {_PLY_TYPE_NAMES[vertices.dtype[name].str[1:]]} {name}" for name in vertices.dtype.names]
    if list_on_vertex:
        lines.append("property list uchar uchar tags")
    if faces is not None:
        lines += [f"element face {len(faces)}", "property list uchar int vertex_indices"]
    lines.append("end_header")
    head = (eol.join(lines) + eol).encode("ascii")
    if fmt == "ascii":
        rows = []
        if before:
            rows.append("1.5 2.5")
        for record in vertices.tolist():
            rows.append(" ".join(repr(value) for value in record) + (" 2 7 9" if list_on_vertex else ""))
        rows += ["3 " + " ".join(str(i) for i in face) for face in (faces if faces is not None else [])]
        return head + ("\n".join(rows) + "\n").encode("ascii")
    body = b""
    if before:
        body += struct.pack(byteorder + "ff", 1.5, 2.5)
    if list_on_vertex:
        records = vertices.astype(vertices.dtype.newbyteorder(byteorder))
        body += b"".join(record.tobytes() + bytes([2, 7, 9]) for record in records)
    else:
        body += vertices.astype(vertices.dtype.newbyteorder(byteorder)).tobytes()
    for face in faces if faces is not None else []:
        body += struct.pack(byteorder + "B3i", 3, *face)
    return head + body


def _pcd_bytes(
    data, body, *, fields="x y z", size="4 4 4", type_="F F F", count="1 1 1", width=None, height=1, points=None
):
    if width is None:
        width = points
    head = (
        "# .PCD v0.7 - Point Cloud Data file format\n"
        "VERSION 0.7\n"
        f"FIELDS {fields}\nSIZE {size}\nTYPE {type_}\nCOUNT {count}\n"
        f"WIDTH {width}\nHEIGHT {height}\nVIEWPOINT 0 0 0 1 0 0 0\n"
        f"POINTS {points if points is not None else width * height}\nDATA {data}\n"
    )
    return head.encode("ascii") + body


def _lzf_literal(data):
    """An LZF stream of literal runs only (up to 32 bytes each): valid, if not compressed."""
    return b"".join(bytes([len(data[i : i + 32]) - 1]) + data[i : i + 32] for i in range(0, len(data), 32))


def _compressed_pcd_bytes(records, *, width=None, height=1):
    """A binary_compressed PCD of a structured array: the fields one after the other, then LZF."""
    types = {"f": "F", "i": "I", "u": "U"}
    fields, sizes, kinds, counts = [], [], [], []
    for name in records.dtype.names:
        base, shape = records.dtype[name].base, records.dtype[name].shape
        fields.append(name)
        sizes.append(str(base.itemsize))
        kinds.append(types[base.kind])
        counts.append(str(shape[0] if shape else 1))
    plain = b"".join(np.ascontiguousarray(records[name]).tobytes() for name in records.dtype.names)
    body = struct.pack("<II", len(_lzf_literal(plain)), len(plain)) + _lzf_literal(plain)
    width = len(records) if width is None else width
    return _pcd_bytes(
        "binary_compressed", body, fields=" ".join(fields), size=" ".join(sizes), type_=" ".join(kinds),
        count=" ".join(counts), width=width, height=height,
    )  # fmt: skip


def _write(path, content):
    if isinstance(content, str):
        content = content.encode("utf-8")
    path.write_bytes(content)
    return path


def _check_cloud(cloud, expected, dropped=0):
    assert isinstance(cloud, Cloud)
    assert cloud.points.dtype == np.float64
    assert cloud.points.flags["C_CONTIGUOUS"]
    assert cloud.points.shape == np.shape(expected)
    np.testing.assert_array_equal(cloud.points, expected)
    assert cloud.dropped == dropped


# --- round trips ------------------------------------------------------------------------------


@pytest.mark.parametrize("extension", [*WRITE_EXTENSIONS, ".PLY", ".Csv"])
def test_round_trip_is_exact(tmp_path, extension):
    points = _points(200)
    points[0] = (0.1, 1e-300, -1e300)  # digits that only a full-precision writer keeps
    path = tmp_path / f"cloud{extension}"
    save_points(path, points)
    cloud = read_cloud(path)
    _check_cloud(cloud, points)
    assert cloud.path == str(path)
    np.testing.assert_array_equal(load_points(str(path)), points)


@pytest.mark.parametrize("extension", WRITE_EXTENSIONS)
def test_round_trip_drops_and_counts_non_finite_rows(tmp_path, extension):
    points = _points(10)
    points[2, 0] = np.nan
    points[5, 2] = np.inf
    points[7] = -np.inf
    path = tmp_path / f"cloud{extension}"
    save_points(path, points)
    _check_cloud(read_cloud(path), points[[0, 1, 3, 4, 6, 8, 9]], dropped=3)


def test_save_points_formats_are_as_documented(tmp_path):
    points = np.array([[0.1, 2.0, -3.5]])
    for name in ("a.ply", "a.pcd"):
        save_points(tmp_path / name, points)
    ply = (tmp_path / "a.ply").read_bytes()
    assert ply.startswith(b"ply\nformat binary_little_endian 1.0\n")
    assert b"property double x\nproperty double y\nproperty double z\nend_header\n" in ply
    assert ply.endswith(points.astype("<f8").tobytes())
    pcd = (tmp_path / "a.pcd").read_bytes()
    for line in (b"FIELDS x y z\n", b"SIZE 8 8 8\n", b"TYPE F F F\n", b"POINTS 1\n", b"DATA binary\n"):
        assert line in pcd
    save_points(tmp_path / "a.csv", points)
    assert (tmp_path / "a.csv").read_text() == "x,y,z\n0.1,2.0,-3.5\n"
    save_points(tmp_path / "a.xyz", points)
    assert (tmp_path / "a.xyz").read_text() == "0.1 2.0 -3.5\n"


def test_save_points_accepts_integer_arrays_and_lists(tmp_path):
    save_points(tmp_path / "a.csv", [[1, 2, 3], [4, 5, 6]])
    _check_cloud(read_cloud(tmp_path / "a.csv"), [[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]])


@pytest.mark.parametrize(
    "points, match",
    [
        (np.zeros((4, 2)), r"shape \(n, 3\), got \(4, 2\)"),
        (np.zeros(3), r"shape \(n, 3\), got \(3,\)"),
        (np.zeros((2, 3, 1)), r"shape \(n, 3\)"),
        (np.array([["a", "b", "c"]]), "numeric array"),
    ],
)
def test_save_points_refuses_a_bad_array(tmp_path, points, match):
    with pytest.raises(ValueError, match=match):
        save_points(tmp_path / "a.ply", points)
    assert list(tmp_path.iterdir()) == []


def test_save_points_refuses_an_unknown_extension(tmp_path):
    with pytest.raises(ValueError, match=r"unsupported extension '\.obj'"):
        save_points(tmp_path / "a.obj", _points())
    assert list(tmp_path.iterdir()) == []


def test_save_points_replaces_an_existing_file(tmp_path):
    path = tmp_path / "a.ply"
    save_points(path, _points(5, seed=1))
    save_points(path, _points(7, seed=2))
    _check_cloud(read_cloud(path), _points(7, seed=2))
    assert [p.name for p in tmp_path.iterdir()] == ["a.ply"]
    assert path.stat().st_mode & 0o777 == 0o666 & ~_umask()


def _umask():
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


@pytest.mark.parametrize("failing", ["replace", "fsync"])
def test_save_points_leaves_the_target_untouched_on_failure(tmp_path, monkeypatch, failing):
    path = _write(tmp_path / "a.csv", "x,y,z\n1,2,3\n")

    def fail(*args, **kwargs):
        raise OSError("disk full")

    monkeypatch.setattr(os, failing, fail)
    with pytest.raises(OSError, match="disk full"):
        save_points(path, _points())
    assert path.read_text() == "x,y,z\n1,2,3\n"
    assert [p.name for p in tmp_path.iterdir()] == ["a.csv"]


# --- PLY --------------------------------------------------------------------------------------

_EXTRAS = [
    ("red", "u1"), ("green", "u1"), ("blue", "u1"), ("intensity", "f4"), ("nx", "f4"), ("ny", "f4"), ("nz", "f4")
]  # fmt: skip


@pytest.mark.parametrize("fmt", ["ascii", "binary_little_endian", "binary_big_endian"])
@pytest.mark.parametrize("coordinate", ["f4", "f8"])
@pytest.mark.parametrize("extras", [(), _EXTRAS], ids=["xyz", "extras"])
@pytest.mark.parametrize("with_faces", [False, True], ids=["points", "faces"])
def test_ply_variants(tmp_path, fmt, coordinate, extras, with_faces):
    points = _points(30)
    faces = np.arange(30).reshape(10, 3) if with_faces else None
    path = _write(tmp_path / "a.ply", _ply_bytes(fmt, _vertices(points, coordinate, extras), faces))
    expected = _as_float32(points) if coordinate == "f4" else points
    _check_cloud(read_cloud(path), expected)


@pytest.mark.parametrize("fmt", ["ascii", "binary_little_endian", "binary_big_endian"])
@pytest.mark.parametrize("layout", ["element_before", "list_on_vertex", "crlf_header"])
def test_ply_unusual_layouts(tmp_path, fmt, layout):
    points = _points(12)
    vertices = _vertices(points, "f8", [("quality", "f4")])
    content = _ply_bytes(
        fmt,
        vertices,
        np.arange(12).reshape(4, 3),
        before=layout == "element_before",
        list_on_vertex=layout == "list_on_vertex",
        eol="\r\n" if layout == "crlf_header" else "\n",
    )
    _check_cloud(read_cloud(_write(tmp_path / "a.ply", content)), points)


def test_ply_header_quirks(tmp_path):
    # "ply " with a trailing space, type aliases, comments and obj_info anywhere, padded lines.
    content = (
        "ply \nformat ascii 1.0   \ncomment first\nobj_info made by hand\nelement vertex 2  \n"
        "comment between element and properties\nproperty float32 x\nproperty float64 y \n"
        "property uint8 red\nproperty float32 z\nelement face 0\nproperty list uint8 int32 vertex_indices\n"
        "end_header\n1 2 255 3\n4 5 0 6\n"
    )
    _check_cloud(read_cloud(_write(tmp_path / "a.ply", content)), [[1, 2, 3], [4, 5, 6]])


def test_binary_ply_body_starting_with_a_newline_byte(tmp_path):
    points = np.array([[struct.unpack("<f", b"\n\n\n\n")[0], 1.0, 2.0]])
    content = _ply_bytes("binary_little_endian", _vertices(points, "f4"))
    assert content.endswith(b"end_header\n\n\n\n\n" + content[-8:])
    _check_cloud(read_cloud(_write(tmp_path / "a.ply", content)), _as_float32(points))


def test_ply_matches_open3d(tmp_path):
    o3d = pytest.importorskip("open3d")
    points = _points(500)
    for fmt in ("ascii", "binary_little_endian", "binary_big_endian"):
        content = _ply_bytes(fmt, _vertices(points, "f4", _EXTRAS), np.arange(300).reshape(100, 3))
        path = _write(tmp_path / f"{fmt}.ply", content)
        np.testing.assert_array_equal(load_points(path), np.asarray(o3d.io.read_point_cloud(str(path)).points))


# --- PCD --------------------------------------------------------------------------------------


@pytest.mark.parametrize("data", ["ascii", "binary"])
def test_pcd_with_extra_and_padding_fields(tmp_path, data):
    points = _points(20)
    dtype = [("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("_", "u1", 4), ("rgb", "<u4"), ("normal_x", "<f8")]
    records = np.zeros(20, dtype=dtype)
    for column, axis in enumerate("xyz"):
        records[axis] = points[:, column]
    records["rgb"] = 4278190080
    if data == "binary":
        body = records.tobytes()
    else:
        rows = records[["x", "y", "z"]].tolist()
        body = "".join(f"{x!r} {y!r} {z!r} 0 0 0 0 4278190080 0.5\n" for x, y, z in rows).encode()
    content = _pcd_bytes(
        data, body, fields="x y z _ rgb normal_x", size="4 4 4 1 4 8", type_="F F F U U F", count="1 1 1 4 1 1",
        points=20,
    )  # fmt: skip
    _check_cloud(read_cloud(_write(tmp_path / "a.pcd", content)), _as_float32(points))


@pytest.mark.parametrize("kind, size, dtype", [("F", 8, "<f8"), ("I", 4, "<i4"), ("U", 2, "<u2"), ("I", 1, "i1")])
def test_binary_pcd_coordinate_types(tmp_path, kind, size, dtype):
    points = np.abs(_points(10)).astype(dtype)
    content = _pcd_bytes("binary", points.tobytes(), size=f"{size} {size} {size}", type_=f"{kind} {kind} {kind}",
                         points=10)  # fmt: skip
    _check_cloud(read_cloud(_write(tmp_path / "a.pcd", content)), points.astype(np.float64))


@pytest.mark.parametrize("data", ["ascii", "binary"])
def test_organized_pcd_drops_nan_rows(tmp_path, data):
    points = _points(12).astype(np.float32)
    holes = [0, 3, 4, 10, 11]
    points[holes] = np.nan
    if data == "binary":
        body = points.astype("<f4").tobytes()
    else:
        body = "".join(" ".join(repr(float(v)) for v in row) + "\n" for row in points).encode()
    path = _write(tmp_path / "a.pcd", _pcd_bytes(data, body, width=4, height=3))
    keep = [i for i in range(12) if i not in holes]
    _check_cloud(read_cloud(path), points[keep].astype(np.float64), dropped=5)


def test_binary_compressed_pcd_written_by_open3d(tmp_path):
    o3d = pytest.importorskip("open3d")
    points = _points(1000)
    path = tmp_path / "a.pcd"
    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points))
    o3d.io.write_point_cloud(str(path), cloud, compressed=True)
    assert b"DATA binary_compressed" in path.read_bytes()[:400]
    _check_cloud(read_cloud(path), _as_float32(points))


def test_binary_compressed_pcd_with_padding_and_other_types(tmp_path):
    pytest.importorskip("open3d")
    points = np.abs(_points(30))
    extras = [("_", "u1", (4,)), ("rgba", "<u4"), ("intensity", "<f8")]
    for coordinate in ("<f4", "<i4", "<u2", "i1"):
        records = np.zeros(30, dtype=[("x", coordinate), ("y", coordinate), ("z", coordinate), *extras])
        for column, axis in enumerate("xyz"):
            records[axis] = points[:, column]
        records["rgba"], records["intensity"] = 4278190080, 0.5
        path = _write(tmp_path / "a.pcd", _compressed_pcd_bytes(records))
        _check_cloud(read_cloud(path), points.astype(coordinate).astype(np.float64))


def test_organized_binary_compressed_pcd_drops_nan_rows(tmp_path):
    pytest.importorskip("open3d")
    points = _points(12).astype(np.float32)
    points[[1, 2, 11]] = np.nan
    path = _write(tmp_path / "a.pcd", _compressed_pcd_bytes(_vertices(points, "<f4"), width=4, height=3))
    _check_cloud(read_cloud(path), np.delete(points, [1, 2, 11], axis=0).astype(np.float64), dropped=3)


def test_pcd_matches_open3d(tmp_path):
    o3d = pytest.importorskip("open3d")
    points = _points(300)
    for data in ("ascii", "binary"):
        path = tmp_path / f"{data}.pcd"
        cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points))
        o3d.io.write_point_cloud(str(path), cloud, write_ascii=data == "ascii")
        np.testing.assert_array_equal(load_points(path), np.asarray(o3d.io.read_point_cloud(str(path)).points))


def test_import_does_not_import_open3d():
    code = "import sys, holecli.io; print('open3d' in sys.modules)"
    repo = Path(__file__).resolve().parents[2]
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=repo)
    assert result.stdout.strip() == "False"


# --- CSV, TXT, XYZ ----------------------------------------------------------------------------

_TABLE = np.array([[1.5, -2.0, 3.25], [4.0, 5.0, -6.0], [7e-3, 8e3, 9.0]])


@pytest.mark.parametrize(
    "delimiter", [",", ";", "\t", " ", "  "], ids=["comma", "semicolon", "tab", "space", "spaces"]
)
@pytest.mark.parametrize(
    "header", [None, "x{d}y{d}z", '"X"{d} "Y" {d}"Z"'], ids=["no-header", "header", "quoted-header"]
)
@pytest.mark.parametrize("extension", [".csv", ".txt", ".xyz"])
def test_text_delimiters_and_headers(tmp_path, delimiter, header, extension):
    lines = [header.format(d=delimiter)] if header else []
    lines += [delimiter.join(repr(v) for v in row) for row in _TABLE.tolist()]
    _check_cloud(read_cloud(_write(tmp_path / f"a{extension}", "\n".join(lines) + "\n")), _TABLE)


def test_csv_header_in_another_order_with_extra_columns(tmp_path):
    rows = [f"{i},{z},0.5,{x},name {i},{y}\n" for i, (x, y, z) in enumerate(_TABLE)]
    text = "id, Z ,intensity,x,label,Y\n" + "".join(rows)
    _check_cloud(read_cloud(_write(tmp_path / "a.csv", text)), _TABLE)


def test_csv_header_without_xyz_uses_its_three_numeric_columns(tmp_path):
    rows = [f"p{i};{x};{y};{z}\n" for i, (x, y, z) in enumerate(_TABLE)]
    text = "name;east;north;height\n" + "".join(rows)
    _check_cloud(read_cloud(_write(tmp_path / "a.csv", text)), _TABLE)


def test_csv_header_without_xyz_over_four_numeric_columns_is_refused_then_read_with_columns(tmp_path):
    # Which three of east, north, height, intensity are x, y, z is a guess: refused, the columns named.
    rows = [f"p{i};{x};{y};{z};7\n" for i, (x, y, z) in enumerate(_TABLE)]
    path = _write(tmp_path / "a.csv", "name;east;north;height;intensity\n" + "".join(rows))
    with pytest.raises(LoadError, match=r"ambiguous columns: the header names no x, y, z and row 2 has 4 numeric "
                                        r"columns \(columns 0 'name', 1 'east', .*, 4 'intensity'\); give --columns, "
                                        r"e\.g\. --columns east,north,height$"):
        read_cloud(path)
    _check_cloud(read_cloud(path, columns=("east", "North", "HEIGHT")), _TABLE)


def test_cloudcompare_style_header(tmp_path):
    text = "//X,Y,Z,R,G,B\n" + "".join(f"{x},{y},{z},1,2,3\n" for x, y, z in _TABLE)
    _check_cloud(read_cloud(_write(tmp_path / "a.txt", text)), _TABLE)


def test_csv_tolerates_crlf_bom_comments_blank_lines_and_trailing_delimiters(tmp_path):
    rows = [f"{x},{y},{z},\r\n\r\n" for x, y, z in _TABLE]
    text = "\ufeff# exported by hand\r\n\r\nx,y,z,\r\n" + "".join(rows) + "# end\r\n"
    _check_cloud(read_cloud(_write(tmp_path / "a.csv", text)), _TABLE)


def test_csv_bom_without_header(tmp_path):
    text = "\ufeff" + "".join(f"{x},{y},{z}\n" for x, y, z in _TABLE)
    _check_cloud(read_cloud(_write(tmp_path / "a.csv", text)), _TABLE)


def test_text_slow_path_gives_the_same_points(tmp_path):
    # Lines of spaces and quoted numbers send the reader from np.loadtxt to the row-by-row path.
    text = "x,y,z\n   \n" + "".join(f'"{x}", {y} ,{z}\n  \t \n' for x, y, z in _TABLE)
    _check_cloud(read_cloud(_write(tmp_path / "a.csv", text)), _TABLE)


def test_xyz_with_colour_columns(tmp_path):
    text = "".join(f"{x} {y} {z} 117 73 49 255\n" for x, y, z in _TABLE)
    _check_cloud(read_cloud(_write(tmp_path / "a.xyz", text)), _TABLE)


def test_csv_nan_and_inf_rows_are_dropped_and_counted(tmp_path):
    text = "x,y,z\n1,2,3\nnan,2,3\n4,NaN,6\n7,8,inf\n-inf,1,1\n4,5,6\n1,Infinity,2\n"
    _check_cloud(read_cloud(_write(tmp_path / "a.csv", text)), [[1, 2, 3], [4, 5, 6]], dropped=5)


# --- bad input --------------------------------------------------------------------------------

_GOOD_BINARY_PLY = _ply_bytes("binary_little_endian", _vertices(_points(10), "f8"))
_GOOD_ASCII_PLY = _ply_bytes("ascii", _vertices(_points(10), "f4"))
_GOOD_BINARY_PCD = _pcd_bytes("binary", _points(10).astype("<f4").tobytes(), points=10)


def _cut(content, nbytes):
    return content[:-nbytes]


_BAD_FILES = [
    # name, content, problem pattern
    ("a.obj", "v 1 2 3\n", r"unsupported extension '\.obj' \(expected \.ply, \.pcd, \.csv, \.txt, \.xyz, \.e57, \.las or \.laz; "
                           r"a text file of x y z rows under another name: give --input-format xyz, or csv\)$"),
    ("noext", "1 2 3\n", r"unsupported extension \(none\)"),
    ("a.ply", b"", r"empty file$"),
    ("a.pcd", b"", r"empty file$"),
    ("a.csv", b"", r"empty file$"),
    ("a.ply", b" \n\t\n", r"empty file$"),
    ("a.csv", "  \n\n# only a comment\n", r"empty file$"),
    ("a.txt", "x y z\n", r"no points \(only a header row\)$"),
    ("a.ply", "solid cube\nfacet normal 0 0 1\n", r"not a PLY file"),
    ("a.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n", r"garbled PLY header \(no end_header line\)$"),
    ("a.ply", "ply\nformat ascii\nelement vertex 1\nproperty float x\nend_header\n1\n", r"garbled PLY header \(bad format line 'format ascii'\)$"),
    ("a.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float128 x\nend_header\n", r"garbled PLY header \(bad property line"),
    ("a.ply", "ply\nformat ascii 1.0\nelement vertex x\nend_header\n", r"garbled PLY header \(bad element line"),
    ("a.ply", "ply\nformat ascii 1.0\nproperty float x\nend_header\n", r"garbled PLY header \(property before any element"),
    ("a.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nbanana\nend_header\n", r"garbled PLY header \(unexpected line 'banana'\)$"),
    ("a.ply", "ply\nelement vertex 1\nproperty float x\nend_header\n", r"garbled PLY header \(no format line\)$"),
    ("a.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty int x\nelement vertex 1\nproperty int y\nend_header\n", r"element 'vertex' declared twice"),
    ("a.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty int x\nproperty int x\nend_header\n", r"property 'x' declared twice"),
    ("a.ply", "ply\nformat ascii 1.0\nend_header\n", r"no vertex element in PLY header$"),
    ("a.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty int8 x\nproperty uint16 y\nproperty int32 j\nend_header\n1 2 3\n", r"no z property in PLY vertex element \(found x, y, j\)$"),
    ("a.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float u\nend_header\n1\n", r"no x, y, z properties in PLY vertex element \(found u\)$"),
    ("a.ply", "ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\nproperty float y\nproperty float z\nend_header\n", r"no points \(PLY header announces 0 vertices\)$"),
    ("a.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nend_header\n", r"truncated ascii PLY: header announces 3 vertices but only 0 lines follow$"),
    ("a.ply", "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nend_header\n", r"truncated binary PLY: header announces 3 vertices \(36 bytes\) but only 0 bytes follow$"),
    ("a.ply", _cut(_GOOD_BINARY_PLY, 100), r"truncated binary PLY: header announces 10 vertices \(240 bytes\) but only 140 bytes follow$"),
    ("a.ply", _GOOD_ASCII_PLY.rsplit(b"\n", 3)[0], r"truncated ascii PLY: header announces 10 vertices but only 8 lines follow$"),
    ("a.ply", "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\nend_header\n1 2 3\n4 abc 6\n", r"malformed ascii PLY: non-numeric value 'abc' in line 9$"),
    ("a.ply", "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\nend_header\n1 2 3\n4 5 6 7\n", r"malformed ascii PLY: line 9 has 4 values, the header declares 3$"),
    ("a.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nproperty list uchar int idx\nend_header\n1 2 3\n", r"malformed ascii PLY: line 9 has 3 values, too few"),
    ("a.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nproperty list uchar int idx\nend_header\n1 2 3 1.5 1\n", r"malformed ascii PLY: list length '1\.5' of 'idx' in line 9 is not a count$"),
    ("a.ply", "ply\nformat binary_little_endian 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\nproperty list uchar int idx\nend_header\n" + "\0" * 12 + "\x05" + "\0" * 13, r"truncated binary PLY: data ends in vertex 1 of the 2"),
    ("a.ply", b"ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nproperty list char int idx\nend_header\n" + b"\0" * 12 + b"\xff", r"negative list length in vertex 1$"),
    ("a.pcd", "VERSION 0.7\nFIELDS x y z\n", r"garbled PCD header \(no DATA line\)$"),
    ("a.pcd", "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 1\nBANANA 3\nDATA ascii\n1 2 3\n", r"garbled PCD header \(unexpected line 'BANANA 3'\)$"),
    ("a.pcd", "FIELDS x y z\nSIZE 4 4\nTYPE F F F\nWIDTH 1\nDATA ascii\n1 2 3\n", r"garbled PCD header \(FIELDS, SIZE, TYPE and COUNT have 3, 2, 3 and 3 entries\)$"),
    ("a.pcd", "FIELDS x y z\nSIZE 4 4 3\nTYPE F F F\nWIDTH 1\nDATA ascii\n1 2 3\n", r"garbled PCD header \(field 'z' has unsupported TYPE F SIZE 3\)$"),
    ("a.pcd", "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 2\nHEIGHT 2\nPOINTS 3\nDATA ascii\n1 2 3\n", r"garbled PCD header \(POINTS 3 but WIDTH x HEIGHT is 4\)$"),
    ("a.pcd", "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 1\nDATA lzma\n", r"unsupported PCD data kind 'lzma'"),
    ("a.pcd", "FIELDS rgba\nSIZE 4\nTYPE U\nWIDTH 1\nDATA ascii\n1\n", r"no x, y, z fields in PCD header \(found rgba\)$"),
    ("a.pcd", "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 0\nDATA ascii\n", r"no points \(PCD header announces 0 points\)$"),
    ("a.pcd", _cut(_GOOD_BINARY_PCD, 30), r"truncated binary PCD: header announces 10 points \(120 bytes\) but only 90 bytes follow$"),
    ("a.pcd", "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 3\nDATA ascii\n1 2 3\n4 5 6\n", r"truncated ascii PCD: header announces 3 points but only 2 lines follow$"),
    ("a.ply", "ply\nformat ascii 1.0\nelement vertex 1000000000000\nproperty float x\nproperty float y\nproperty float z\nend_header\n1 2 3\n", r"truncated ascii PLY: header announces 1000000000000 vertices but only 1 line follows$"),
    ("a.pcd", "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 1000000000000\nDATA ascii\n1 2 3\n", r"truncated ascii PCD: header announces 1000000000000 points but only 1 line follows$"),
    ("a.pcd", "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 1\nDATA ascii\n1 2 3\n4 5 6\n", r"malformed ascii PCD: line 7 is past the 1 points the header announces$"),
    ("a.pcd", "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 2\nDATA ascii\n1 2 3\n4 5 x\n", r"malformed ascii PCD: non-numeric value 'x' in line 7$"),
    ("a.pcd", "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 10\nHEIGHT 1\nPOINTS 10\nDATA binary_compressed\n" + "\x00" * 4, r"truncated binary_compressed PCD: no data after the header$"),
    ("a.pcd", b"FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 10\nHEIGHT 1\nPOINTS 10\nDATA binary_compressed\n" + struct.pack("<II", 50, 120) + b"\0" * 20, r"truncated binary_compressed PCD: 50 compressed bytes announced but only 20 follow$"),
    ("a.pcd", b"FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 10\nHEIGHT 1\nPOINTS 10\nDATA binary_compressed\n" + struct.pack("<II", 5, 99) + b"\0" * 5, r"garbled binary_compressed PCD: data unpack to 99 bytes, but 10 points take 120$"),
    ("a.pcd", b"FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 10\nHEIGHT 1\nPOINTS 10\nDATA binary_compressed\n" + struct.pack("<II", 5, 120) + b"\xff" * 5, r"garbled binary_compressed PCD: decoded 0 of the 10 points the header announces$"),
    ("a.pcd", "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 10\nDATA binary_compressed\n", r"unsupported binary_compressed PCD header \(needs a POINTS line"),
    ("a.pcd", "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nPOINTS 10\nWIDTH 10\nHEIGHT 1\nDATA binary_compressed\n", r"in the standard order"),
    ("a.pcd", _compressed_pcd_bytes(_vertices(_points(3), "<f8")), r"unsupported binary_compressed PCD: 8-byte x, y, z \(open3d would read zeros\)"),
    ("a.csv", "x,y,z\n1,2,3\n4,abc,6\n", r"non-numeric value 'abc' in row 3$"),
    ("a.csv", "\ufeff# comment\r\nx;y;z\r\n\r\n1;2;3\r\n1,5;2;3\r\n", r"non-numeric value '1,5' in row 5$"),
    ("a.csv", 'x,y,z\n1,2,3\n"1,5",2,3\n', r"non-numeric value '1,5' in row 3$"),
    ("a.csv", "1,2\n3,4\n", r"fewer than 3 columns \(row 1 has 2\)$"),
    ("a.csv", "1,2,3\n4,5,6\n7,8\n", r"row 3 has 2 values, expected at least 3$"),
    ("a.csv", "x,y,elevation\n1,2,3\n", r"header names x, y but no z column$"),
    ("a.csv", "x,x,y,z\n1,2,3,4\n", r"header names column 'x' twice$"),
    ("a.csv", "name,label,z1\na,b,1\n", r"no x, y, z columns in the header and fewer than 3 numeric columns \(row 2\)$"),
    ("a.csv", "x,y,z\nnan,1,2\n1,inf,2\nNaN,NaN,NaN\n", r"no finite points \(all 3 rows have a NaN or infinite coordinate\)$"),
    ("a.txt", "1 2 3\n" + "\0" * 10 + "\n", r"not a text file \(contains NUL bytes\)$"),
    ("a.csv", b"x,y,z\n1,2,3\n\xff\xfe,2,3\n", r"non-numeric value '\ufffd\ufffd' in row 3$"),
]


@pytest.mark.parametrize(
    "name, content, problem", _BAD_FILES, ids=[f"{i}-{row[0]}" for i, row in enumerate(_BAD_FILES)]
)
def test_bad_file_raises_load_error(tmp_path, name, content, problem):
    path = _write(tmp_path / name, content)
    with pytest.raises(LoadError, match=problem) as info:
        read_cloud(path)
    assert str(info.value) == f"{path}: {info.value.problem}"
    assert info.value.path == str(path)
    assert not info.value.problem.endswith(".")


def test_missing_file(tmp_path):
    with pytest.raises(LoadError, match="file not found$"):
        read_cloud(tmp_path / "missing.ply")


def test_directory(tmp_path):
    (tmp_path / "scan.ply").mkdir()
    # the hint points to the command that measures a folder
    with pytest.raises(LoadError, match=r"is a directory \(to measure every scan in it: holecli batch .*scan\.ply\)$"):
        load_points(tmp_path / "scan.ply")


@pytest.mark.parametrize("kind", ["binary_ply", "ascii_ply", "binary_pcd", "csv"])
def test_truncation_anywhere_is_refused_or_keeps_the_count(tmp_path, kind):
    points = _points(40)
    if kind == "binary_ply":
        name = "a.ply"
        content = _ply_bytes("binary_big_endian", _vertices(points, "f4", _EXTRAS), np.arange(30).reshape(10, 3))
    elif kind == "ascii_ply":
        content, name = _ply_bytes("ascii", _vertices(points, "f8")), "a.ply"
    elif kind == "binary_pcd":
        content, name = _pcd_bytes("binary", points.astype("<f8").tobytes(), size="8 8 8", points=40), "a.pcd"
    else:
        save_points(tmp_path / "full.csv", points)
        content, name = (tmp_path / "full.csv").read_bytes(), "a.csv"
    path = tmp_path / name
    for end in np.linspace(0, len(content) - 1, 97).astype(int):
        path.write_bytes(content[:end])
        try:
            cloud = read_cloud(path)
        except LoadError:
            continue
        if kind == "csv":
            # A table has no count to check: a cut at a line end is a shorter table.
            assert len(cloud.points) <= 40
        else:
            # A binary file must be as long as its header says; only a cut inside the last number of
            # an ascii file can load.
            assert kind == "ascii_ply", f"cut at {end} loaded"
            assert len(cloud.points) == 40


def test_corrupted_bytes_give_load_error_or_points(tmp_path):
    rng = np.random.default_rng(7)
    sources = {
        "a.ply": _ply_bytes("ascii", _vertices(_points(20), "f4", _EXTRAS)),
        "b.ply": _ply_bytes("binary_little_endian", _vertices(_points(20), "f4", _EXTRAS), np.arange(9).reshape(3, 3)),
        "c.pcd": _GOOD_BINARY_PCD,
        "d.csv": "x,y,z\n" + "".join(f"{x},{y},{z}\n" for x, y, z in _points(20)),
    }
    for name, content in sources.items():
        content = content.encode() if isinstance(content, str) else content
        for _ in range(60):
            corrupted = bytearray(content)
            for position in rng.integers(0, min(len(content), 400), size=3):
                corrupted[position] = int(rng.integers(0, 256))
            path = _write(tmp_path / name, bytes(corrupted))
            try:
                points = load_points(path)
            except LoadError:
                continue
            assert points.ndim == 2 and points.shape[1] == 3 and np.isfinite(points).all()


# --- damaged files: sizes and counts that disagree with the header -----------------------------


def _binary_ply_with_faces(byteorder="little", faces=((0, 1, 2), (2, 3, 4), (4, 5, 6))):
    fmt = f"binary_{byteorder}_endian"
    return _ply_bytes(fmt, _vertices(_points(10), "f8"), np.array(faces))


def test_pcd_ascii_body_relabelled_binary_is_refused(tmp_path):
    # Issue 8: read as 12-byte records, the text gave 10 "points" and a 0.00024 mm hole.
    text = "".join(f"{x!r} {y!r} {z!r}\n" for x, y, z in _as_float32(_points(10)))
    content = _pcd_bytes("binary", text.encode(), points=10)
    with pytest.raises(LoadError, match=rf"garbled binary PCD: {len(text)} bytes of data but the header declares "
                       r"120 \(10 points of 12 bytes\)$"):  # fmt: skip
        read_cloud(_write(tmp_path / "a.pcd", content))


@pytest.mark.parametrize(
    "count, problem",
    [
        (5, r"garbled binary PLY: 240 bytes of data but the header declares 120 \(5 vertices of 24 bytes\)$"),
        (9, r"garbled binary PLY: 240 bytes of data but the header declares 216 \(9 vertices of 24 bytes\)$"),
        (11, r"truncated binary PLY: header announces 11 vertices \(264 bytes\) but only 240 bytes follow$"),
    ],
    ids=["halved", "minus-one", "plus-10-percent"],
)
def test_binary_ply_vertex_count_that_disagrees_with_the_data_is_refused(tmp_path, count, problem):
    content = _GOOD_BINARY_PLY.replace(b"element vertex 10\n", f"element vertex {count}\n".encode())
    with pytest.raises(LoadError, match=problem):
        read_cloud(_write(tmp_path / "a.ply", content))


def test_binary_ply_double_relabelled_float_is_refused(tmp_path):
    content = _GOOD_BINARY_PLY.replace(b"property double", b"property float")
    with pytest.raises(LoadError, match=r"240 bytes of data but the header declares 120 \(10 vertices of 12 bytes\)$"):
        read_cloud(_write(tmp_path / "a.ply", content))


@pytest.mark.parametrize("tail", [b"\n", b"\0", b"\r\n", b"junk", b"\0" * 24], ids=repr)
@pytest.mark.parametrize("kind", ["ply", "ply_faces_big_endian", "pcd", "pcd_compressed"])
def test_bytes_after_binary_data_are_refused(tmp_path, kind, tail):
    if kind == "pcd_compressed":
        pytest.importorskip("open3d")
    content, name = {
        "ply": (_GOOD_BINARY_PLY, "a.ply"),
        "ply_faces_big_endian": (_binary_ply_with_faces("big"), "a.ply"),
        "pcd": (_GOOD_BINARY_PCD, "a.pcd"),
        "pcd_compressed": (_compressed_pcd_bytes(_vertices(_points(10), "<f4")), "a.pcd"),
    }[kind]
    path = _write(tmp_path / name, content)
    read_cloud(path)
    path.write_bytes(content + tail)
    with pytest.raises(LoadError, match=r"garbled binary\S* (PLY|PCD): (\d+) bytes of data.* (\d+)") as info:
        read_cloud(path)
    actual, declared = map(int, re.search(r"(\d+) bytes of data\D+(\d+)", info.value.problem).groups())
    assert actual - declared == len(tail)


def test_binary_ply_message_names_every_element(tmp_path):
    path = _write(tmp_path / "a.ply", _binary_ply_with_faces() + b"\n")
    with pytest.raises(LoadError, match=r"garbled binary PLY: 280 bytes of data but the header declares 279 "
                       r"\(10 vertices of 24 bytes, 3 'face' records of 13 bytes\)$"):  # fmt: skip
        read_cloud(path)


def test_binary_ply_faces_of_mixed_sizes_are_walked(tmp_path):
    # Triangles and quads: the records differ in size, so the uniform fast path must hand over.
    faces = [(0, 1, 2), (2, 3, 4, 5), (4, 5, 6)]
    byteorder = "<"
    head = _ply_bytes("binary_little_endian", _vertices(_points(10), "f8"), np.zeros((3, 3), int))
    head = head[: head.index(b"end_header\n") + len(b"end_header\n")]
    body = _vertices(_points(10), "f8").tobytes()
    body += b"".join(struct.pack(byteorder + f"B{len(f)}i", len(f), *f) for f in faces)
    path = _write(tmp_path / "a.ply", head + body)
    _check_cloud(read_cloud(path), _points(10))
    path.write_bytes(head + body[:-1])
    with pytest.raises(LoadError, match=r"truncated binary PLY: data ends in face 3 of the 3"):
        read_cloud(path)
    path.write_bytes(head + body + b"\0")
    with pytest.raises(LoadError, match=r"284 bytes of data but the header declares 283 \(10 vertices of 24 "
                       r"bytes, 3 'face' records in 43 bytes\)$"):  # fmt: skip
        read_cloud(path)


@pytest.mark.parametrize(
    "edit",
    [(b"element vertex 30\n", b"element vertex 31\n"), (b"property float x\n", b"property double x\n")],
    ids=["vertex-plus-one", "x-relabelled-double"],
)
def test_binary_ply_faces_misread_after_a_wrong_vertex_layout_are_refused(tmp_path, edit):
    # Found by the fuzz test: the vertices take 12 bytes more and end inside the first face, on the
    # high byte (0) of its last index, which reads as a face of length 0; the faces after it read in
    # step again and the sizes add up exactly.
    content = _ply_bytes("binary_little_endian", _vertices(_points(30), "f4"), np.arange(30).reshape(10, 3))
    path = _write(tmp_path / "a.ply", content)
    read_cloud(path)
    path.write_bytes(content.replace(*edit))
    with pytest.raises(LoadError, match=r"garbled binary PLY: face \d+ has 0 vertex indices \(a face has at least 3\)$"):
        read_cloud(path)


@pytest.mark.parametrize("index", [30, -1, 2**31 - 1])
def test_binary_ply_face_index_past_the_vertices_is_refused(tmp_path, index):
    faces = np.arange(30).reshape(10, 3)
    faces[6, 1] = index
    content = _ply_bytes("binary_big_endian", _vertices(_points(30), "f4"), faces)
    with pytest.raises(LoadError, match=rf"garbled binary PLY: face 7 refers to vertex {index}, but the header "
                       r"declares 30 vertices$"):  # fmt: skip
        read_cloud(_write(tmp_path / "a.ply", content))


@pytest.mark.parametrize("page", [4096, 16384])
@pytest.mark.parametrize("data", ["binary", "binary_compressed"])
def test_pcd_with_old_pcl_page_padding_is_read(tmp_path, page, data):
    # PCL up to about 1.8 stretches the file to getpagesize() + the data size, padded with NUL.
    if data == "binary_compressed":
        pytest.importorskip("open3d")
        content = _compressed_pcd_bytes(_vertices(_points(10), "<f4"))
        body = len(content) - content.index(b"DATA binary_compressed\n") - len(b"DATA binary_compressed\n")
    else:
        content, body = _GOOD_BINARY_PCD, 120
    padded = content + b"\0" * (page + body - len(content))
    _check_cloud(read_cloud(_write(tmp_path / "a.pcd", padded)), _as_float32(_points(10)))
    for damaged in (padded[:-1], padded + b"\0", padded[:-1] + b"\n"):
        with pytest.raises(LoadError, match=r"garbled binary\S* PCD: \d+ bytes of data"):
            read_cloud(_write(tmp_path / "a.pcd", damaged))


@pytest.mark.parametrize(
    "content, problem",
    [
        (_GOOD_ASCII_PLY + b"1 2 3\n", r"malformed ascii PLY: line 19 is past the 10 vertices the header announces$"),
        (_GOOD_ASCII_PLY + b"garbage\n", r"line 19 is past the 10 vertices"),
        (_ply_bytes("ascii", _vertices(_points(4), "f4"), np.array([[0, 1, 2]])) + b"3 1 2 3\n",
         r"malformed ascii PLY: line 16 is past the 1 'face' records the header announces$"),
        (_ply_bytes("ascii", _vertices(_points(4), "f4"), np.array([[0, 1, 2], [1, 2, 3]])).rsplit(b"3 ", 1)[0],
         r"truncated ascii PLY: header announces 2 'face' records but only 1 line follows$"),
        (_pcd_bytes("ascii", b"1 2 3\n4 5 6\nextra\n", points=2),
         r"malformed ascii PCD: line 14 is past the 2 points the header announces$"),
    ],
    ids=["ply-extra-vertex-line", "ply-garbage-line", "ply-extra-face-line", "ply-face-line-missing", "pcd-extra-line"],
)
def test_ascii_lines_past_or_short_of_the_header_counts_are_refused(tmp_path, content, problem):
    with pytest.raises(LoadError, match=problem):
        read_cloud(_write(tmp_path / "a.ply" if content.startswith(b"ply") else tmp_path / "a.pcd", content))


def test_ascii_blank_lines_after_the_data_are_fine(tmp_path):
    content = _ply_bytes("ascii", _vertices(_points(4), "f8"), np.array([[0, 1, 2]])) + b"\n  \r\n\t\n"
    _check_cloud(read_cloud(_write(tmp_path / "a.ply", content)), _points(4))
    content = _pcd_bytes("ascii", b"1 2 3\n4 5 6\n\n \n", points=2)
    _check_cloud(read_cloud(_write(tmp_path / "a.pcd", content)), [[1, 2, 3], [4, 5, 6]])


def test_float32_signalling_nan_is_dropped_without_a_warning(tmp_path):
    signalling_nan = struct.unpack("<f", struct.pack("<I", 0x7F800001))[0]
    points = np.array([[1.0, 2.0, 3.0], [signalling_nan, 0.0, 0.0]])
    content = _ply_bytes("binary_little_endian", _vertices(points, "f4"))
    content = content[:-12] + struct.pack("<I", 0x7F800001) + content[-8:]  # keep the exact bit pattern
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        cloud = read_cloud(_write(tmp_path / "a.ply", content))
    _check_cloud(cloud, [[1.0, 2.0, 3.0]], dropped=1)


# --- headers that ask for more than the file holds ---------------------------------------------

_HUGE_HEADERS = [
    # name, content, problem: each is a few hundred bytes asking for gigabytes.
    ("a.pcd", "FIELDS x y z n\nSIZE 4 4 4 4\nTYPE F F F F\nCOUNT 1 1 1 10000000\nWIDTH 1\nDATA ascii\n1 2 3 4\n",
     r"truncated ascii PCD: header announces points of 10000003 values \(at least 20000005 bytes each\) but only 8 bytes follow$"),
    ("a.pcd", "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 1000000000000\nDATA binary\n" + "\0" * 24,
     r"truncated binary PCD: header announces 1000000000000 points \(12000000000000 bytes\) but only 24 bytes follow$"),
    ("a.pcd", b"FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 100000000\nHEIGHT 1\nPOINTS 100000000\nDATA binary_compressed\n"
     + struct.pack("<II", 16, 1200000000) + b"\xe0\xff\0" * 5 + b"\0",
     r"garbled binary_compressed PCD: 16 compressed bytes cannot unpack to 1200000000 \(LZF expands at most 88 times\)$"),
    ("a.ply", "ply\nformat binary_little_endian 1.0\nelement vertex 1000000000000\nproperty float x\nproperty float y\n"
     "property float z\nend_header\n" + "\0" * 24,
     r"truncated binary PLY: header announces 1000000000000 vertices \(12000000000000 bytes\) but only 24 bytes follow$"),
    ("a.ply", "ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\n"
     "property list uint float tags\nend_header\n" + "\0" * 12 + "\xff\xff\xff\x7f" + "\0" * 8,
     r"truncated binary PLY: data ends in vertex 1 of the 1 the header announces$"),
    ("a.ply", "ply\nformat binary_little_endian 1.0\nelement camera 1000000000000\nproperty list uchar float v\n"
     "element vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n" + "\0" * 40,
     r"truncated binary PLY: header announces 1000000000000 'camera' records \(at least 1000000000000 bytes\) but only 40"),
    ("a.ply", "ply\nformat ascii 1.0\nelement vertex 1000000000000\nproperty float x\nproperty float y\nproperty float z\n"
     "end_header\n1 2 3\n", r"truncated ascii PLY: header announces 1000000000000 vertices but only 1 line follows$"),
    ("a.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\n"
     "property list uint float tags\nend_header\n1 2 3 4000000000 1\n",
     r"malformed ascii PLY: line 9 has 5 values, the header declares 4000000004$"),
]  # fmt: skip


@pytest.mark.parametrize(
    "name, content, problem", _HUGE_HEADERS, ids=[f"{i}-{row[0]}" for i, row in enumerate(_HUGE_HEADERS)]
)
def test_header_asking_for_more_than_the_file_holds_is_refused_before_allocating(tmp_path, name, content, problem):
    if b"binary_compressed" in (content if isinstance(content, bytes) else content.encode()):
        pytest.importorskip("open3d")
    path = _write(tmp_path / name, content)
    tracemalloc.start()
    try:
        with pytest.raises(LoadError) as info:
            read_cloud(path)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    # Python-side memory first: it is the point (open3d's own allocations are not traced, which is
    # why the compressed case is refused before open3d is called).
    assert peak < 5_000_000
    assert re.search(problem, info.value.problem)


# --- text tables: long lines, odd bytes, headers that do not fit the rows -----------------------


@pytest.mark.parametrize(
    "name, content, line",
    [
        # The header's long field went to the csv module, which raised _csv.Error (a traceback).
        ("a.csv", "x,y,z," + "a" * 140_000 + "\n1,2,3,4\n", 1),
        ("a.csv", "x,y,z\n1,2,3\n" + '"' + "1" * 140_000 + '",2,3\n', 3),
        ("a.csv", "x,y,z\r\n1,2,3\r\n4,5,6\r\n" + "1" * 70_000 + ",2,3\r\n", 4),
        ("a.xyz", "1 2 3\r" + "9" * 1_000_000, 2),
        ("a.txt", "1 2 3 " * 20_000 + "\n", 1),
    ],
    ids=["csv-header-field", "csv-quoted-field", "csv-crlf", "xyz-cr", "txt-many-columns"],
)
def test_text_line_too_long_is_refused(tmp_path, name, content, line):
    with pytest.raises(LoadError, match=rf"line {line} is longer than 65536 bytes \(not a point table\)$"):
        read_cloud(_write(tmp_path / name, content))


@pytest.mark.parametrize(
    "content, problem",
    [
        (b"1 2 3\n4 5 6 # a NUL \0 in a comment\n", r"not a text file \(contains NUL bytes\)$"),
        (b"\xff\xfe1\0 \0002\0 \0003\0\n\0", r"not a text file \(contains NUL bytes\)$"),  # UTF-16
        (b"1 2 3\n4 5\xe9 6\n", r"non-numeric value '5\ufffd' in row 2$"),
    ],
    ids=["nul-in-comment", "utf-16", "latin-1-in-value"],
)
def test_text_with_odd_bytes_is_refused(tmp_path, content, problem):
    with pytest.raises(LoadError, match=problem):
        read_cloud(_write(tmp_path / "a.xyz", content))


def test_text_with_a_non_utf8_byte_in_a_comment_loads(tmp_path):
    path = _write(tmp_path / "a.xyz", b"# caf\xe9\n1 2 3\n4 5 6 # \xe9\n")
    _check_cloud(read_cloud(path), [[1, 2, 3], [4, 5, 6]])


@pytest.mark.parametrize(
    "text, problem",
    [
        ("id,x,y,z\n1;10;20;30\n2;11;21;31\n", r"the header \(line 1\) has 1 field but row 2 has 4, split at semicolons$"),
        ("x y z\n1,2,3\n", r"the header \(line 1\) has 1 field but row 2 has 3, split at commas$"),
        ("# made by hand\nx,y,z,intensity\n1,2,3\n", r"the header \(line 2\) has 4 fields but row 3 has 3, split at commas$"),
        ("x;y;z\n1 2 3\n", r"the header \(line 1\) has 1 field but row 2 has 3, split at whitespace$"),
    ],
    ids=["comma-header-semicolon-rows", "space-header-comma-rows", "header-longer", "semicolon-header-space-rows"],
)
def test_csv_header_that_does_not_fit_the_rows_is_refused(tmp_path, text, problem):
    # Issue 8: "id,x,y,z" over ";" rows was one unnamed column, and (id, x, y) were read as (x, y, z).
    with pytest.raises(LoadError, match=problem):
        read_cloud(_write(tmp_path / "a.csv", text))


# --- files that are not regular files ----------------------------------------------------------


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs here")
def test_fifo_is_refused_without_being_opened(tmp_path):
    fifo = tmp_path / "scan.ply"
    os.mkfifo(fifo)
    outcome = []

    def read():
        try:
            read_cloud(fifo)
        except LoadError as exc:
            outcome.append(exc)

    reader = threading.Thread(target=read, daemon=True)
    reader.start()
    reader.join(timeout=5)
    try:
        assert not reader.is_alive(), "read_cloud blocked on the FIFO"
    finally:
        if reader.is_alive():  # opening the FIFO for writing releases a reader blocked in open()
            os.close(os.open(fifo, os.O_WRONLY | os.O_NONBLOCK))
    assert len(outcome) == 1
    assert outcome[0].problem == "not a regular file (a FIFO)"


@pytest.mark.skipif(not os.path.exists("/dev/null") or not stat.S_ISCHR(os.stat("/dev/null").st_mode),
                    reason="no /dev/null character device")  # fmt: skip
def test_character_device_is_refused():
    with pytest.raises(LoadError, match=r"not a regular file \(a character device\)$"):
        read_cloud("/dev/null")


# --- real files -------------------------------------------------------------------------------

# From the README of the real-data folder: the number of finite points to load, or None to refuse.
# Where the README allows "N or refuse", the entry is what this reader does (checked further below).
_REAL_FILES = {
    "ahmeddhahri_model_binary.pcd": 100000,
    "ahmeddhahri_sim_test_ascii_rgbU.pcd": 10072,
    "assimp_cube.ply": 8,
    "assimp_cube_binary_header_with_RN_newline.ply": 8,  # 8 or refuse
    "assimp_cube_binary_starts_with_nl.ply": 8,
    "assimp_float-color.ply": 3,
    "assimp_issue623.ply": None,  # 24 or refuse: vertex lines lack the list the header declares
    "assimp_payload_JVN42386607_malformed.ply": None,
    "assimp_points.ply": 4,
    "assimp_pond.0.ply": 70051,
    "benthebear93_keyence_surface_ascii_camera_element.ply": 20489,  # 20489 or refuse
    "benthebear93_keyence_surface_ascii_rgbU.pcd": 20489,
    "pcl_test_2d_lena.pcd": 65536,
    "pcl_test_brisk_descriptors_gt.pcd": None,
    "pcl_test_bun0.pcd": 397,
    "pcl_test_bunny.pcd": 397,
    "pcl_test_car6.pcd": 10031,
    "pcl_test_milk.pcd": 13704,
    "pcl_test_colored_cloud.pcd": 1000,
    "pcl_test_cturtle.pcd": 167198,
    "pcl_test_cube_binary_le.ply": 24,
    "pcl_test_curve2d.pcd": 51,
    "pcl_test_curve3d.pcd": 110,
    "pcl_test_curve_close.pcd": 110,
    "pcl_test_five_people.pcd": 239075,
    "pcl_test_lamppost.pcd": 1771,
    "pcl_test_milk_cartoon_all_small_clorox.pcd": 241407,
    "pcl_test_milk_color.pcd": 13704,
    "pcl_test_nhood_test.pcd": 36,
    "pcl_test_noisy_slice_displaced.pcd": 3782,
    "pcl_test_octants.pcd": 8,
    "pcl_test_office1.pcd": 254456,
    "pcl_test_office1_keypoints.pcd": 1318,
    "pcl_test_sac_plane_test.pcd": 3283,
    "pcl_test_stereo_left.pcd": None,
    "pcl_test_table_scene_mug_stereo_textured.pcd": 209280,
    "pdal_no_vertex.ply": None,
    "pdal_simple_text.ply": 3,
    "pdal_sized_dims_no_z.ply": None,
    "pdal_text_extradim.ply": 1,
    "trimesh_emptyIO_ply_empty_ascii.ply": None,
    "trimesh_emptyIO_ply_empty_header.ply": None,
    "trimesh_emptyIO_ply_points_bin.ply": 8,
    "trimesh_fixed_top.ply": 2374,
    "trimesh_octagonal_pocket.ply": 1658,
    "trimesh_metadata.ply": 4,
    "trimesh_points_ascii.ply": 5,
    "trimesh_points_ascii_with_lists.ply": 5,
    "trimesh_points_bin.ply": 5,
    "trimesh_points_agisoft.xyz": 100,
    "trimesh_points_cloudcompare.xyz": 101,
}
# open3d returns zeros or garbage for these (marked * in the README); elsewhere it is a reference.
_OPEN3D_WRONG = {
    "assimp_cube_binary_header_with_RN_newline.ply",
    "assimp_issue623.ply",
    "benthebear93_keyence_surface_ascii_camera_element.ply",
}

needs_realdata = pytest.mark.skipif(not REALDATA.is_dir(), reason=f"no real-data folder at {REALDATA}")


def _real(name):
    path = REALDATA / name
    if not path.is_file():
        pytest.skip(f"{name} is not in {REALDATA}")
    return path


@needs_realdata
@pytest.mark.parametrize("name, expected", _REAL_FILES.items(), ids=list(_REAL_FILES))
def test_real_file(name, expected):
    path = _real(name)
    if expected is None:
        with pytest.raises(LoadError) as info:
            read_cloud(path)
        assert "\n" not in str(info.value)
        return
    cloud = read_cloud(path)
    assert len(cloud.points) == expected
    assert cloud.points.dtype == np.float64 and cloud.points.flags["C_CONTIGUOUS"]
    assert np.isfinite(cloud.points).all()


@pytest.mark.slow
@needs_realdata
def test_real_files_match_open3d_where_it_is_right():
    o3d = pytest.importorskip("open3d")
    checked = 0
    with o3d.utility.VerbosityContextManager(o3d.utility.VerbosityLevel.Error):
        for name, expected in _REAL_FILES.items():
            path = REALDATA / name
            if expected is None or name in _OPEN3D_WRONG or path.suffix == ".xyz" or not path.is_file():
                continue
            reference = np.asarray(o3d.io.read_point_cloud(str(path)).points)
            reference = reference[np.isfinite(reference).all(axis=1)]
            np.testing.assert_allclose(load_points(path), reference, rtol=1e-12, atol=0, err_msg=name)
            checked += 1
    assert checked > 0


@needs_realdata
def test_real_ply_with_crlf_binary_header_is_the_unit_cube():
    points = load_points(_real("assimp_cube_binary_header_with_RN_newline.ply"))
    corners = {(x, y, z) for x in (0.0, 1.0) for y in (0.0, 1.0) for z in (0.0, 1.0)}
    assert set(map(tuple, points.tolist())) == corners


@needs_realdata
def test_real_ascii_ply_with_camera_element_matches_its_text():
    path = _real("benthebear93_keyence_surface_ascii_camera_element.ply")
    lines = path.read_text().split("end_header\n", 1)[1].splitlines()[:20489]
    expected = np.array([[float(v) for v in line.split()[:3]] for line in lines])
    np.testing.assert_array_equal(load_points(path), expected)


@needs_realdata
@pytest.mark.parametrize(
    "name, problem",
    [
        ("assimp_issue623.ply", "line 14 has 6 values, too few for the vertex properties"),
        ("assimp_payload_JVN42386607_malformed.ply", "bad format line"),
        ("pcl_test_brisk_descriptors_gt.pcd", "no x, y, z fields"),
        ("pcl_test_stereo_left.pcd", r"no x, y, z fields in PCD header \(found rgba\)"),
        ("pdal_no_vertex.ply", "no vertex element"),
        ("pdal_sized_dims_no_z.ply", "no z property"),
        ("trimesh_emptyIO_ply_empty_ascii.ply", "no points"),
        ("trimesh_emptyIO_ply_empty_header.ply", "no vertex element"),
    ],
)
def test_real_file_refusals_say_why(name, problem):
    with pytest.raises(LoadError, match=problem):
        read_cloud(_real(name))


@needs_realdata
def test_real_binary_mesh_with_one_vertex_too_many_is_refused(tmp_path):
    content = _real("pcl_test_cube_binary_le.ply").read_bytes()
    assert b"element vertex 24\n" in content
    path = _write(tmp_path / "a.ply", content.replace(b"element vertex 24\n", b"element vertex 25\n"))
    with pytest.raises(LoadError, match=r"face 1 has 0 vertex indices"):
        read_cloud(path)


@pytest.mark.parametrize("extension", [".ply", ".pcd", ".csv", ".xyz"])
def test_save_points_float32_writes_single_precision_that_reads_back_exactly(tmp_path, extension):
    from holecli.io import load_points, save_points

    points = np.random.default_rng(5).normal(size=(50, 3)) * 1000.0
    path = tmp_path / f"f32{extension}"
    save_points(path, points, float32=True)
    assert np.array_equal(load_points(path), points.astype(np.float32).astype(np.float64))
    if extension == ".ply":
        assert b"property float x" in path.read_bytes()[:200]
        assert path.stat().st_size < 50 * 24


# --- issue 23, item 7: PCD with upper-case X Y Z (PDAL writes them) -----------------------------------

PDAL_CLI_DATA = Path(__file__).parent.parent / "data" / "pdal_cli"


def test_pcd_written_by_pdal_with_upper_case_xyz_fields_is_read():
    path = PDAL_CLI_DATA / "utm17_space.pcd"
    text = path.read_text().splitlines()
    assert "FIELDS X Y Z" in text
    expected = np.array([[float(value) for value in line.split()] for line in text[text.index("DATA ascii") + 1:]])
    np.testing.assert_array_equal(load_points(path), expected)


def test_binary_pcd_with_upper_case_and_mixed_case_fields_is_read(tmp_path):
    points = _points(20)
    records = np.zeros(20, dtype=[("X", "<f8"), ("intensity", "<f4"), ("y", "<f8"), ("Z", "<f8")])
    records["X"], records["y"], records["Z"] = points.T
    header = ("VERSION 0.7\nFIELDS X intensity y Z\nSIZE 8 4 8 8\nTYPE F F F F\nCOUNT 1 1 1 1\nWIDTH 20\n"
              "HEIGHT 1\nPOINTS 20\nDATA binary\n")
    path = _write(tmp_path / "a.pcd", header.encode() + records.tobytes())
    np.testing.assert_array_equal(load_points(path), points)


def test_pcd_naming_a_coordinate_in_both_cases_is_refused(tmp_path):
    path = _write(tmp_path / "a.pcd", b"VERSION 0.7\nFIELDS x y z X\nSIZE 4 4 4 4\nTYPE F F F F\nCOUNT 1 1 1 1\n"
                                      b"WIDTH 1\nHEIGHT 1\nPOINTS 1\nDATA ascii\n1 2 3 4\n")
    with pytest.raises(LoadError, match=r"fields 'X' and 'x' both name coordinate x: which one holds it is ambiguous"):
        load_points(path)
