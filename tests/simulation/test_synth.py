"""Known-answer tests of the synthetic scan generator (holecli.simulation.synth)."""

import json
import math
from dataclasses import replace

import numpy as np
import pytest
from scipy import ndimage
from scipy.spatial import cKDTree

from holecli.simulation.synth import (
    BORE,
    BOSS,
    BOTTOM,
    COUNTERSINK,
    INSIDE,
    MATERIAL,
    MISSING,
    OUTLIER,
    HoleSpec,
    SceneSpec,
    make_scan,
    random_rotation,
    rotation_matrix,
    table1_scene,
)

H = 0.0908


def to_local(scan, scene):
    """Undo the scene's pose (and unit scale): rows in the local surface frame."""
    rot = rotation_matrix(scene.rotation_deg)
    return (scan.points / scene.unit_scale - np.asarray(scene.translation)) @ rot


def median_nn(xy):
    dist, _ = cKDTree(xy).query(xy, k=2)
    return float(np.median(dist[:, 1]))


# -------------------------------------------------------------------------------------------------
# rotations


def test_rotation_matrix_is_proper():
    rot = rotation_matrix((32.0, -17.0, 20.0))
    np.testing.assert_allclose(rot @ rot.T, np.eye(3), atol=1e-15)
    assert np.linalg.det(rot) == pytest.approx(1.0)


def test_rotation_matrix_is_x_then_y_then_z():
    # Rx(90) takes y to z, then Rz(90) leaves z alone; x is fixed by Rx(90) and sent to y by Rz(90).
    rot = rotation_matrix((90.0, 0.0, 90.0))
    np.testing.assert_allclose(rot @ [0.0, 1.0, 0.0], [0.0, 0.0, 1.0], atol=1e-15)
    np.testing.assert_allclose(rot @ [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], atol=1e-15)
    # And it is the product of the single-axis rotations in that order.
    a, b, c = 32.0, -17.0, 20.0
    expected = rotation_matrix((0, 0, c)) @ rotation_matrix((0, b, 0)) @ rotation_matrix((a, 0, 0))
    np.testing.assert_allclose(rotation_matrix((a, b, c)), expected, atol=1e-15)
    # Counter-clockwise about +x: y goes toward +z.
    np.testing.assert_allclose(rotation_matrix((30, 0, 0)) @ [0, 1, 0], [0, math.sqrt(3) / 2, 0.5])


@pytest.mark.parametrize("bad", [(1.0, 2.0), (0.0, np.nan, 0.0), "abc"])
def test_rotation_matrix_rejects_bad_angles(bad):
    with pytest.raises(ValueError, match="rotation_deg"):
        rotation_matrix(bad)


def test_random_rotation_is_proper_and_uniform():
    rng = np.random.default_rng(7)
    mats = np.array([random_rotation(rng) for _ in range(3000)])
    identity = np.broadcast_to(np.eye(3), mats.shape)
    np.testing.assert_allclose(mats @ mats.transpose(0, 2, 1), identity, atol=1e-12)
    np.testing.assert_allclose(np.linalg.det(mats), 1.0)
    # Haar measure on SO(3): every entry has mean 0 and variance 1/3.
    assert np.abs(mats.mean(axis=0)).max() < 0.05
    np.testing.assert_allclose(mats.var(axis=0), 1.0 / 3.0, atol=0.04)
    np.testing.assert_array_equal(random_rotation(3), random_rotation(3))


# -------------------------------------------------------------------------------------------------
# the paper's Table I scene


