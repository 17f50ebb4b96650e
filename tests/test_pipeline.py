"""Tests of holecli.pipeline: detect() on the paper's Table I scene, the result contract, validation."""

import dataclasses
import json

import numpy as np
import pytest

from holecli.errors import PointsError
from holecli.geometry.plane import orient_normal
from holecli.pipeline import MIN_POINTS, detect, validate_points
from holecli.results import Detection, Hole, Plane, Timing
from holecli.simulation import synth

PLANE_KEYS = {"point", "normal", "rms", "inliers"}
HOLE_KEYS = {
    "index", "center", "diameter", "normal", "rim_points", "fit_rms", "max_residual", "roundness",
    "bias_correction", "partial", "arc_deg", "scan_lines", "type", "countersink", "counterbore", "bore", "axis",
    "perpendicularity_deg", "warnings", "notes", "uncertainty",
}  # fmt: skip
RECORD_KEYS = {"schema_version", "holecli_version", "file", "points", "dropped_points", "input_columns", "method", "options", "scales",
               "candidates", "plane", "holes", "timing"}


def _angle_deg(a, b):
    cosine = np.dot(a, b) / (np.linalg.norm(a) * np.linalg.norm(b))
    return float(np.degrees(np.arccos(np.clip(cosine, -1.0, 1.0))))


def _distance(a, b):
    return float(np.linalg.norm(np.subtract(a, b)))


# --- known answer: the paper's Table I scene without noise -----------------------------------------


def test_paper_method_on_table1_scene(table1_paper, table1_truth, table1_scan):
    assert table1_paper.method == "paper"
    assert table1_paper.points == len(table1_scan.points)
    assert len(table1_paper.holes) == 1
    hole = table1_paper.holes[0]
    assert hole.index == 0
    assert _distance(hole.center, table1_truth["center"]) < 0.010
    assert _angle_deg(hole.normal, table1_truth["normal"]) < 0.01
    # The paper method fits material points outside the edge: biased high by about 0.2 h in radius.
    assert abs(hole.diameter - table1_truth["diameter"]) < 0.070
    assert hole.diameter > table1_truth["diameter"]
    assert hole.bias_correction == 0.0


def test_paper_method_plane_on_table1_scene(table1_paper, table1_truth, table1_scan):
    plane = table1_paper.plane
    assert _angle_deg(plane.normal, table1_truth["normal"]) < 0.01
    assert plane.normal[2] > 0
    assert np.linalg.norm(plane.normal) == pytest.approx(1.0, abs=1e-12)
    np.testing.assert_allclose(plane.point, table1_scan.points.mean(axis=0), atol=1e-12)
    assert plane.rms < 1e-9
    assert plane.inliers == len(table1_scan.points)


def test_paper_method_hole_quality_fields(table1_paper):
    hole = table1_paper.holes[0]
    assert hole.rim_points >= 12
    assert 0.0 < hole.fit_rms <= hole.max_residual <= hole.roundness
    # On a clean grid the rim lies within one grid step of a circle.
    assert hole.roundness < synth.TABLE1_SPACING


def test_center_lies_on_the_fitted_plane(table1_paper):
    hole, plane = table1_paper.holes[0], table1_paper.plane
    assert abs(np.dot(np.subtract(hole.center, plane.point), plane.normal)) < 1e-9


# --- result types and the JSON contract ------------------------------------------------------------


def test_result_types(table1_paper):
    assert isinstance(table1_paper, Detection)
    assert isinstance(table1_paper.holes, tuple)
    assert isinstance(table1_paper.holes[0], Hole)
    assert isinstance(table1_paper.plane, Plane)


def test_to_dict_has_exactly_the_contract_keys(table1_paper):
    record = table1_paper.to_dict()
    assert set(record) == RECORD_KEYS
    assert set(record["plane"]) == PLANE_KEYS
    assert len(record["holes"]) == 1
    assert set(record["holes"][0]) == HOLE_KEYS
    assert record["file"] is None
    assert record["dropped_points"] == 0
    assert record["method"] == "paper"


