"""Tests of holecli.simulation.scan_part and ``holecli simulate --panel``: a profiler's scan of a built panel,
its truth in the scan's frame, and what the detector makes of it."""

import json
import math
import os

import numpy as np
import pytest

from holecli import cli
from holecli.simulation.panel import FeatureSpec, PanelSpec, build_panel, panel_truth
from holecli.simulation.profiler import ProfilerSpec
from holecli.simulation.scan_part import scan_part

SAMPLE_PANEL = os.path.join(os.path.dirname(__file__), os.pardir, os.pardir, "sample_clouds", "panel.toml")


@pytest.fixture(scope="module")
def small_panel():
    spec = PanelSpec(width=24.0, height=14.0, thickness=2.0, segments=128,
                     features=(FeatureSpec(kind="through", center=(-5.0, 0.0), diameter=4.0),
                               FeatureSpec(kind="countersunk", center=(6.0, 0.0), diameter=3.0,
                                           countersink_diameter=5.5)))
    return build_panel(spec)


def test_truth_moves_into_the_robot_frame_and_units(small_panel):
    angle = math.radians(30.0)
    frame = np.eye(4)
    frame[:3, :3] = [[math.cos(angle), -math.sin(angle), 0.0], [math.sin(angle), math.cos(angle), 0.0], [0, 0, 1]]
    frame[:3, 3] = [1200.0, -300.0, 800.0]
    spec = ProfilerSpec(target=(0.0, 0.0, 0.0), view=(0.0, 0.0, -1.0), line_length=30.0, scan_length=20.0,
                        point_pitch=0.2, line_pitch=0.2, fan=False, frame=tuple(map(tuple, frame)), unit_scale=1e-3)
    scanned = scan_part(small_panel.vertices, small_panel.triangles, panel_truth(small_panel)["features"], spec)
    (through, countersunk) = sorted(scanned.truth["holes"], key=lambda hole: hole["center"][0])
    expected = (frame[:3, :3] @ [-5.0, 0.0, 0.0] + frame[:3, 3]) * 1e-3
    assert through["center"] == pytest.approx(expected.tolist(), abs=1e-12)
    assert through["diameter"] == pytest.approx(4.0e-3)
    assert countersunk["countersink_depth"] == pytest.approx(panel_truth(small_panel)["holes"][1]["countersink_depth"]
                                                             * 1e-3)
    assert through["inside_scan"] and not through["partial"]
    # the points are in the same frame: the top surface lies at z = 0.8 m, the cone below it
    heights = scanned.scan.points[:, 2]
    assert np.median(heights) == pytest.approx(0.8, abs=1e-12) and heights.max() < 0.8 + 1e-12


def test_a_hole_the_scan_only_reaches_is_partial_and_one_it_misses_is_left_out(small_panel):
    spec = ProfilerSpec(target=(-5.0, 0.0, 0.0), line_length=3.0, scan_length=10.0, point_pitch=0.2, line_pitch=0.2,
                        fan=False)
    holes = scan_part(small_panel.vertices, small_panel.triangles, panel_truth(small_panel)["features"], spec).truth["holes"]
    (hole,) = holes  # the countersink at x = 6 is beyond the scanned strip
    assert hole["partial"] and not hole["inside_scan"]


def test_simulate_panel_writes_a_float32_scan_and_its_truth(run, tmp_path):
    scan = tmp_path / "panel.ply"
    result = run("simulate", scan, "--panel", SAMPLE_PANEL, "--spacing", "0.2", "--range-noise", "0.002")
    assert result.exit_code == 0, result.stderr
    assert b"property float x" in scan.read_bytes()[:300]
    truth = json.loads((tmp_path / "panel.truth.json").read_text())
    assert sorted(hole["name"] for hole in truth["holes"]) == ["B1", "C1", "L1", "T1"]
    assert sorted(feature["kind"] for feature in truth["features"]) == ["boss", "slot"]
    assert truth["profiler"]["point_pitch"] == 0.2 and truth["units"] == "mm"


def test_simulate_panel_carries_a_tilted_axis_into_the_robot_frame(run, tmp_path):
    spec = tmp_path / "tilted.toml"
    spec.write_text("[panel]\nwidth = 20\nheight = 14\nthickness = 2\nsegments = 128\n\n[[feature]]\n"
                    "name = 'T1'\nkind = 'through'\ncenter = [0.0, 0.0]\ndiameter = 4.0\ntilt_deg = 5.0\n"
                    "tilt_direction_deg = 30.0\n")
    scan = tmp_path / "tilted.ply"
    result = run("simulate", scan, "--panel", spec, "--spacing", "0.2", "--rotation", "0,0,90")
    assert result.exit_code == 0, result.stderr
    (hole,) = json.loads((tmp_path / "tilted.truth.json").read_text())["holes"]
    tilt, lean = math.radians(5.0), math.radians(30.0)
    part_axis = np.array([math.sin(tilt) * math.cos(lean), math.sin(tilt) * math.sin(lean), math.cos(tilt)])
    # Turned 90 degrees about z: (x, y, z) -> (-y, x, z); the angles are the sheet's and stay.
    np.testing.assert_allclose(hole["axis"], [-part_axis[1], part_axis[0], part_axis[2]], atol=1e-12)
    np.testing.assert_allclose(hole["normal"], [0.0, 0.0, 1.0], atol=1e-12)
    assert hole["perpendicularity_deg"] == pytest.approx(5.0, abs=1e-12)
    assert (hole["tilt_deg"], hole["tilt_direction_deg"]) == (5.0, 30.0)
    assert 4.0 < hole["diameter"] < 4.0 / math.cos(tilt)