def test_table1_scene_known_answer():
    scene = table1_scene()
    scan = make_scan(scene, rng=0)
    pts = scan.points
    assert pts.shape == (7062, 3) and pts.dtype == np.float64  # 89 x 89 grid minus the 3 mm disk
    assert scan.truth["points"] == len(pts)
    assert np.all(scan.labels == MATERIAL)

    rot = rotation_matrix((32.0, 0.0, 20.0))
    hole = scan.truth["holes"][0]
    np.testing.assert_allclose(hole["center"], rot @ [1.0, 1.0, 0.0] + [3.0, 4.0, 5.0], atol=1e-14)
    np.testing.assert_allclose(hole["normal"], rot @ [0.0, 0.0, 1.0], atol=1e-15)
    assert hole["diameter"] == hole["bore_diameter"] == 3.0
    assert hole["partial"] is False and hole["arc_deg"] == 360.0 and hole["is_hole"] is True

    normal, center = np.array(hole["normal"]), np.array(hole["center"])
    assert np.abs((pts - center) @ normal).max() < 1e-12           # all on the plane
    radial = pts - center - np.outer((pts - center) @ normal, normal)
    assert np.linalg.norm(radial, axis=1).min() >= 1.5             # none inside the hole's disk
    local = to_local(scan, scene)
    assert local[:, 0].min() == pytest.approx(-3.0)
    assert local[:, 0].max() == pytest.approx(-3 + 88 * H)
    assert median_nn(local[:, :2]) == pytest.approx(H)

    json.dumps(scan.truth)  # JSON-ready


def test_table1_noise_is_on_world_z_with_the_asked_sigma():
    clean = make_scan(table1_scene(), rng=5).points
    noisy = make_scan(table1_scene(noise_fraction=0.3), rng=5).points
    truth = make_scan(table1_scene(noise_fraction=0.3), rng=5).truth
    assert truth["noise_world_z"] == pytest.approx(0.3 * H)
    clean, noisy = clean[np.lexsort(clean[:, :2].T)], noisy[np.lexsort(noisy[:, :2].T)]
    np.testing.assert_array_equal(clean[:, :2], noisy[:, :2])
    assert np.std(noisy[:, 2] - clean[:, 2]) == pytest.approx(0.3 * H, rel=0.05)


def test_table1_inside_points():
    scene = table1_scene(inside_points=100)
    scan = make_scan(scene, rng=1)
    local = to_local(scan, scene)[scan.labels == INSIDE]
    assert len(local) == 100
    assert np.all(np.hypot(local[:, 0] - 1.0, local[:, 1] - 1.0) < 1.5)
    np.testing.assert_allclose(local[:, 2], 0.0, atol=1e-12)


def test_same_seed_same_scan_and_rows_are_shuffled():
    scene = table1_scene(noise_fraction=0.1)
    a, b = make_scan(scene, rng=3), make_scan(scene, rng=3)
    np.testing.assert_array_equal(a.points, b.points)
    plain = make_scan(table1_scene(), rng=1).points
    other = make_scan(table1_scene(), rng=2).points
    assert not np.array_equal(plain, other)
    np.testing.assert_array_equal(plain[np.lexsort(plain.T)], other[np.lexsort(other.T)])


# -------------------------------------------------------------------------------------------------
# sampling patterns


@pytest.mark.parametrize("angle, offset", [(0.0, (0.0, 0.0)), (27.0, (0.03, -0.05))])
def test_grid_spacing(angle, offset):
    scene = SceneSpec(scan_angle_deg=angle, grid_offset=offset)
    local = to_local(make_scan(scene), scene)
    assert median_nn(local[:, :2]) == pytest.approx(H, rel=1e-9)
    assert len(local) == pytest.approx(64 / H**2 - math.pi * 1.5**2 / H**2, rel=0.03)


@pytest.mark.parametrize("angle", [0.0, 35.0])
def test_stripes_spacing_and_pitch(angle):
    scene = SceneSpec(pattern="stripes", spacing=0.05, line_pitch=0.2, scan_angle_deg=angle)
    scan = make_scan(scene)
    local = to_local(scan, scene)
    assert median_nn(local[:, :2]) == pytest.approx(0.05, rel=1e-9)
    t = math.radians(angle)
    across = local[:, :2] @ [-math.sin(t), math.cos(t)]
    lines = np.unique(np.round(across / 1e-6)) * 1e-6
    np.testing.assert_allclose(np.diff(lines), 0.2, atol=1e-5)
    assert scan.truth["line_pitch"] == 0.2 and scan.truth["spacing"] == 0.05