def test_to_dict_is_json_ready_with_plain_types(table1_paper):
    record = table1_paper.to_dict()
    text = json.dumps(record, allow_nan=False)
    assert json.loads(text) == record
    hole, plane = record["holes"][0], record["plane"]
    # Plain Python types (not numpy scalars): the CSV writer prints floats by repr.
    for value in (*hole["center"], *hole["normal"], hole["diameter"], hole["fit_rms"], hole["max_residual"],
                  hole["roundness"], hole["bias_correction"], hole["arc_deg"], *plane["point"], *plane["normal"],
                  plane["rms"], record["timing"]["elapsed_ms"]):
        assert type(value) is float
    for value in (hole["index"], hole["rim_points"], plane["inliers"], record["points"], record["dropped_points"]):
        assert type(value) is int
    assert type(hole["partial"]) is bool
    assert isinstance(hole["center"], list) and len(hole["center"]) == 3


# --- sign convention and invariances ------------------------------------------------------------


def test_normal_points_up_when_the_cloud_is_upside_down(table1_scan, table1_truth):
    half_turn = np.diag([1.0, -1.0, -1.0])  # about x: the part seen from below
    detection = detect(table1_scan.points @ half_turn.T, method="paper")
    hole = detection.holes[0]
    assert hole.normal[2] > 0 and detection.plane.normal[2] > 0
    expected = orient_normal(half_turn @ np.asarray(table1_truth["normal"]))
    assert _angle_deg(hole.normal, expected) < 0.01
    assert _distance(hole.center, half_turn @ np.asarray(table1_truth["center"])) < 0.010


def test_result_follows_a_rigid_transform_to_within_a_few_micrometres(table1_scan, table1_paper):
    reference = table1_paper.holes[0]
    for seed in range(5):
        rotation = synth.random_rotation(seed)
        shift = np.random.default_rng(seed).normal(0.0, 100.0, 3)
        hole = detect(table1_scan.points @ rotation.T + shift, method="paper").holes[0]
        assert _distance(hole.center, rotation @ np.asarray(reference.center) + shift) < 0.005
        assert abs(hole.diameter - reference.diameter) < 0.005
        assert _angle_deg(hole.normal, orient_normal(rotation @ np.asarray(reference.normal))) < 1e-6


@pytest.mark.xfail(
    reason="paper method depends on the pose beyond round-off: after a random rotation ConvexHull keeps "
    "or drops rim points that are exactly collinear with their hull neighbours (28 -> 29 or 30 rim "
    "points), which moves the center by 1.6 um and the diameter by up to 3.3 um",
    strict=True,
)
def test_result_follows_a_rigid_transform_exactly(table1_scan, table1_paper):
    reference = table1_paper.holes[0]
    for seed in range(5):
        rotation = synth.random_rotation(seed)
        shift = np.random.default_rng(seed).normal(0.0, 100.0, 3)
        hole = detect(table1_scan.points @ rotation.T + shift, method="paper").holes[0]
        assert _distance(hole.center, rotation @ np.asarray(reference.center) + shift) < 1e-6
        assert abs(hole.diameter - reference.diameter) < 1e-6


def test_result_does_not_depend_on_the_order_of_the_points(table1_scan, table1_paper):
    reference = table1_paper.holes[0]
    for seed in range(3):
        order = np.random.default_rng(seed).permutation(len(table1_scan.points))
        detection = detect(table1_scan.points[order], method="paper")
        hole = detection.holes[0]
        assert _distance(hole.center, reference.center) < 1e-9
        assert abs(hole.diameter - reference.diameter) < 1e-9
        assert _distance(hole.normal, reference.normal) < 1e-9
        assert hole.rim_points == reference.rim_points


