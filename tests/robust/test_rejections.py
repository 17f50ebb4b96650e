"""Tests of the named rejections of the robust method (``Detection.rejected``, ``detect --explain``):
every candidate void that is not a hole says which check refused it, with the check's value and limit."""

import json

import numpy as np
import pytest

from holecli.pipeline import detect
from holecli.vocabulary import REJECTION_REASONS
from holecli.simulation import synth


def _scan(holes, seed=0, **scene):
    spec = synth.SceneSpec(holes=tuple(holes), extent=scene.pop("extent", (-4.0, 4.0, -4.0, 4.0)), spacing=0.08,
                           **scene)
    return synth.make_scan(spec, seed)


def _checks(detection):
    return [rejection.check for rejection in detection.rejected]


def test_a_plain_hole_on_a_grid_rejects_nothing():
    detection = detect(_scan([synth.HoleSpec(center=(0.0, 0.0), diameter=3.0)]).points)
    assert len(detection.holes) == 1
    assert detection.rejected == ()


def test_a_hole_below_the_minimum_diameter_says_so_with_its_size():
    detection = detect(_scan([synth.HoleSpec(center=(0.0, 0.0), diameter=3.0)]).points, min_diameter=4.0)
    assert detection.holes == ()
    (rejection,) = detection.rejected
    assert rejection.check == "below_min_diameter"
    # refused before its rim is extracted: the largest disk empty of material centred in it (an upper
    # bound: a little larger than the hole)
    assert rejection.value == pytest.approx(3.0, abs=0.1) and rejection.limit == pytest.approx(4.0)
    assert rejection.diameter == pytest.approx(rejection.value)
    assert rejection.reason == REJECTION_REASONS["below_min_diameter"]


def test_a_boss_is_rejected_as_a_boss():
    detection = detect(_scan([synth.HoleSpec(center=(0.0, 0.0), diameter=3.0, boss_height=0.5)]).points)
    assert detection.holes == ()
    assert "boss" in _checks(detection)
    boss = next(r for r in detection.rejected if r.check == "boss")
    assert boss.value > boss.limit


def _slot_points(width=2.0, length=6.0, spacing=0.08, tilt_deg=20.0):
    """A tilted grid scan of a plate with a rounded slot (a cut-out that is not a hole)."""
    u, v = np.meshgrid(np.arange(-6.0, 6.0, spacing), np.arange(-4.0, 4.0, spacing))
    u, v = u.ravel(), v.ravel()
    half = (length - width) / 2.0
    along = np.clip(u, -half, half)
    keep = np.hypot(u - along, v) > width / 2.0
    points = np.column_stack([u[keep], v[keep], np.zeros(keep.sum())])
    t = np.radians(tilt_deg)
    rotation = np.array([[1.0, 0.0, 0.0], [0.0, np.cos(t), -np.sin(t)], [0.0, np.sin(t), np.cos(t)]])
    return points @ rotation.T + [10.0, 20.0, 30.0]


def test_a_slot_is_not_round_and_has_its_shape():
    detection = detect(_slot_points())
    assert detection.holes == ()
    (slot,) = [r for r in detection.rejected if r.check == "not_round"]
    # 6 x 2 mm along x, on a 0.08 mm grid: to about a point spacing
    assert slot.shape["length"] == pytest.approx(6.0, abs=0.1)
    assert slot.shape["width"] == pytest.approx(2.0, abs=0.1)
    assert abs(slot.shape["direction"][0]) == pytest.approx(1.0, abs=1e-3)
    assert slot.center == pytest.approx((10.0, 20.0, 30.0), abs=0.05)
    assert all(r.shape is None for r in detection.rejected if r.check != "not_round")


def _cutout_among_holes(width=4.5, length=15.0, corner=0.6, spacing=0.1, tilt_deg=20.0, seed=0):
    """A tilted grid scan of a plate with a rectangular cut-out (rounded corners, its length along y)
    between four 1.5 mm holes, 2 um noise: the class of the tray's 12.7 x 45 mm window."""
    u, v = np.meshgrid(np.arange(-10.0, 10.0, spacing), np.arange(-10.0, 10.0, spacing))
    u, v = u.ravel(), v.ravel()
    qu, qv = np.abs(u) - (width / 2 - corner), np.abs(v) - (length / 2 - corner)
    outside = np.hypot(np.maximum(qu, 0), np.maximum(qv, 0)) + np.minimum(np.maximum(qu, qv), 0) > corner
    for x in (-8.0, 8.0):
        for y in (-8.0, 8.0):
            outside &= np.hypot(u - x, v - y) > 0.75
    noise = np.random.default_rng(seed).normal(0.0, 0.002, outside.sum())
    points = np.column_stack([u[outside], v[outside], noise])
    t = np.radians(tilt_deg)
    rotation = np.array([[1.0, 0.0, 0.0], [0.0, np.cos(t), -np.sin(t)], [0.0, np.sin(t), np.cos(t)]])
    return points @ rotation.T + [10.0, 20.0, 30.0]


