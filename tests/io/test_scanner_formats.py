"""E57 (pye57) and LAS/LAZ (laspy) reading: files written here by the libraries themselves.

Each reader is checked on good files (points, poses, invalid flags, scaled integers), on damaged,
truncated and empty ones (refused with a one-line LoadError, never measured), and without its
optional extra (simulated: the import fails), which must give the one line naming the extra.
"""

import builtins
import sys

import numpy as np
import pytest

from holecli.errors import LoadError
from holecli.io import read_cloud

pye57 = pytest.importorskip("pye57")
laspy = pytest.importorskip("laspy")


def _points(n=400, seed=0, scale=1.0):
    rng = np.random.default_rng(seed)
    return rng.uniform(-1.0, 1.0, size=(n, 3)) * scale


def write_e57(path, scans):
    """An E57 file of ``scans``: a list of (points in the scan's frame, quaternion w,x,y,z, translation,
    invalid flags or None)."""
    with pye57.E57(str(path), mode="w") as e57:
        for points, rotation, translation, invalid in scans:
            data = {"cartesianX": np.ascontiguousarray(points[:, 0]), "cartesianY": np.ascontiguousarray(points[:, 1]),
                    "cartesianZ": np.ascontiguousarray(points[:, 2])}
            if invalid is not None:
                data["cartesianInvalidState"] = np.asarray(invalid, dtype=np.int8)
            e57.write_scan_raw(data, rotation=np.asarray(rotation, dtype=float),
                               translation=np.asarray(translation, dtype=float))
    return path


def _quaternion_z(degrees):
    half = np.radians(degrees) / 2
    return np.array([np.cos(half), 0.0, 0.0, np.sin(half)])


def _rotate_z(points, degrees):
    angle = np.radians(degrees)
    c, s = np.cos(angle), np.sin(angle)
    return points @ np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]).T


def write_las(path, points, version="1.2", point_format=3, scale=0.0001):
    header = laspy.LasHeader(point_format=point_format, version=version)
    header.scales = [scale] * 3
    header.offsets = np.floor(points.min(axis=0))
    las = laspy.LasData(header)
    las.x, las.y, las.z = points[:, 0], points[:, 1], points[:, 2]
    las.write(str(path))
    return path


def _single(points):
    """``points`` as E57 writes them (pye57 stores single-precision coordinates)."""
    return points.astype(np.float32).astype(np.float64)


# --- E57 -----------------------------------------------------------------------------------------


def test_e57_one_scan(tmp_path):
    points = _points()
    cloud = read_cloud(write_e57(tmp_path / "one.e57", [(points, [1, 0, 0, 0], [0, 0, 0], None)]))
    np.testing.assert_allclose(cloud.points, _single(points), rtol=0, atol=1e-7)
    assert cloud.dropped == 0 and cloud.units == "m" and cloud.points.dtype == np.float64
    assert cloud.points.flags.c_contiguous


def test_e57_two_scans_are_merged_each_moved_by_its_pose(tmp_path):
    world = _points(600, seed=1)
    first, second = world[:300], world[300:]
    translation = np.array([0.25, -0.5, 0.125])
    # the second scan's own frame: world = R local + t
    local = _rotate_z(second - translation, -40.0)
    path = write_e57(tmp_path / "two.e57", [(first, [1, 0, 0, 0], [0, 0, 0], None),
                                            (local, _quaternion_z(40.0), translation, None)])
    merged = read_cloud(path)
    np.testing.assert_allclose(merged.points, world, rtol=0, atol=1e-6)
    np.testing.assert_allclose(read_cloud(path, scan=0).points, first, rtol=0, atol=1e-6)
    np.testing.assert_allclose(read_cloud(path, scan=1).points, second, rtol=0, atol=1e-6)
    # without the pose the second scan would be elsewhere
    assert np.abs(local - second).max() > 0.1


def test_e57_scan_out_of_range_is_refused(tmp_path):
    path = write_e57(tmp_path / "two.e57", [(_points(), [1, 0, 0, 0], [0, 0, 0], None)] * 2)
    with pytest.raises(LoadError, match=r"two\.e57: scan 2 is out of range: the file has 2 scans \(0 to 1\)$"):
        read_cloud(path, scan=2)


def test_other_formats_hold_one_scan(tmp_path):
    from holecli.io import save_points

    path = tmp_path / "cloud.ply"
    save_points(path, _points())
    assert len(read_cloud(path, scan=0).points) == 400
    with pytest.raises(LoadError, match=r"scan 1 is out of range: a \.ply file holds 1 scan \(scan 0\)$"):
        read_cloud(path, scan=1)