def test_stripes_default_pitch_is_three_spacings():
    scene = SceneSpec(pattern="stripes")
    scan = make_scan(scene)
    assert scan.truth["line_pitch"] == pytest.approx(3 * H)
    lines = np.unique(np.round(to_local(scan, scene)[:, 1] / 1e-6))
    np.testing.assert_allclose(np.diff(lines) * 1e-6, 3 * H, atol=1e-5)


def test_jittered_stays_within_its_cell():
    scene = SceneSpec(pattern="jittered", jitter=0.5)
    local = to_local(make_scan(scene, rng=4), scene)
    dev = (local[:, :2] + 3.0) / H
    dev = np.abs(dev - np.round(dev))
    assert dev.max() <= 0.25 + 1e-9
    assert dev.max() > 0.2
    assert 0.6 * H < median_nn(local[:, :2]) < H


def test_random_density():
    scene = SceneSpec(pattern="random", holes=())
    scan = make_scan(scene, rng=2)
    local = to_local(scan, scene)
    assert len(local) == pytest.approx(64 / H**2, rel=0.03)
    # Poisson process of density 1/h^2: median nearest-neighbour distance sqrt(ln 2 / pi) h.
    assert median_nn(local[:, :2]) == pytest.approx(math.sqrt(math.log(2) / math.pi) * H, rel=0.05)
    assert scan.truth["line_pitch"] is None


# -------------------------------------------------------------------------------------------------
# hole features


def test_countersink_points_on_the_cone_and_bore_on_the_cylinder():
    hole = HoleSpec(center=(1.0, 1.0), diameter=3.0, countersink_diameter=4.0,
                    countersink_angle_deg=100.0, bore_depth=2.5)
    scene = SceneSpec(holes=(hole,), rotation_deg=(10.0, -40.0, 75.0))
    scan = make_scan(scene, rng=0)
    local = to_local(scan, scene)
    rho = np.hypot(local[:, 0] - 1.0, local[:, 1] - 1.0)
    tan_half = math.tan(math.radians(50.0))
    cs_depth = 0.5 / tan_half

    cone = scan.labels == COUNTERSINK
    assert cone.sum() == pytest.approx(math.pi * (2.0**2 - 1.5**2) / H**2, rel=0.1)
    assert np.all((rho[cone] >= 1.5) & (rho[cone] < 2.0))
    np.testing.assert_allclose(local[cone, 2], -(2.0 - rho[cone]) / tan_half, atol=1e-12)

    bore = scan.labels == BORE
    np.testing.assert_allclose(rho[bore], 1.5, atol=1e-12)
    assert local[bore, 2].max() < -cs_depth
    assert local[bore, 2].min() == pytest.approx(-2.5)
    depths = np.unique(np.round(local[bore, 2], 9))
    assert np.diff(depths).max() <= H + 1e-9
    assert len(depths) == math.ceil((2.5 - cs_depth) / H)

    material = scan.labels == MATERIAL
    assert rho[material].min() >= 2.0
    np.testing.assert_allclose(local[material, 2], 0.0, atol=1e-12)
    truth = scan.truth["holes"][0]
    assert truth["diameter"] == 4.0 and truth["bore_diameter"] == 3.0


def test_bore_without_countersink_starts_below_the_surface():
    scene = SceneSpec(holes=(HoleSpec(center=(1.0, 1.0), diameter=3.0, bore_depth=1.0),))
    scan = make_scan(scene)
    local = to_local(scan, scene)[scan.labels == BORE]
    assert -H - 1e-9 <= local[:, 2].max() < 0
    assert local[:, 2].min() == pytest.approx(-1.0)
    # About h apart along each ring as well.
    assert len(local) / len(np.unique(np.round(local[:, 2], 9))) == math.ceil(2 * math.pi * 1.5 / H)


def test_boss_is_above_the_surface_and_not_a_hole():
    scene = SceneSpec(holes=(HoleSpec(center=(1.0, 1.0), diameter=3.0, boss_height=0.8),))
    scan = make_scan(scene)
    local = to_local(scan, scene)
    boss = scan.labels == BOSS
    assert boss.sum() == pytest.approx(math.pi * 1.35**2 / H**2, rel=0.05)
    np.testing.assert_allclose(local[boss, 2], 0.8, atol=1e-12)
    assert np.hypot(local[boss, 0] - 1.0, local[boss, 1] - 1.0).max() < 1.35
    assert scan.truth["holes"][0]["is_hole"] is False