@pytest.mark.slow
def test_detect_finds_the_holes_of_a_scanned_panel_and_nothing_on_its_slot_and_boss(run, tmp_path):
    scan = tmp_path / "panel.ply"
    assert run("simulate", scan, "--panel", SAMPLE_PANEL, "--spacing", "0.1", "--range-noise", "0.002",
               "--seed", "4").exit_code == 0
    truth = json.loads((tmp_path / "panel.truth.json").read_text())
    result = run("detect", scan, "--explain")
    assert result.exit_code == 0, result.stderr
    record = json.loads(result.stdout)
    assert len(record["holes"]) == 4
    for expected in truth["holes"]:
        (hole,) = [h for h in record["holes"] if np.hypot(*np.subtract(h["center"], expected["center"])[:2]) < 1.0]
        # on this 0.1 mm pitch: within 0.1 h of the truth (issue 9 asks for 3 um median; see the benchmark)
        assert np.linalg.norm(np.subtract(hole["center"], expected["center"])) < 0.01
        assert abs(hole["diameter"] - expected["diameter"]) < 0.01
    checks = {rejection["check"] for rejection in record["rejected"] if rejection["diameter"] > 3.0}
    assert checks == {"not_round", "boss"}  # the slot and the pin


@pytest.mark.parametrize("args, message", [
    (["--panel", SAMPLE_PANEL, "--hole", "0,0,3"], "--hole cannot be used with --panel"),
    (["--panel", SAMPLE_PANEL, "--mesh", "part.stl"], "not both"),
    (["--standoff", "80"], "--standoff need --panel or --mesh"),
    (["--range-noise", "0.01", "--float64"], "--range-noise, --float64 need --panel or --mesh"),
])
def test_simulate_options_of_the_other_kind_are_usage_errors(run, tmp_path, args, message):
    result = run("simulate", tmp_path / "scan.ply", *args)
    assert result.exit_code == 2
    assert message in result.stderr


def test_simulate_panel_with_an_invalid_spec_is_one_line_error(run, tmp_path):
    spec = tmp_path / "bad.toml"
    spec.write_text("[panel]\nwidth = 10\nheight = 10\nthickness = -1\n")
    result = run("simulate", tmp_path / "scan.ply", "--panel", spec)
    assert result.exit_code == cli.EXIT_INPUT
    assert result.stderr.startswith(f"Error: {spec}: ") and result.stderr.count("\n") == 1
    assert "thickness" in result.stderr


def test_simulate_mesh_derives_the_truth_from_the_mesh_itself(run, small_panel, tmp_path):
    import open3d as o3d

    part = tmp_path / "plate.stl"
    mesh = o3d.geometry.TriangleMesh(o3d.utility.Vector3dVector(small_panel.vertices),
                                     o3d.utility.Vector3iVector(small_panel.triangles.astype(np.int32)))
    mesh.compute_triangle_normals()
    assert o3d.io.write_triangle_mesh(str(part), mesh)  # STL: float32 vertices, a triangle soup
    scan = tmp_path / "plate.ply"
    result = run("simulate", scan, "--mesh", part, "--spacing", "0.08", "--translation", "1200,-300,800")
    assert result.exit_code == 0, result.stderr
    truth = json.loads((tmp_path / "plate.truth.json").read_text())
    built = {hole["kind"]: hole for hole in panel_truth(small_panel)["holes"]}
    assert sorted(hole["kind"] for hole in truth["holes"]) == ["countersunk", "through"]
    for hole in truth["holes"]:
        expected = built[hole["kind"]]
        assert hole["center"] == pytest.approx(np.add(expected["center"], [1200.0, -300.0, 800.0]).tolist(), abs=1e-4)
        assert hole["diameter"] == pytest.approx(expected["diameter"], abs=1e-4)
    detected = json.loads(run("detect", scan).stdout)["holes"]
    assert len(detected) == 2
    for hole in truth["holes"]:
        (match,) = [h for h in detected if np.linalg.norm(np.subtract(h["center"], hole["center"])) < 0.05]
        assert abs(match["diameter"] - hole["diameter"]) < 0.016  # 0.2 of the pitch


def test_simulate_mesh_that_is_not_a_mesh_is_one_line_error(run, tmp_path):
    part = tmp_path / "part.stl"
    part.write_bytes(b"solid nothing\nendsolid nothing\n")
    result = run("simulate", tmp_path / "scan.ply", "--mesh", part)
    assert result.exit_code == cli.EXIT_INPUT
    assert result.stderr.startswith("Error: ") and str(part) in result.stderr and result.stderr.count("\n") == 1


def test_simulate_panel_spec_that_is_a_fifo_is_refused_without_opening_it(holecli_process, tmp_path):
    spec = tmp_path / "panel.toml"
    os.mkfifo(spec)  # opening it would wait for a writer forever
    result = holecli_process("simulate", tmp_path / "scan.ply", "--panel", spec, timeout=60)
    assert result.returncode == cli.EXIT_INPUT
    assert result.stderr == f"Error: {spec}: not a regular file (a FIFO): a panel spec must be a TOML file\n"
