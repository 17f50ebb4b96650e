"""benchmarks/peers.py: its core on one simulated scan (the full benchmark takes minutes)."""

import importlib.util
import json
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[1]
SCORER = REPO.parent.parent / "shared" / "validation" / "score.py"  # the validation suite's scorer, when there


def _load(name, path):
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def bench():
    return _load("benchmark_peers", REPO / "benchmarks" / "peers.py")


@pytest.fixture(scope="module")
def easy_suite(tmp_path_factory):
    """A folder with one easy scan in holecli's own truth format: a flat 3 mm sheet, one 5 mm through hole."""
    from holecli.io import save_points
    from holecli.simulation.panel import FeatureSpec, PanelSpec, build_panel, panel_truth
    from holecli.simulation.profiler import ProfilerSpec
    from holecli.simulation.scan_part import scan_part

    panel = build_panel(PanelSpec(width=30, height=30, thickness=3,
                                  features=(FeatureSpec(kind="through", center=(0.5, -0.3), diameter=5.0),)))
    sensor = ProfilerSpec(line_length=16, scan_length=16, point_pitch=0.1, line_pitch=0.1, range_noise=0.002)
    scanned = scan_part(panel.vertices, panel.triangles, panel_truth(panel)["features"], sensor, rng=3)
    folder = tmp_path_factory.mktemp("easy")
    points = scanned.scan.points
    save_points(folder / "plate_d5.ply", points[np.isfinite(points).all(axis=1)])
    (folder / "plate_d5.truth.json").write_text(json.dumps(dict(scanned.truth, units="mm")))
    return folder


def test_the_peers_find_a_plain_hole_and_the_table_has_a_row_per_method(bench, easy_suite):
    (path, case, raw), = bench.find_scans(easy_suite)
    result = bench.measure_file(path, case, raw, methods=("holecli", "open3d", "pcl"))
    assert result["pitch_from"] == "profiler" and result["pitch"] == pytest.approx(0.1)
    for name in ("open3d", "pcl"):
        run = result["methods"][name]
        assert run["ok"], run["fails"]
        (hole,) = run["holes"]
        assert hole["found"] and abs(hole["diameter_err"]) <= hole["diameter_tol"]
        assert run["extras"] == [] and run["cpu_s"] > 0
    summary = bench.summarise([result], ("holecli", "open3d", "pcl"))
    assert list(summary) == ["holecli", "open3d", "pcl"]
    for row in summary.values():
        assert row["files"] == 1 and row["full_holes"] == 1
        assert set(row) >= {"files_ok", "found", "false_holes", "center_um_median", "center_um_max",
                            "diameter_um_median", "diameter_um_max", "cpu_s_per_file", "wall_s_per_file"}
    assert summary["open3d"]["found"] == summary["pcl"]["found"] == 1
    table = bench.format_table({"easy": summary}).splitlines()
    assert table[0].split()[:3] == ["suite", "method", "files"] and len(table) == 2 + 3
    assert [line.split()[1 if k == 0 else 0] for k, line in enumerate(table[2:])] == ["holecli", "open3d", "pcl"]


def test_the_peers_report_nothing_on_a_plain_sheet(bench):
    rng = np.random.default_rng(0)
    x, y = np.meshgrid(np.arange(0, 12, 0.1), np.arange(0, 10, 0.1))
    points = np.column_stack([x.ravel(), y.ravel(), 0.002 * rng.standard_normal(x.size)])
    assert bench.peer_open3d(points) == [] and bench.peer_pcl(points) == []


@pytest.mark.skipif(not SCORER.exists(), reason="the validation suite's scorer is not beside the repository")
def test_the_copied_scoring_rules_agree_with_the_validation_scorer(bench):
    scorer = _load("validation_score", SCORER)
    suite = SCORER.parent / "realistic"
    cases = {c["scan"]: c for c in json.loads((suite / "cases.json").read_text())["cases"]}
    rng = np.random.default_rng(1)
    for name in ("plate_csk_t10_pp050_lp050_n02_occ.ply", "tray_4holes_slot_t00_pp100_lp200_n02.ply",
                 "pflat_d8_robotB_m_f32_n02_occ.ply"):
        case = cases[name]
        truth = json.loads((suite / case["truth"]).read_text())
        scale = 1e-3 if truth["units"] == "m" else 1.0
        # a report near the truth (some holes off by more than the tolerances), plus a hole on plain material
        holes = [{"center": (np.asarray(h["center"]) + rng.normal(0, 0.02 * scale, 3)).tolist(),
                  "diameter": h["edge_diameter"] + rng.normal(0, 0.03 * scale), "normal": h["surface_normal"],
                  "partial": False} for h in truth["holes"]]
        holes.append({"center": (np.asarray(truth["holes"][0]["center"]) + [5 * scale, 0, 0]).tolist(),
                      "diameter": 2 * scale, "normal": [0, 0, 1], "partial": False})
        doc = {"holes": holes}
        assert bench.score(case, bench._normalise_truth(truth), doc) == scorer.score(case, truth, doc)
