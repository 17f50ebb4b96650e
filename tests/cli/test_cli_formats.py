"""The command line on E57 and LAS/LAZ scans: --scan, the units E57 declares, errors as one line."""

import json
import sys
from pathlib import Path

import numpy as np
import pytest

from holecli.io import load_points

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "io"))
from test_scanner_formats import _quaternion_z, _rotate_z, _without, write_e57, write_las  # noqa: E402

pytest.importorskip("pye57")
pytest.importorskip("laspy")

SAMPLES = Path(__file__).resolve().parents[2] / "sample_clouds"


@pytest.fixture(scope="module")
def table1_m():
    """The Table I scan in metres."""
    return load_points(SAMPLES / "table1.ply") / 1000.0


def test_detect_e57_is_in_metres_and_converts(run, tmp_path, table1_m):
    scan = write_e57(tmp_path / "table1.e57", [(table1_m, [1, 0, 0, 0], [0, 0, 0], None)])
    record = json.loads(run("detect", scan).stdout)
    assert record["units"] == "m" and record["holes"][0]["diameter"] == pytest.approx(0.003, abs=1e-5)
    result = run("detect", scan, "--output-units", "mm", "--nominal-diameter", "3", "--tolerance", "0.01")
    assert result.exit_code == 0, result.output
    record = json.loads(result.stdout)
    assert record["units"] == "mm" and record["holes"][0]["diameter"] == pytest.approx(3.0, abs=0.01)
    assert record["holes"][0]["in_tolerance"] is True


def test_detect_two_scan_e57_merged_or_one(run, tmp_path, table1_m):
    half = len(table1_m) // 2
    translation = np.array([0.002, -0.001, 0.004])
    local = _rotate_z(table1_m[half:] - translation, -25.0)
    scan = write_e57(tmp_path / "two.e57", [(table1_m[:half], [1, 0, 0, 0], [0, 0, 0], None),
                                            (local, _quaternion_z(25.0), translation, None)])
    merged = json.loads(run("detect", scan, "--output-units", "mm").stdout)
    assert merged["points"] == len(table1_m)
    assert merged["holes"][0]["diameter"] == pytest.approx(3.0, abs=0.02)
    assert merged["holes"][0]["center"] == pytest.approx([3.6498, 5.1392, 5.5300], abs=0.02)
    second = json.loads(run("detect", scan, "--scan", "1").stdout)
    assert second["points"] == len(table1_m) - half
    result = run("detect", scan, "--scan", "2")
    assert result.exit_code == 3 and result.stdout == ""
    assert result.stderr == f"Error: {scan}: scan 2 is out of range: the file has 2 scans (0 to 1)\n"


@pytest.mark.parametrize("extension", [".las", ".laz"])
def test_detect_las(run, tmp_path, extension):
    points = load_points(SAMPLES / "table1.ply") + [500.0, 200.0, 100.0]
    scan = write_las(tmp_path / f"table1{extension}", points, scale=0.00001)
    result = run("detect", scan, "--units", "mm")
    assert result.exit_code == 0, result.output
    record = json.loads(result.stdout)
    assert record["units"] == "mm" and record["holes"][0]["diameter"] == pytest.approx(3.0, abs=0.01)


@pytest.mark.parametrize("name, content, problem", [
    ("empty.e57", b"", "empty file"),
    ("empty.las", b"", "empty file"),
    ("text.e57", b"1 2 3\n", "not an E57 file"),
    ("text.laz", b"1 2 3\n", "not a LAS file"),
])
def test_bad_scanner_files_are_one_line_errors(run, tmp_path, name, content, problem):
    path = tmp_path / name
    path.write_bytes(content)
    result = run("detect", path)
    assert result.exit_code == 3 and result.stdout == ""
    assert result.stderr.startswith(f"Error: {path}: {problem}") and result.stderr.count("\n") == 1


def test_truncated_e57_is_refused(run, tmp_path, table1_m):
    scan = write_e57(tmp_path / "cut.e57", [(table1_m, [1, 0, 0, 0], [0, 0, 0], None)])
    scan.write_bytes(scan.read_bytes()[:-2000])
    result = run("detect", scan)
    assert result.exit_code == 3 and result.stdout == ""
    assert result.stderr.startswith(f"Error: {scan}: damaged E57 file (its header gives ") and result.stderr.count("\n") == 1


def test_missing_extra_is_one_line(run, tmp_path, table1_m, monkeypatch):
    scan = write_e57(tmp_path / "table1.e57", [(table1_m[:100], [1, 0, 0, 0], [0, 0, 0], None)])
    _without(monkeypatch, "pye57")
    result = run("detect", scan)
    assert result.exit_code == 3 and result.stdout == ""
    assert result.stderr == f"Error: {scan}: reading .e57 needs the optional extra: pip install 'holecli[e57]'\n"


def test_batch_finds_scanner_formats_and_takes_scan_and_units(run, tmp_path, table1_m):
    write_e57(tmp_path / "a.E57", [(table1_m, [1, 0, 0, 0], [0, 0, 0], None)] * 2)
    write_las(tmp_path / "b.laz", table1_m * 1000.0, scale=0.00001)
    result = run("batch", tmp_path, "--scan", "1", "-j", "1")
    records = {Path(record["file"]).name: record for record in map(json.loads, result.stdout.splitlines())}
    assert records["a.E57"]["units"] == "m" and records["a.E57"]["points"] == len(table1_m)
    assert records["b.laz"]["error"].endswith("scan 1 is out of range: a .laz file holds 1 scan (scan 0)")
    assert result.exit_code == 6
    # --output-units without --units: only when every file is E57
    result = run("batch", tmp_path, "--output-units", "mm", "-j", "1")
    assert result.exit_code == 2 and "not every file is .e57" in result.stderr
    # (both scans merged would be every point twice: no point spacing, the same points twice are degenerate)
    result = run("batch", tmp_path / "a.E57", "--scan", "0", "--output-units", "mm", "-j", "1")
    assert result.exit_code == 0, result.output
    assert json.loads(result.stdout)["holes"][0]["diameter"] == pytest.approx(3.0, abs=0.01)