@pytest.mark.parametrize("factor", [2.0**-10, 2.0**10, 2.0**-40])
def test_result_scales_with_the_cloud(table1_scan, table1_paper, factor):
    # Powers of two scale every coordinate exactly: nothing in the paper method may hold an absolute length.
    reference = table1_paper.holes[0]
    hole = detect(table1_scan.points * factor, method="paper").holes[0]
    assert hole.diameter / factor == pytest.approx(reference.diameter, rel=1e-12)
    np.testing.assert_allclose(np.divide(hole.center, factor), reference.center, rtol=1e-12)
    assert hole.rim_points == reference.rim_points


def test_table1_scene_in_metres():
    scan = synth.make_scan(synth.SceneSpec(unit_scale=0.001), 0)
    truth = scan.truth["holes"][0]
    hole = detect(scan.points, method="paper").holes[0]
    assert _distance(hole.center, truth["center"]) < 0.010e-3
    assert abs(hole.diameter - truth["diameter"]) < 0.070e-3
    assert _angle_deg(hole.normal, truth["normal"]) < 0.01


def test_accepts_float32_and_lists(table1_scan, table1_paper):
    as_list = detect(table1_scan.points[:500].tolist(), method="paper")
    assert as_list.points == 500
    single = detect(table1_scan.points.astype(np.float32), method="paper")
    # float32 moves the points by ~3e-7 mm; the paper's hull step turns that into micrometres (see the
    # xfail above), so the bound here is the same few micrometres.
    assert abs(single.holes[0].diameter - table1_paper.holes[0].diameter) < 0.005


# --- validation --------------------------------------------------------------------------------


def _cloud(n=100):
    return np.random.default_rng(0).normal(size=(n, 3))


def _with_value(value):
    points = _cloud()
    points[17, 1] = value
    return points


@pytest.mark.parametrize(
    "points, match",
    [
        (np.zeros((100, 2)), r"\(n, 3\) array, got shape \(100, 2\)"),
        (np.zeros((100, 4)), r"\(n, 3\) array, got shape \(100, 4\)"),
        (np.zeros(300), r"\(n, 3\) array, got shape \(300,\)"),
        (np.zeros((10, 10, 3)), r"\(n, 3\) array, got shape \(10, 10, 3\)"),
        (_with_value(np.nan), "finite"),
        (_with_value(np.inf), "finite"),
        (_with_value(-np.inf), "finite"),
        (_cloud(MIN_POINTS - 1), f"too few points: {MIN_POINTS - 1}"),
        (np.zeros((0, 3)), "too few points: 0"),
        (np.full((30, 3), "a"), "numeric"),
    ],
)
def test_detect_refuses_unusable_points(points, match):
    with pytest.raises(PointsError, match=match):
        validate_points(points)
    with pytest.raises(PointsError, match=match):
        detect(points, method="paper")


def test_validate_points_returns_contiguous_float64():
    points = np.asfortranarray(np.arange(MIN_POINTS * 3, dtype=np.int32).reshape(MIN_POINTS, 3))
    array = validate_points(points)
    assert array.dtype == np.float64 and array.flags.c_contiguous
    np.testing.assert_array_equal(array, points)


@pytest.mark.parametrize("method", ["magic", "", "Paper", None])
def test_unknown_method_raises(table1_scan, method):
    with pytest.raises(PointsError, match="method must be one of"):
        detect(table1_scan.points, method=method)


def test_flat_points_on_a_line_raise():
    points = np.outer(np.arange(50.0), (1.0, 2.0, 3.0))
    with pytest.raises(PointsError, match="collinear"):
        detect(points, method="paper")


# --- detect_file: read, drop non-finite rows, detect, fill in the file (issue 10) ----------------------


def _without_timing(detection):
    return dataclasses.replace(detection, timing=Timing())


