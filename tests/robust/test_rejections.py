"""Tests of the named rejections of the robust method (``Detection.rejected``, ``detect --explain``):
every candidate void that is not a hole says which check refused it, with the check's value and limit."""

import json

import numpy as np
import pytest

from holecli.pipeline import detect
from holecli.robust.method import REJECTION_REASONS
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