def test_e57_invalid_points_and_nans_are_dropped_and_counted(tmp_path):
    points = _points(50)
    invalid = np.zeros(50, dtype=np.int8)
    invalid[[3, 10]] = 2  # no point measured
    invalid[20] = 1  # a direction but no range
    # a NaN where nothing was measured (pye57 cannot write a NaN it takes for valid: its bounds would be NaN)
    points[30, 1] = np.nan
    invalid[30] = 2
    cloud = read_cloud(write_e57(tmp_path / "flags.e57", [(points, [1, 0, 0, 0], [0, 0, 0], invalid)]))
    keep = np.ones(50, dtype=bool)
    keep[[3, 10, 20, 30]] = False
    assert cloud.dropped == 4
    np.testing.assert_allclose(cloud.points, _single(points[keep]), rtol=0, atol=1e-7)


def test_all_points_invalid_is_refused():
    # (pye57 cannot write a scan without a valid point: its bounds would be empty)
    from holecli.io.cloud import _finite_cloud

    with pytest.raises(LoadError, match=r"^void\.e57: no valid points \(all 20 points are flagged invalid"):
        _finite_cloud(np.empty((0, 3)), "void.e57", flagged=20)
    with pytest.raises(LoadError, match=r"no valid points \(all 21 points"):
        _finite_cloud(np.full((1, 3), np.nan), "void.e57", flagged=20)


def test_e57_without_scans_is_refused(tmp_path):
    path = tmp_path / "none.e57"
    pye57.E57(str(path), mode="w").close()
    with pytest.raises(LoadError, match=r"none\.e57: no scans in the E57 file"):
        read_cloud(path)


@pytest.mark.parametrize("rotation, translation, problem", [
    ([0.5, 0, 0, 0], [0, 0, 0], "rotation is not a unit quaternion"),
    ([0, 0, 0, 0], [0, 0, 0], "rotation is not a unit quaternion"),
    ([0.6, 0.6, 0.6, 0.6], [0, 0, 0], "rotation is not a unit quaternion"),
])  # (libE57 cannot write a NaN or infinite pose)
def test_e57_bad_pose_is_refused(tmp_path, rotation, translation, problem):
    path = write_e57(tmp_path / "pose.e57", [(_points(20), [1, 0, 0, 0], [0, 0, 0], None),
                                             (_points(20), rotation, translation, None)])
    with pytest.raises(LoadError, match=f"scan 1: the pose's {problem}"):
        read_cloud(path)
    read_cloud(path, scan=0)  # the other scan is fine


@pytest.fixture(scope="module")
def e57_bytes(tmp_path_factory):
    path = tmp_path_factory.mktemp("e57") / "good.e57"
    write_e57(path, [(_points(3000), [1, 0, 0, 0], [0, 0, 0], None), (_points(500, 2), [1, 0, 0, 0], [1, 2, 3], None)])
    return path.read_bytes()