def test_detect_file_is_detect_on_the_files_finite_points(table1_files, tmp_path):
    from holecli import detect_file
    from holecli.io import load_points, save_points

    points = load_points(table1_files[".ply"])
    noisy = np.vstack([points[:10], [[np.nan, 0.0, 0.0], [0.0, np.inf, 1.0]], points[10:]])
    path = tmp_path / "with_nan.csv"
    save_points(path, noisy)
    detection = detect_file(path, method="paper")
    assert detection.file == str(path)
    assert detection.dropped_points == 2
    assert detection.points == len(points)
    assert detection.elapsed_ms > 0
    assert detection.input_columns.indices == (0, 1, 2) and detection.input_columns.names == ("x", "y", "z")
    expected = dataclasses.replace(detect(load_points(path), method="paper"), file=str(path), dropped_points=2,
                                   input_columns=detection.input_columns)
    assert _without_timing(detection) == _without_timing(expected)


def test_detect_file_raises_the_errors_of_reading_and_of_detect(tmp_path, table1_files):
    from holecli import LoadError, detect_file

    with pytest.raises(LoadError, match="file not found"):
        detect_file(tmp_path / "missing.ply")
    with pytest.raises(PointsError, match="max_holes"):
        detect_file(table1_files[".ply"], max_holes=0)
    with pytest.raises(TypeError):
        detect_file(table1_files[".ply"], no_such_option=1)


def test_the_command_line_and_the_batch_workers_measure_with_detect_file(table1_files, run, monkeypatch):
    # The sequence read -> detect -> fill in exists once: both callers go through detect_file.
    from holecli import batch, pipeline

    calls = []
    original = pipeline.detect_file

    def counting(path, **options):
        calls.append((str(path), options))
        return original(path, **options)

    monkeypatch.setattr(pipeline, "detect_file", counting)
    path = str(table1_files[".ply"])
    result = run("detect", path, "--method", "paper")
    assert result.exit_code == 0, result.stderr
    record = batch.measure_record(path, {"method": "paper"})
    assert calls == [(path, {"method": "paper"}), (path, {"method": "paper"})]
    cli_record = json.loads(result.stdout)
    for key in ("timing", "path"):
        cli_record.pop(key, None)
        record.pop(key, None)
    assert cli_record == record


def test_the_panel_sample_s_holes_are_measured_below_their_edges(repo_root):
    """sample_clouds/panel.ply (a straight-down profiler scan at 0.2 mm pitch): each hole's type and
    what the scan shows of it, against the mesh's truth; the paper method does not look below."""
    from holecli import detect_file

    truth = json.loads((repo_root / "sample_clouds" / "panel.truth.json").read_text())["holes"]
    detection = detect_file(repo_root / "sample_clouds" / "panel.ply", gauge_depth=0.5)
    by_kind = {}
    for expected in truth:
        (hole,) = [h for h in detection.holes if np.linalg.norm(np.subtract(h.center, expected["center"])) < 0.5]
        assert hole.type == expected["kind"]
        by_kind[hole.type] = (hole, expected)
    hole, expected = by_kind["countersunk"]
    assert abs(hole.countersink.angle_deg - expected["countersink_angle_deg"]) < 0.1
    assert abs(hole.countersink.diameter - expected["countersink_diameter"]) < 0.005
    assert abs(hole.countersink.depth - expected["countersink_depth"]) < 0.01
    half = np.radians(hole.countersink.angle_deg / 2)
    assert hole.countersink.diameter_at_depth == pytest.approx(hole.countersink.diameter - 2 * 0.5 * np.tan(half))
    assert hole.perpendicularity_deg < 0.1
    hole, expected = by_kind["counterbored"]
    assert abs(hole.counterbore.depth - expected["counterbore_depth"]) < 0.005
    hole, expected = by_kind["blind"]
    assert abs(hole.bore.floor_depth - expected["floor_depth"]) < 0.005
    hole, _ = by_kind["through"]
    assert hole.bore.diameter is None and {n.code for n in hole.notes} == {"bore_not_seen", "axis_not_measured"}
    # a clean straight-down scan: why its values are null are notes, and no hole has a warning
    assert all(h.warnings == () for h, _ in by_kind.values())
    paper = detect_file(repo_root / "sample_clouds" / "table1.ply", method="paper").holes[0]
    assert paper.type is None and paper.bore is None and paper.warnings == () and paper.notes == ()


