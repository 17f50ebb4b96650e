"""The sensor's side of the surface (issue 24, holecli.robust.facing): a part whose surface faces
away from +z in the file's frame (upside down in a robot's frame, a face inclined away from +z) is
measured as one facing it. The side is taken from ``--view-dir`` when given, else from the points seen
through the surface (a floor or a bore behind it, seen through a hole at a slant), else from the
z-positive convention."""

import math

import numpy as np
import pytest

from holecli.pipeline import detect
from holecli.robust import facing as facing_module
from holecli.simulation.panel import FeatureSpec, PanelSpec, build_panel, panel_truth, with_backing
from holecli.simulation.profiler import ProfilerSpec
from holecli.simulation.scan_part import scan_part
from holecli.simulation.synth import random_rotation


def _turn_over():
    """180 degrees about x: the part upside down in the file's frame."""
    return np.diag([1.0, -1.0, -1.0])


def _frame(rotation, shift):
    matrix = np.eye(4)
    matrix[:3, :3], matrix[:3, 3] = rotation, shift
    return tuple(map(tuple, matrix))


def _scene(seed, frame=None, floor=True, kind="through"):
    """A flat face with one hole, viewed 15-40 degrees off its normal with fan rays, a backing
    floor 2-8 mm behind it (seen through the hole), in the part's frame or ``frame``."""
    rng = np.random.default_rng([2024, seed])
    diameter = rng.uniform(3.0, 6.0)
    feature = FeatureSpec(kind="through", center=(0.0, 0.0), diameter=diameter) if kind == "through" else \
        FeatureSpec(kind="boss", center=(0.0, 0.0), diameter=diameter, height=rng.uniform(1.0, 3.0))
    panel = build_panel(PanelSpec(width=8 * diameter, height=8 * diameter, thickness=rng.uniform(2.0, 4.0),
                                  features=(feature,)))
    vertices, triangles = with_backing(panel, rng.uniform(2.0, 8.0)) if floor else (panel.vertices, panel.triangles)
    tilt = math.radians(rng.uniform(15.0, 40.0))
    pitch = rng.uniform(0.04, 0.08)
    view = (0.0, math.sin(tilt), -math.cos(tilt))
    spec = ProfilerSpec(view=view, line_length=5 * diameter, scan_length=5 * diameter, point_pitch=pitch,
                        line_pitch=pitch, range_noise=0.002, frame=frame)
    scanned = scan_part(vertices, triangles, panel_truth(panel)["features"], spec, rng=seed)
    world_view = np.asarray(view) if frame is None else np.asarray(frame)[:3, :3] @ np.asarray(view)
    return scanned.scan.points, scanned.truth, world_view, pitch


def _matched(holes, truth):
    (hole,) = holes
    return np.asarray(hole.center), hole.diameter, truth["holes"][0]


@pytest.mark.slow
def test_rigid_motions_of_scans_with_floors_seen_through_holes_give_the_same_holes():
    """A scan, the same scan turned over (180 degrees about x: the face's normal has negative z) and
    moved by random rigid motions give the same hole (center moved with it, same diameter) whenever
    the data show the side; they do on some of these scenes (a floor seen through the hole, under
    the material, at a slant), and say so ("convention") on the others."""
    worst, decided = 0.0, 0
    for seed in range(10):
        points, truth, view, pitch = _scene(seed)
        base = detect(points)
        if base.plane.facing.cue != "seen_through":
            # (seed 8 is decided by the fan's spacing since issue 24's fan cue, on the right side,
            # but its diameter is 12.7 um off (> 0.1 pitch): a measurement matter left open)
            assert base.plane.facing.source in ("convention", "data")
            continue
        decided += 1
        center, diameter, true = _matched(base.holes, truth)
        assert abs(diameter - true["diameter"]) < 0.1 * pitch, (seed, diameter, true["diameter"])
        rng = np.random.default_rng([7, seed])
        for rotation in (_turn_over(), random_rotation(rng) @ _turn_over(), random_rotation(rng)):
            shift = rng.uniform(-300.0, 300.0, 3)
            moved = detect(points @ rotation.T + shift)
            assert moved.plane.facing.source == "data", (seed, moved.plane.facing)
            moved_center, moved_diameter, _ = _matched(moved.holes, truth)
            worst = max(worst, np.linalg.norm(moved_center - (rotation @ center + shift)) / pitch,
                        abs(moved_diameter - diameter) / pitch)
    assert decided >= 3, decided  # measured: 3 of 10 (the others: floor inside the circle, or too few points)
    assert worst < 1e-3, worst