def _damaged_cases(data_length):
    rng = np.random.default_rng(13)
    cases = [("cut to 8 bytes", lambda d: d[:8]), ("cut to half", lambda d: d[: len(d) // 2]),
             ("last byte cut", lambda d: d[:-1]), ("garbage appended", lambda d: d + b"\x00garbage" * 16)]
    for position in rng.integers(0, data_length, size=12):
        cases.append((f"bit flipped at {position}", lambda d, p=int(position): d[:p] + bytes([d[p] ^ 0x10]) + d[p + 1:]))
    return cases


def test_damaged_e57_is_refused(tmp_path, e57_bytes, capfd):
    for what, damage in _damaged_cases(len(e57_bytes)):
        path = tmp_path / "damaged.e57"
        path.write_bytes(damage(e57_bytes))
        with pytest.raises(LoadError) as error:
            read_cloud(path)
        message = str(error.value)
        assert message.startswith(f"{path}: ") and "\n" not in message, what
        assert "E57" in message, (what, message)
    assert capfd.readouterr().err == ""  # nothing of libE57 on the console


@pytest.mark.parametrize("content, problem", [
    (b"", "empty file"),
    (b"hello world\n", "not an E57 file"),
    (b"ply\nformat ascii 1.0\n", "not an E57 file"),
])
def test_not_an_e57_file(tmp_path, content, problem):
    path = tmp_path / "scan.E57"
    path.write_bytes(content)
    with pytest.raises(LoadError, match=problem):
        read_cloud(path)


# --- LAS and LAZ ---------------------------------------------------------------------------------


@pytest.mark.parametrize("extension, version, point_format", [(".las", "1.2", 3), (".las", "1.4", 6),
                                                              (".laz", "1.2", 1), (".laz", "1.4", 7)])
def test_las_coordinates_are_scaled_integers(tmp_path, extension, version, point_format):
    points = _points(500, scale=50.0) + [1000.0, -2000.0, 300.0]
    cloud = read_cloud(write_las(tmp_path / f"scan{extension}", points, version, point_format))
    # stored as integers of 0.0001: the points within half a step
    np.testing.assert_allclose(cloud.points, points, rtol=0, atol=0.5001e-4)
    assert cloud.dropped == 0 and cloud.units is None
    steps = (cloud.points - np.floor(points.min(axis=0))) / 1e-4
    np.testing.assert_allclose(steps, np.round(steps), rtol=0, atol=1e-5)


def test_las_without_points_is_refused(tmp_path):
    header = laspy.LasHeader(point_format=3, version="1.2")
    path = tmp_path / "empty.las"
    laspy.LasData(header).write(str(path))
    with pytest.raises(LoadError, match=r"empty\.las: no points$"):
        read_cloud(path)


@pytest.fixture(scope="module", params=[".las", ".laz"])
def las_file(request, tmp_path_factory):
    path = tmp_path_factory.mktemp("las") / f"good{request.param}"
    write_las(path, _points(800, scale=10.0))
    return path


def test_truncated_las_is_refused(tmp_path, las_file, capfd):
    data = las_file.read_bytes()
    for cut in (4, 100, 227, 400, len(data) // 2, len(data) - 1):
        path = tmp_path / f"cut{las_file.suffix}"
        path.write_bytes(data[:cut])
        with pytest.raises(LoadError) as error:
            read_cloud(path)
        assert "\n" not in str(error.value) and str(error.value).startswith(f"{path}: "), cut
    # laspy logs a short read as an error: nothing of it on the console
    assert capfd.readouterr().err == ""


def test_las_with_bytes_after_its_points_is_refused(tmp_path):
    path = write_las(tmp_path / "long.las", _points(100))
    path.write_bytes(path.read_bytes() + b"\x00" * 34)
    with pytest.raises(LoadError, match=r"34 bytes after the 100 points the header announces"):
        read_cloud(path)


def test_las_with_zero_scale_is_refused(tmp_path):
    path = write_las(tmp_path / "scale.las", _points(100))
    data = bytearray(path.read_bytes())
    data[131:139] = np.float64(0.0).tobytes()  # the x scale factor (LAS 1.2 header, offset 131)
    path.write_bytes(bytes(data))
    with pytest.raises(LoadError, match=r"scales 0, 0\.0001, 0\.0001"):
        read_cloud(path)


def test_not_a_las_file(tmp_path):
    path = tmp_path / "scan.las"
    path.write_text("1 2 3\n")
    with pytest.raises(LoadError, match=r"not a LAS file"):
        read_cloud(path)


def test_damaged_laz_is_refused_or_read_whole(tmp_path):
    path = tmp_path / "good.laz"
    points = _points(2000, scale=10.0)
    write_las(path, points)
    data = path.read_bytes()
    rng = np.random.default_rng(5)
    for position in rng.integers(400, len(data), size=20):
        damaged = tmp_path / "damaged.laz"
        damaged.write_bytes(data[:position] + bytes([data[position] ^ 0x04]) + data[position + 1:])
        try:
            cloud = read_cloud(damaged)
        except LoadError as error:
            assert "\n" not in str(error)
        else:  # the backend did not see it: as many points, never fewer
            assert len(cloud.points) + cloud.dropped == len(points)


# --- missing extras --------------------------------------------------------------------------------


def _without(monkeypatch, *modules):
    """Make ``import`` of these modules fail, as when the extra is not installed."""
    real_import = builtins.__import__

    def fake_import(name, *args, **kwargs):
        if name.split(".")[0] in modules:
            raise ImportError(f"No module named {name!r}")
        return real_import(name, *args, **kwargs)

    for name in list(sys.modules):
        if name.split(".")[0] in modules:
            monkeypatch.delitem(sys.modules, name)
    monkeypatch.setattr(builtins, "__import__", fake_import)


def test_e57_without_its_extra(tmp_path, monkeypatch):
    path = write_e57(tmp_path / "scan.e57", [(_points(), [1, 0, 0, 0], [0, 0, 0], None)])
    _without(monkeypatch, "pye57")
    with pytest.raises(LoadError) as error:
        read_cloud(path)
    assert str(error.value) == f"{path}: reading .e57 needs the optional extra: pip install 'holecli[e57]'"


@pytest.mark.parametrize("extension", [".las", ".laz"])
def test_las_without_its_extra(tmp_path, monkeypatch, extension):
    path = write_las(tmp_path / f"scan{extension}", _points())
    _without(monkeypatch, "laspy")
    with pytest.raises(LoadError) as error:
        read_cloud(path)
    assert str(error.value) == f"{path}: reading {extension} needs the optional extra: pip install 'holecli[las]'"


def test_laz_without_a_backend(tmp_path, monkeypatch):
    path = write_las(tmp_path / "scan.laz", _points())
    monkeypatch.setattr(laspy.LazBackend, "detect_available", staticmethod(lambda: ()))
    with pytest.raises(LoadError, match=r"reading \.laz needs the optional extra: pip install 'holecli\[las\]'$"):
        read_cloud(path)
    assert len(read_cloud(write_las(tmp_path / "plain.las", _points())).points) == 400  # no backend needed