# --- provenance: scales, options, candidates and timing of a detection (issue 13) ---------------------


def test_detection_carries_the_measured_scales_and_the_options(table1_scan):
    from holecli.results import Options, Scales
    from holecli.settings import RobustSettings

    settings = RobustSettings(alpha_gaps=2.6)
    detection = detect(table1_scan.points, view_dir=(0, 0, 2), max_holes=5, gauge_depth=0.25, settings=settings,
                       rng=3)
    scales = detection.scales
    assert scales.point_spacing == pytest.approx(0.0908, rel=1e-6)  # the Table I grid
    assert scales.lattice is True and scales.line_pitch is None and scales.period == scales.point_spacing
    assert scales.min_diameter == pytest.approx(6 * scales.gap_scale)
    assert scales.triangle_area_bound is None
    assert detection.options == Options(method="robust", view_dir=(0.0, 0.0, 2.0), min_diameter=None, max_holes=5,
                                        full_only=False, gauge_depth=0.25, rng=3, settings=(("alpha_gaps", 2.6),))
    record = detection.to_dict()
    assert record["options"]["min_diameter_effective"] == scales.min_diameter
    assert record["options"]["settings"] == {"alpha_gaps": 2.6}
    assert record["options"]["tolerances"] is None
    assert record["scales"] == dataclasses.asdict(scales)
    assert isinstance(detect(table1_scan.points, min_diameter=1).scales, Scales)
    assert detect(table1_scan.points, min_diameter=1).scales.min_diameter == 1.0


def test_every_candidate_is_a_hole_or_a_rejection(rng):
    scan = synth.make_scan(synth.SceneSpec(holes=(synth.HoleSpec(center=(0.0, 0.0), diameter=3.0),),
                                           extent=(-4, 4, -4, 4), spacing=0.1, pattern="random"), 1)
    detection = detect(scan.points, max_holes=1)
    assert detection.candidates == len(detection.holes) + len(detection.rejected) > 1


def test_timing_has_every_stage_in_order_and_they_make_up_the_elapsed_time(table1_scan):
    detection = detect(table1_scan.points)
    stages = dict(detection.timing.stages)
    assert list(stages) == ["validate", "imports", "plane", "frame", "sampling", "grid", "candidates", "shape"]
    assert all(ms >= 0 for ms in stages.values())
    assert sum(stages.values()) <= detection.timing.elapsed_ms
    assert sum(stages.values()) > 0.9 * detection.timing.elapsed_ms
    assert detection.elapsed_ms == detection.timing.elapsed_ms
    assert detection.timing.read_ms is None
    seen = []
    detect(table1_scan.points, progress=seen.append)
    assert seen == list(stages)


def test_the_paper_method_gives_its_area_bound_and_no_robust_scales(table1_paper):
    scales = table1_paper.scales
    assert scales.triangle_area_bound > 0
    assert scales.point_spacing is None and scales.gap_scale is None and scales.min_diameter is None
    assert [name for name, _ in table1_paper.timing.stages] == ["validate", "imports", "paper"]
    assert table1_paper.candidates == 1
    assert table1_paper.options.settings is None and table1_paper.options.rng is None


def test_detect_file_times_the_reading(table1_files):
    from holecli import detect_file

    detection = detect_file(table1_files[".ply"], method="paper")
    assert detection.timing.read_ms > 0
    assert detection.to_dict()["timing"]["read_ms"] == detection.timing.read_ms