def test_blind_hole_floor_fills_the_bore_disk():
    hole = HoleSpec(center=(1.0, 1.0), diameter=3.0, bottom_depth=0.6, bore_depth=0.6)
    scene = SceneSpec(holes=(hole,), rotation_deg=(10.0, -40.0, 75.0))
    scan = make_scan(scene)
    local = to_local(scan, scene)
    rho = np.hypot(local[:, 0] - 1.0, local[:, 1] - 1.0)
    floor = scan.labels == BOTTOM
    assert floor.sum() == pytest.approx(math.pi * 1.5**2 / H**2, rel=0.05)
    assert rho[floor].max() < 1.5
    np.testing.assert_allclose(local[floor, 2], -0.6, atol=1e-12)
    # The wall ends on the floor; the surface and the truth are those of the same hole without one.
    assert local[scan.labels == BORE, 2].min() == pytest.approx(-0.6)
    assert rho[scan.labels == MATERIAL].min() >= 1.5
    assert scan.truth["holes"] == make_scan(replace(scene, holes=(replace(hole, bottom_depth=0.0),))).truth["holes"]


def test_several_holes():
    holes = (HoleSpec(center=(-1.0, -1.0), diameter=1.5), HoleSpec(center=(2.5, 2.5), diameter=2.0))
    scene = SceneSpec(holes=holes)
    scan = make_scan(scene)
    local = to_local(scan, scene)
    for hole, truth in zip(holes, scan.truth["holes"]):
        assert np.hypot(*(local[:, :2] - hole.center).T).min() >= hole.diameter / 2
        assert truth["diameter"] == hole.diameter


# -------------------------------------------------------------------------------------------------
# defects and units


def test_outliers_and_nan_rows():
    base = make_scan(SceneSpec(), rng=0)
    scene = SceneSpec(outlier_fraction=0.05, nan_points=17)
    scan = make_scan(scene, rng=0)
    n_clean = len(base.points)
    n_out = round(0.05 * n_clean)
    assert (scan.labels == OUTLIER).sum() == n_out == scan.truth["outliers"]
    nan_rows = np.isnan(scan.points).any(axis=1)
    assert nan_rows.sum() == 17 == (scan.labels == MISSING).sum() == scan.truth["nan_points"]
    assert np.isnan(scan.points[nan_rows]).all()
    assert len(scan.points) == n_clean + n_out + 17 == scan.truth["points"]
    local = to_local(scan, scene)[scan.labels == OUTLIER]
    assert local[:, 0].min() >= -3.8 and local[:, 0].max() <= 5.8
    assert np.abs(local[:, 2]).max() <= 2.0 and np.abs(local[:, 2]).max() > 1.0


def test_noise_along_the_normal():
    scene = SceneSpec(noise_normal=0.01)
    local = to_local(make_scan(scene, rng=9), scene)
    assert np.std(local[:, 2]) == pytest.approx(0.01, rel=0.05)


def test_unit_scale_scales_everything():
    scene = SceneSpec(pattern="jittered", noise_world_z=0.02, outlier_fraction=0.01,
                      holes=(HoleSpec(center=(1.0, 1.0), diameter=3.0, countersink_diameter=3.6,
                                      bore_depth=1.0, inside_points=10),))
    mm = make_scan(scene, rng=11)
    metres = make_scan(replace(scene, unit_scale=0.001), rng=11)
    np.testing.assert_allclose(metres.points * 1000.0, mm.points, rtol=1e-12, atol=1e-12)
    t_mm, t_m = mm.truth, metres.truth
    for key in ("spacing", "line_pitch", "noise_world_z", "noise_normal"):
        assert t_m[key] == pytest.approx(t_mm[key] * 0.001)
    np.testing.assert_allclose(t_m["translation"], np.array(t_mm["translation"]) * 0.001)
    center_mm = np.array(t_mm["holes"][0]["center"])
    np.testing.assert_allclose(t_m["holes"][0]["center"], center_mm * 0.001)
    assert t_m["holes"][0]["diameter"] == pytest.approx(0.0036)
    assert t_m["holes"][0]["bore_diameter"] == pytest.approx(0.003)
    assert t_m["holes"][0]["normal"] == t_mm["holes"][0]["normal"]
    assert t_m["rotation_deg"] == t_mm["rotation_deg"] and t_m["unit_scale"] == 0.001