@pytest.mark.slow
def test_an_upside_down_part_in_the_files_frame_is_measured_as_one_facing_it():
    """The profiler's own frame option turns the part over (and moves it): the face's normal points
    to -z, the floor behind the hole lies on +z; --view-dir, and the data where they show the side,
    put the sensor on the right side."""
    for seed in (0, 4, 5):
        frame = _frame(_turn_over(), (10.0, -20.0, 30.0))
        points, truth, view, pitch = _scene(seed, frame=frame)
        true = truth["holes"][0]
        assert true["normal"][2] < 0
        for view_dir in (None, view):
            detection = detect(points, view_dir=view_dir)
            assert detection.plane.facing.sign == -1
            assert detection.plane.facing.source == ("data" if view_dir is None else "view_dir")
            center, diameter, _ = _matched(detection.holes, truth)
            assert abs(diameter - true["diameter"]) < 0.1 * pitch, (seed, view_dir, diameter, true["diameter"])
            assert np.linalg.norm(center - true["center"]) < 0.1 * pitch
            assert detection.holes[0].normal[2] > 0  # reported with the z-positive convention


@pytest.mark.slow
def test_a_reversed_view_dir_is_followed_and_flagged():
    """--view-dir is the direction the sensor looks; given reversed on a scan whose data show the
    side, it is followed (the floor becomes a boss: no hole), and when a hole survives, it says so."""
    points, truth, view, pitch = _scene(0, frame=_frame(_turn_over(), (0.0, 0.0, 0.0)))
    detection = detect(points, view_dir=-view)
    assert detection.plane.facing.source == "view_dir" and detection.plane.facing.conflict
    assert all("view_dir_contradicted" in [w.code for w in hole.warnings] for hole in detection.holes)


@pytest.mark.slow
def test_a_boss_seen_at_a_slant_does_not_turn_the_side():
    """A pin's side wall lies over its outline, in the rim's material cells, in front of the surface:
    counted without the surround test (MAX_GAP_DEG) as seen through the surface from the other side,
    the side would flip and the pin's top become a hole's floor."""
    for seed in range(4):
        for frame in (None, _frame(_turn_over(), (0.0, 0.0, 0.0))):
            points, truth, view, pitch = _scene(seed, frame=frame, floor=False, kind="boss")
            detection = detect(points)
            # (a pin seen at a slant may still be reported as a hole: not this test's subject)
            assert detection.plane.facing.source == "convention", (seed, frame is None, detection.plane.facing)


def test_a_bias_correction_that_cannot_be_measured_widens_u_and_warns(monkeypatch):
    """The fallback of the sampling-bias correction (no synthetic hole gave a rim: the correction is
    0) is never silent: the hole says bias_not_measured and its diameter's u covers the correction it
    would have had (up to two gaps). Seen with --view-dir on a hole at the border of an inclined
    face (issue 24's survey, angle_face_from_top: +53 um with the u of a corrected diameter)."""
    import holecli.robust.estimators.rim_fit as rim_fit
    from holecli.simulation.synth import HoleSpec, SceneSpec, make_scan

    scene = SceneSpec(holes=(HoleSpec(center=(0.37, -0.21), diameter=3.0),), extent=(-4.5, 4.5, -4.5, 4.5),
                      spacing=0.1, pattern="random", noise_world_z=0.03)
    points = make_scan(scene, 0).points
    (measured,) = detect(points).holes
    assert measured.uncertainty.estimator == "rim_fit"
    monkeypatch.setattr(rim_fit, "sampling_errors", lambda *args, **kwargs: None)
    detection = detect(points)
    (hole,) = detection.holes
    assert hole.bias_correction == 0.0
    assert "bias_not_measured" in [w.code for w in hole.warnings]
    assert "bias_not_measured" not in [w.code for w in measured.warnings]
    assert hole.uncertainty.diameter >= 2.0 * detection.scales.gap_scale / math.sqrt(3.0)
    assert abs(hole.diameter - measured.diameter) <= 2.0 * hole.uncertainty.diameter