def test_a_long_cutout_is_no_hole_though_its_ends_are_round():
    # Its first circle spans the window's long sides; without them (dropped as reflections) the rim
    # left is its two ends, which a circle through the corners fits well (the tray's d45.5 "hole").
    detection = detect(_cutout_among_holes())
    assert [round(hole.diameter, 1) for hole in detection.holes] == [1.5] * 4
    (cutout,) = [r for r in detection.rejected if r.check == "material_in_first_circle"]
    assert cutout.value > cutout.limit
    assert cutout.center == pytest.approx((10.0, 20.0, 30.0), abs=0.5)
    # its outline: 15 x 4.5 mm along y, to about a spacing
    assert cutout.shape["length"] == pytest.approx(15.0, abs=0.2)
    assert cutout.shape["width"] == pytest.approx(4.5, abs=0.2)
    assert abs(cutout.shape["direction"][0]) < 1e-2


def test_reflections_inside_a_hole_are_not_material():
    # 100 reflections scattered in the paper's 3 mm hole lie deep inside its first circle: specks of
    # the occupancy grid, not material, so the check above leaves the hole alone.
    detection = detect(synth.make_scan(synth.table1_scene(inside_points=100), 0).points)
    assert len(detection.holes) == 1
    assert "material_in_first_circle" not in _checks(detection)


def test_max_holes_and_full_only_name_what_they_leave_out():
    holes = [synth.HoleSpec(center=(-2.0, 0.0), diameter=3.0), synth.HoleSpec(center=(2.5, 0.0), diameter=2.0),
             synth.HoleSpec(center=(5.6, 0.0), diameter=2.0)]  # the last one cut by the border
    scan = _scan(holes, extent=(-4.0, 6.0, -3.0, 3.0))
    everything = detect(scan.points)
    assert len(everything.holes) == 3 and sum(hole.partial for hole in everything.holes) == 1
    one = detect(scan.points, max_holes=1)
    assert len(one.holes) == 1 and _checks(one).count("beyond_max_holes") == 2
    full = detect(scan.points, full_only=True)
    assert len(full.holes) == 2 and _checks(full).count("partial_left_out") == 1


def test_every_check_named_is_documented():
    detection = detect(_scan([synth.HoleSpec(center=(0.0, 0.0), diameter=3.0)], pattern="random", seed=3).points)
    assert detection.rejected  # natural gaps of random sampling
    for rejection in detection.rejected:
        assert rejection.check in REJECTION_REASONS
        assert np.all(np.isfinite(rejection.center)) and rejection.diameter > 0


# --- the command line ------------------------------------------------------------------------------------


@pytest.fixture
def slot_scan(tmp_path):
    from holecli.io import save_points

    path = tmp_path / "slot.ply"
    save_points(path, _slot_points())
    return path


def test_explain_adds_the_rejected_list_to_the_record(run, slot_scan):
    plain = run("detect", slot_scan)
    assert plain.exit_code == 4 and "rejected" not in json.loads(plain.stdout)
    explained = run("detect", slot_scan, "--explain")
    assert explained.exit_code == 4
    rejected = json.loads(explained.stdout)["rejected"]
    assert any(rejection["check"] == "not_round" for rejection in rejected)
    assert set(rejected[0]) == {"check", "reason", "center", "diameter", "value", "limit", "shape"}


def test_explain_table_lists_the_candidates(run, slot_scan):
    result = run("detect", slot_scan, "--explain", "--format", "table")
    assert result.exit_code == 4
    assert "not reported as holes" in result.stdout and "not_round" in result.stdout


def test_explain_with_csv_is_a_usage_error(run, slot_scan):
    assert run("detect", slot_scan, "--explain", "--format", "csv").exit_code == 2