def test_ragged_border_only_eats_the_border_and_leaves_no_void():
    amplitude = 0.6
    plain_scene = SceneSpec()
    ragged_scene = SceneSpec(ragged_border=amplitude)
    plain = to_local(make_scan(plain_scene, rng=0), plain_scene)
    ragged = to_local(make_scan(ragged_scene, rng=0), ragged_scene)

    def cells(local):
        return {tuple(ij) for ij in np.round((local[:, :2] + 3.0) / H).astype(int)}

    kept, full = cells(ragged), cells(plain)
    assert kept < full
    removed = np.array(sorted(full - kept)) * H - 3.0
    x, y = removed.T
    border_distance = np.minimum.reduce([x + 3, 5 - x, y + 3, 5 - y])
    assert border_distance.max() <= amplitude + 1e-9
    assert len(removed) > 0.2 * 4 * 8 * amplitude / H**2  # it did eat a real strip
    # No closed void: every removed node connects (4-neighbours) to the outside of the patch.
    n = 89
    missing = np.ones((n + 2, n + 2), dtype=bool)
    for i, j in kept:
        missing[i + 1, j + 1] = False
    hole = np.hypot(np.arange(n)[:, None] * H - 4.0, np.arange(n)[None, :] * H - 4.0) < 1.5
    missing[1:-1, 1:-1] &= ~hole
    _, count = ndimage.label(missing)
    assert count == 1


def test_partial_hole_at_the_border():
    scene = SceneSpec(holes=(HoleSpec(center=(5.0, 1.0), diameter=3.0),
                             HoleSpec(center=(-3.5, -3.5), diameter=2.0),
                             HoleSpec(center=(1.0, 1.0), diameter=2.0)))
    scan = make_scan(scene)
    half, corner, whole = scan.truth["holes"]
    assert half["partial"] is True and half["arc_deg"] == pytest.approx(180.0, abs=0.1)
    assert corner["partial"] is True and 0 < corner["arc_deg"] < 360
    assert whole["partial"] is False and whole["arc_deg"] == 360.0
    local = to_local(scan, scene)
    assert local[:, 0].max() <= 5.0 and np.hypot(local[:, 0] - 5.0, local[:, 1] - 1.0).min() >= 1.5


def test_hole_outside_the_patch_has_no_arc():
    scan = make_scan(SceneSpec(holes=(HoleSpec(center=(20.0, 1.0), diameter=3.0),)))
    assert scan.truth["holes"][0]["arc_deg"] == 0.0 and scan.truth["holes"][0]["partial"] is True
    assert len(scan.points) == 89 * 89


def test_normal_sign_convention():
    # Turned upside down: R @ z points down, the truth normal still points up.
    scan = make_scan(SceneSpec(rotation_deg=(180.0, 0.0, 0.0)))
    np.testing.assert_allclose(scan.truth["holes"][0]["normal"], [0.0, 0.0, 1.0], atol=1e-15)
    # A wall: the normal lies in the x-y plane and the y component is made positive.
    scan = make_scan(SceneSpec(rotation_deg=(90.0, 0.0, 0.0)))
    np.testing.assert_allclose(scan.truth["holes"][0]["normal"], [0.0, 1.0, 0.0], atol=1e-15)