def _fan_scene(seed, turned, kind, fan=True):
    """Like :func:`_scene`, tilts 10-40 degrees, fan or parallel rays, the part in its own frame or
    turned over; ``kind`` "through" (a floor behind, seen through the hole) or "boss" (no floor)."""
    rng = np.random.default_rng([2025, seed])
    diameter = rng.uniform(3.0, 6.0)
    feature = FeatureSpec(kind="through", center=(0.0, 0.0), diameter=diameter) if kind == "through" else \
        FeatureSpec(kind="boss", center=(0.0, 0.0), diameter=diameter, height=rng.uniform(1.0, 4.0))
    thickness = rng.uniform(2.0, 4.0)
    panel = build_panel(PanelSpec(width=8 * diameter, height=8 * diameter, thickness=thickness, features=(feature,)))
    vertices, triangles = with_backing(panel, rng.uniform(2.0, 10.0)) if kind == "through" else \
        (panel.vertices, panel.triangles)
    tilt = math.radians(rng.uniform(10.0, 40.0))
    pitch = rng.uniform(0.04, 0.08)
    frame = _frame(_turn_over(), tuple(rng.uniform(-50.0, 50.0, 3))) if turned else None
    spec = ProfilerSpec(view=(0.0, math.sin(tilt), -math.cos(tilt)), line_length=5 * diameter,
                        scan_length=5 * diameter, point_pitch=pitch, line_pitch=pitch * rng.uniform(1.0, 3.0),
                        range_noise=rng.uniform(0.0, 0.01), frame=frame, fan=fan)
    scanned = scan_part(vertices, triangles, panel_truth(panel)["features"], spec, rng=seed)
    return scanned.scan.points, (-1 if turned else 1), thickness


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["through", "boss"])
def test_a_fans_spacing_decides_the_side_and_never_wrongly(kind):
    """A fan's spacing grows with the range (facing.fan_side): a floor behind a hole, seen straight
    through it (nothing under the material, so seen_through cannot tell), is sparser than the face;
    a boss's top is denser. Over fresh scenes, turned over or not, the data never name the wrong
    side; with parallel rays the spacing cannot tell and the fan cue never decides. Where the floor
    is not seen at all (the bore hides it at a steep view) no cue can tell: those scenes are not
    counted in the decided fraction."""
    wrong, by_fan, cases = [], 0, 0
    for seed in range(8):
        for turned in (False, True):
            for fan in (True, False):
                points, truth, thickness = _fan_scene(seed, turned, kind, fan=fan)
                plane = detect(points).plane
                facing = plane.facing
                floor = np.abs((points - plane.point) @ plane.normal) > thickness + 0.5
                if facing.source == "data" and facing.sign != truth:
                    wrong.append((seed, turned, fan, facing))
                if not fan:
                    assert facing.cue != "fan_spacing", (seed, turned, facing)
                elif facing.cue != "seen_through" and (kind == "boss" or floor.sum() >= facing_module.FAN_MIN_POINTS):
                    cases += 1
                    by_fan += facing.cue == "fan_spacing"
    assert not wrong, wrong
    print(f"{kind}: fan cue decided {by_fan} of {cases}")
    if kind == "through":
        assert by_fan >= 0.5 * cases, (by_fan, cases)  # measured: 4 of 8 (2 seeds, each way up)


def test_a_wide_countersinks_cone_does_not_vote_as_a_floor():
    """Issue 26's defect (benchmarks/features.py, cs110 seed 0): a 110 deg countersink drilled 5 deg
    off the normal, scanned by a fan 10 deg off it, without --view-dir and with nothing seen through
    the surface. The per-point slope test kept the cone's flattest strip (30 deg from the surface),
    6 % denser than the surface through its incidence alone: the fan cue took it for a face in front
    of the sensor, turned the surface over and refused the hole as a boss. A cluster steeper than
    FAN_MAX_FACE_SLOPE_DEG as a whole does not vote: the convention stands and the hole is measured."""
    # The scene as drawn (its fan cue depends on the exact sampling, so the values are kept in full).
    angle = 110.0
    feature = FeatureSpec(kind="countersunk", center=(0.0, 0.0), diameter=4.254335788060978,
                          countersink_diameter=7.080619646556139, countersink_angle_deg=angle, tilt_deg=5.0,
                          tilt_direction_deg=342.36032902035373)
    size, reach = 42.48371787933684, 21.24185893966842
    panel = build_panel(PanelSpec(width=size, height=size, thickness=3.703198319430205, features=(feature,),
                                  chord_error=1e-4))
    spec = ProfilerSpec(target=(0.0, 0.0, 0.0), standoff=100.0,
                        view=(0.1441598994129228, -0.09772987304464642, -0.9847166066010735),
                        line=(-0.8150731461056849, 0.5525600074320565, -0.17416430370218441),
                        line_length=reach, scan_length=reach, point_pitch=0.053104647349171044,
                        line_pitch=0.053104647349171044, fan=True, triangulation_deg=25.0, range_noise=0.005,
                        range_quantum=0.001, float32=True)
    points = scan_part(panel.vertices, panel.triangles, panel_truth(panel)["features"], spec, rng=0).scan.points
    detection = detect(points[np.isfinite(points).all(axis=1)])
    assert detection.plane.facing.sign == 1 and detection.plane.facing.cue != "fan_spacing", detection.plane.facing
    (hole,) = detection.holes
    assert hole.type == "countersunk"
    assert abs(hole.countersink.angle_deg - angle) < 0.5
    assert abs(hole.countersink.diameter - feature.countersink_diameter) < 0.01