def test_truth_normals_follow_the_library_convention():
    """The simulation orients its truth normals by holecli's own rule (one convention, one code)."""
    from holecli.geometry.kernels import orient_normal
    from holecli.simulation.synth import rotation_matrix

    for rotation in ((180.0, 0.0, 0.0), (90.0, 0.0, 0.0), (90.0, 0.0, 90.0), (-90.0, 0.0, 90.0), (32.0, 0.0, 20.0),
                     (0.0, 90.0, 0.0), (0.0, -90.0, 0.0)):
        scan = make_scan(SceneSpec(rotation_deg=rotation))
        expected = orient_normal(rotation_matrix(rotation)[:, 2])
        np.testing.assert_array_equal(scan.truth["holes"][0]["normal"], expected)


def test_million_point_stripes_scene():
    scene = SceneSpec(pattern="stripes", spacing=0.04, line_pitch=0.15, scan_angle_deg=20.0,
                      extent=(-40.0, 40.0, -40.0, 40.0), ragged_border=1.0,
                      holes=tuple(HoleSpec(center=(x, y), diameter=4.0, bore_depth=3.0)
                                  for x in (-20.0, 0.0, 20.0) for y in (-20.0, 0.0, 20.0)))
    scan = make_scan(scene)
    assert len(scan.points) > 1_000_000


# -------------------------------------------------------------------------------------------------
# validation


@pytest.mark.parametrize(
    "changes, match",
    [
        ({"spacing": 0.0}, "spacing must be a finite number > 0, got 0.0"),
        ({"spacing": float("nan")}, "spacing"),
        ({"extent": (5.0, -3.0, -3.0, 5.0)}, "xmin < xmax"),
        ({"extent": (0.0, 1.0, 2.0)}, "extent must be 4 finite numbers"),
        ({"pattern": "hexagonal"},
         "pattern must be one of grid, stripes, jittered, random, got 'hexagonal'"),
        ({"line_pitch": -1.0}, "line_pitch"),
        ({"jitter": -0.1}, "jitter"),
        ({"noise_world_z": -1.0}, "noise_world_z"),
        ({"outlier_fraction": 1.5}, r"outlier_fraction must be in \[0, 1\], got 1.5"),
        ({"ragged_border": 3.0}, r"ragged_border must be in \[0, 2\)"),
        ({"nan_points": -1}, "nan_points"),
        ({"nan_points": 2.5}, "nan_points"),
        ({"unit_scale": 0.0}, "unit_scale"),
        ({"spacing": 1e-5}, "samples of the extent"),
        ({"holes": (HoleSpec(center=(1.0, 1.0), diameter=0.0),)}, r"holes\[0\].diameter must be"),
        ({"holes": (HoleSpec(center=(1.0, 1.0), diameter=3.0, countersink_diameter=2.0),)},
         r"countersink_diameter must be None or a finite number > diameter \(3.0\), got 2.0"),
        ({"holes": (HoleSpec(center=(1.0, 1.0), diameter=3.0, countersink_angle_deg=180.0),)},
         "countersink_angle_deg"),
        ({"holes": (HoleSpec(center=(1.0,), diameter=3.0),)}, "center"),
        ({"holes": (HoleSpec(center=(1.0, 1.0), diameter=3.0, inside_points=-5),)},
         "inside_points"),
        ({"holes": (HoleSpec(center=(1.0, 1.0), diameter=3.0, bottom_depth=-1.0),)}, "bottom_depth"),
        ({"holes": (HoleSpec(center=(1.0, 1.0), diameter=3.0, bottom_depth=0.5, bore_depth=1.0),)},
         r"bottom_depth must be 0 or at least bore_depth \(1.0\), got 0.5"),
        ({"holes": (HoleSpec(center=(1.0, 1.0), diameter=3.0, countersink_diameter=4.0, bottom_depth=0.2),)},
         "deeper than the countersink"),
        ({"holes": (HoleSpec(center=(1.0, 1.0), diameter=3.0, boss_height=0.5, bottom_depth=1.0),)},
         "when the hole holds a boss"),
        ({"holes": (HoleSpec(center=(0.0, 0.0), diameter=3.0),
                    HoleSpec(center=(2.0, 0.0), diameter=3.0))},
         "must not overlap"),
    ],
)
def test_invalid_scenes_are_rejected(changes, match):
    with pytest.raises(ValueError, match=match):
        make_scan(replace(SceneSpec(), **changes))
