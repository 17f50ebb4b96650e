"""Tests of holecli.simulation.panel: closed meshes of drilled panels and their truth."""

import json
import math

import numpy as np
import pytest

from holecli.errors import SpecError
from holecli.simulation.panel import (
    BOTTOM,
    FLOOR,
    SIDE,
    TOP,
    WALL,
    FeatureSpec,
    PanelSpec,
    build_panel,
    panel_truth,
    parse_panel_toml,
)

THICKNESS = 3.0


def _features():
    return (
        FeatureSpec("through", (-50.0, -20.0), 5.0),
        FeatureSpec("countersunk", (-25.0, -20.0), 4.8, countersink_diameter=9.0),
        FeatureSpec("counterbored", (0.0, -20.0), 4.0, counterbore_diameter=8.0, counterbore_depth=1.5),
        FeatureSpec("blind", (25.0, -20.0), 3.0, depth=2.0),
        FeatureSpec("slot", (50.0, -20.0), width=6.0, length=20.0, direction_deg=30.0),
        FeatureSpec("through", (-50.0, 20.0), 3.0),
        FeatureSpec("countersunk", (-25.0, 20.0), 5.0, countersink_diameter=10.0, countersink_angle_deg=82.0),
        FeatureSpec("through", (0.0, 20.0), 6.35),
        FeatureSpec("blind", (25.0, 20.0), 5.0, depth=1.0),
        FeatureSpec("countersunk", (50.0, 20.0), 4.0, countersink_diameter=7.0, countersink_angle_deg=90.0),
        FeatureSpec("boss", (0.0, 0.0), 6.0, height=2.0),
    )


SPECS = {
    "flat": PanelSpec(140.0, 90.0, THICKNESS, features=_features()),
    "convex": PanelSpec(140.0, 90.0, THICKNESS, "convex", 500.0, features=_features()),
    "concave": PanelSpec(140.0, 90.0, THICKNESS, "concave", 800.0, features=_features()),
}


_BUILT = {}


def _built(name):
    # Each panel is built once for the whole module (about a second each).
    if name not in _BUILT:
        _BUILT[name] = build_panel(SPECS[name])
    return _BUILT[name]


@pytest.fixture(params=sorted(SPECS))
def panel(request):
    return _built(request.param)


@pytest.fixture
def flat():
    return _built("flat")


def _axis_frame(panel, k):
    truth = panel.features[k]
    return np.asarray(truth["center"]), np.asarray(truth["axis"])


def _part_vertices(panel, part, k):
    tri = panel.triangles[(panel.parts == part) & (panel.triangle_feature == k)]
    return panel.vertices[np.unique(tri)]


def _radial_axial(points, center, axis):
    rel = points - center
    axial = rel @ axis
    return np.linalg.norm(rel - axial[:, None] * axis, axis=1), axial


def _distance_from_bend_axis(panel, points):
    sign = 1.0 if panel.spec.curvature == "convex" else -1.0
    return np.hypot(points[:, 0], points[:, 2] + sign * panel.spec.radius)


# --------------------------------------------------------------------------------------------------
# The mesh


def test_closed_and_consistently_oriented(panel):
    tri = panel.triangles
    assert tri.dtype == np.int64 and panel.vertices.dtype == np.float64
    n = len(panel.vertices)
    directed = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    key = directed[:, 0] * n + directed[:, 1]
    reverse = directed[:, 1] * n + directed[:, 0]
    # Each directed edge once and its reverse once: every edge in exactly two triangles, run
    # opposite ways (consistent orientation).
    assert len(np.unique(key)) == len(key)
    assert np.isin(key, reverse).all()
    assert len(np.unique(tri)) == n
    p = panel.vertices[tri]
    area = np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1) / 2
    assert area.min() > 0
    volume = np.einsum("ij,ij->i", p[:, 0], np.cross(p[:, 1], p[:, 2])).sum() / 6
    assert volume > 0.9 * 140 * 90 * THICKNESS


def _feature_volume(f, t, segments):
    """Volume of the feature's polygonal solid (inscribed polygons of ``segments`` sides)."""
    if f.kind == "slot":
        n_arc, r = segments // 2, f.width / 2
        return (n_arc * r * r * math.sin(math.pi / n_arc) + f.width * (f.length - f.width)) * t
    # A regular N-gon inscribed in a circle holds this fraction of its area (frusta scale alike).
    return segments * math.sin(2 * math.pi / segments) / (2 * math.pi) * _round_volume(f, t)


def _round_volume(f, t):
    r = f.diameter / 2
    if f.kind == "through":
        return math.pi * r * r * t
    if f.kind == "blind":
        return math.pi * r * r * f.depth
    if f.kind == "boss":
        return -math.pi * r * r * f.height
    if f.kind == "counterbored":
        rb, h = f.counterbore_diameter / 2, f.counterbore_depth
        return math.pi * (rb * rb * h + r * r * (t - h))
    rc = f.countersink_diameter / 2
    h = (rc - r) / math.tan(math.radians(f.countersink_angle_deg) / 2)
    return math.pi * h / 3 * (rc * rc + rc * r + r * r) + math.pi * r * r * (t - h)


def test_flat_volume_is_the_sheet_minus_the_features(flat):
    spec = flat.spec
    p = flat.vertices[flat.triangles]
    volume = np.einsum("ij,ij->i", p[:, 0], np.cross(p[:, 1], p[:, 2])).sum() / 6
    expected = spec.width * spec.height * spec.thickness - sum(
        _feature_volume(f, spec.thickness, truth["segments"]) for f, truth in zip(spec.features, flat.features))
    assert volume == pytest.approx(expected, rel=1e-11)


def test_top_face_covers_the_sheet_minus_the_edge_polygons(flat):
    top = flat.triangles[flat.parts == TOP]
    p = flat.vertices[top]
    area = np.sum(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])[:, 2]) / 2
    holes = 0.0
    for loop in flat.edge_loops:
        x, y = flat.vertices[loop, 0], flat.vertices[loop, 1]
        holes += 0.5 * np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y)
    assert area == pytest.approx(flat.spec.width * flat.spec.height - holes, rel=1e-12)


def test_no_top_triangle_crosses_a_feature_contour(panel):
    # With every edge shared by two triangles and the face's area accounted for above, a crossing
    # triangle would have to cover part of a feature: its centroid would be inside the contour.
    top = panel.triangles[panel.parts == TOP]
    centroids = panel.vertices[top].mean(axis=1)
    for k, loop in enumerate(panel.edge_loops):
        center, axis = _axis_frame(panel, k)
        edge = panel.vertices[loop]
        near = centroids[np.linalg.norm(centroids - center, axis=1) < 20] - center
        # A point is outside the convex edge polygon (projected along the axis) iff it is to the
        # right of at least one of the polygon's counter-clockwise edges.
        a, b = edge - center, np.roll(edge, -1, axis=0) - center
        normal = np.cross(axis, b - a)          # points into the polygon
        side = near @ normal.T - np.sum(a * normal, axis=1)
        assert (side < 0).any(axis=1).all()


def test_faces_lie_on_the_design_surfaces(panel):
    spec = panel.spec
    top = panel.vertices[np.unique(panel.triangles[panel.parts == TOP])]
    bottom = panel.vertices[np.unique(panel.triangles[panel.parts == BOTTOM])]
    if spec.curvature == "flat":
        assert np.abs(top[:, 2]).max() < 1e-12
        assert np.abs(bottom[:, 2] + spec.thickness).max() < 1e-12
    else:
        sign = 1.0 if spec.curvature == "convex" else -1.0
        assert np.abs(_distance_from_bend_axis(panel, top) - spec.radius).max() < 1e-9
        assert np.abs(_distance_from_bend_axis(panel, bottom) - (spec.radius - sign * spec.thickness)).max() < 1e-9
    assert set(np.unique(panel.parts)) == {TOP, BOTTOM, SIDE, WALL, FLOOR}


def test_curved_facets_stay_near_the_cylinder(panel):
    spec = panel.spec
    if spec.curvature == "flat":
        pytest.skip("flat")
    p = panel.vertices[panel.triangles[panel.parts == TOP]]
    worst = 0.0
    for weights in ([1 / 3, 1 / 3, 1 / 3], [0.5, 0.5, 0.0], [0.0, 0.5, 0.5], [0.5, 0.0, 0.5]):
        q = np.einsum("k,ikj->ij", np.array(weights), p)
        worst = max(worst, np.abs(_distance_from_bend_axis(panel, q) - spec.radius).max())
    # Grid facets are within chord_error; those where the rings meet the grid within about 4 times.
    assert worst < 5 * spec.chord_error


def test_edge_loops_at_the_stated_diameters(panel):
    for k, (f, truth) in enumerate(zip(panel.spec.features, panel.features)):
        if f.kind == "slot":
            continue
        center, axis = _axis_frame(panel, k)
        radial, _ = _radial_axial(panel.vertices[panel.edge_loops[k]], center, axis)
        assert len(radial) == truth["segments"]
        if f.kind != "countersunk" or panel.spec.curvature == "flat":
            # A drilled cylinder's edge projects along the axis onto its own circle.
            assert truth["diameter"] == pytest.approx(truth["nominal_diameter"], abs=1e-9)
            np.testing.assert_allclose(radial, truth["diameter"] / 2, atol=1e-9)
        assert radial.max() == pytest.approx(truth["polygon_circumradius"], abs=1e-12)
        assert truth["edge_diameter_min"] <= truth["diameter"] <= truth["edge_diameter_max"]
        assert 2 * truth["polygon_inradius"] <= truth["edge_diameter_min"] + 1e-12
        if f.kind != "countersunk" or panel.spec.curvature == "flat":
            # Default chord error 0.1 um: the polygon's inscribed and circumscribed circles agree to it.
            assert truth["polygon_circumradius"] - truth["polygon_inradius"] < 1e-4
        else:
            # The curved cone's edge is no circle; its polygon's vertices lie on the exact loop.
            assert radial.min() >= truth["edge_diameter_min"] / 2 - 1e-9
            assert radial.max() <= truth["edge_diameter_max"] / 2 + 1e-9


def test_curved_countersink_edge_moves_with_the_surface():
    convex = _built("convex").features[1]
    concave = _built("concave").features[1]
    # The convex surface falls away from the tangent plane, so the cone is cut lower and narrower.
    assert convex["diameter"] < 9.0 < concave["diameter"]
    half = math.radians(100.0 / 2)
    # First order: the edge drops by rho^2 cos^2(theta) / (2R), its radius by tan(half) times that.
    expected = 9.0 - 2 * math.tan(half) * 4.5 ** 2 / (2 * 500.0) / 2
    assert convex["diameter"] == pytest.approx(expected, abs=2e-3)
    assert convex["edge_axial_offset"][0] < 0 and convex["edge_axial_offset"][2] == pytest.approx(0, abs=1e-9)


def test_countersink_angle_from_the_cone_vertices(panel):
    for k, f in enumerate(panel.spec.features):
        if f.kind != "countersunk":
            continue
        center, axis = _axis_frame(panel, k)
        truth = panel.features[k]
        h, r = truth["countersink_depth"], f.diameter / 2
        radial, axial = _radial_axial(_part_vertices(panel, WALL, k), center, axis)
        rim = radial > r + 1e-6
        angle = 2 * np.degrees(np.arctan((radial[rim] - r) / (axial[rim] + h)))
        np.testing.assert_allclose(angle, f.countersink_angle_deg, atol=1e-9)
        assert truth["countersink_angle_deg"] == f.countersink_angle_deg


def test_floors_at_the_stated_depths(panel):
    for k, f in enumerate(panel.spec.features):
        if f.kind not in ("blind", "counterbored", "boss"):
            continue
        center, axis = _axis_frame(panel, k)
        radial, axial = _radial_axial(_part_vertices(panel, FLOOR, k), center, axis)
        if f.kind == "boss":
            np.testing.assert_allclose(axial, f.height, atol=1e-12)
            assert panel.features[k]["height"] == f.height
            continue
        depth = f.depth if f.kind == "blind" else f.counterbore_depth
        np.testing.assert_allclose(axial, -depth, atol=1e-12)
        key = "floor_depth" if f.kind == "blind" else "counterbore_depth"
        assert panel.features[k][key] == depth
        outer = f.diameter / 2 if f.kind == "blind" else f.counterbore_diameter / 2
        assert radial.max() == pytest.approx(outer, abs=1e-12)


def test_raycast_through_blind_slot_and_countersink(flat):
    o3d = pytest.importorskip("open3d")
    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(o3d.core.Tensor(flat.vertices.astype(np.float32)),
                        o3d.core.Tensor(flat.triangles.astype(np.uint32)))
    f = flat.spec.features
    cs = f[1]
    mid = (cs.diameter / 2 + cs.countersink_diameter / 2) / 2
    cone_z = -(cs.countersink_diameter / 2 - mid) / math.tan(math.radians(cs.countersink_angle_deg) / 2)
    targets = [(f[0].center, math.inf), (f[4].center, math.inf), (f[3].center, -f[3].depth),
               (f[8].center, -f[8].depth), ((0.0, 10.0), 0.0), ((cs.center[0] + mid, cs.center[1]), cone_z),
               (f[2].center, math.inf),
               ((f[2].center[0], f[2].center[1] + 3.0), -f[2].counterbore_depth),
               (f[10].center, f[10].height), ((f[10].center[0] + 3.5, 0.0), 0.0)]
    rays = np.array([[u, v, 10.0, 0.0, 0.0, -1.0] for (u, v), _ in targets], dtype=np.float32)
    hits = scene.cast_rays(o3d.core.Tensor(rays))["t_hit"].numpy()
    for (where, z), t_hit in zip(targets, hits):
        if math.isinf(z):
            assert math.isinf(t_hit), where
        else:
            assert 10.0 - t_hit == pytest.approx(z, abs=1e-5), where


# --------------------------------------------------------------------------------------------------
# Resolution and truth


def test_segments_follow_the_chord_error():
    spec = PanelSpec(30.0, 30.0, 3.0, features=(FeatureSpec("through", (0.0, 0.0), 5.0),), chord_error=1e-4)
    n = build_panel(spec).features[0]["segments"]
    assert n % 8 == 0 and 2.5 * (1 - math.cos(math.pi / n)) <= 1e-4
    coarse = PanelSpec(30.0, 30.0, 3.0, features=spec.features, segments=64)
    truth = build_panel(coarse).features[0]
    assert truth["segments"] == 64
    assert truth["polygon_inradius"] == pytest.approx(2.5 * math.cos(math.pi / 64), abs=1e-12)
    assert truth["bore_polygon_inradius"] == pytest.approx(2.5 * math.cos(math.pi / 64), abs=1e-12)


def _is_closed(panel):
    tri, n = panel.triangles, len(panel.vertices)
    directed = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    key, reverse = directed[:, 0] * n + directed[:, 1], directed[:, 1] * n + directed[:, 0]
    return len(np.unique(key)) == len(key) and bool(np.isin(key, reverse).all())


@pytest.mark.parametrize("spec", [
    PanelSpec(40.0, 40.0, 3.0, segments=8, features=(
        FeatureSpec("countersunk", (0.0, 0.0), 5.0, countersink_diameter=9.0),
        FeatureSpec("slot", (0.0, 12.0), width=4.0, length=10.0))),
    PanelSpec(40.0, 40.0, 3.0, chord_error=0.05, features=(FeatureSpec("through", (0.0, 0.0), 0.5),)),
    PanelSpec(40.0, 40.0, 3.0, features=(FeatureSpec("through", (0.0, 0.0), 5.0),
                                         FeatureSpec("through", (5.5, 0.0), 5.0))),
    PanelSpec(40.0, 40.0, 6.0, "convex", 60.0, features=(
        FeatureSpec("counterbored", (10.0, 0.0), 4.0, counterbore_diameter=12.0, counterbore_depth=2.0),
        FeatureSpec("slot", (-10.0, 0.0), width=4.0, length=15.0, direction_deg=45.0))),
    PanelSpec(40.0, 40.0, 6.0, "concave", 60.0, features=(
        FeatureSpec("countersunk", (10.0, 0.0), 4.0, countersink_diameter=12.0, countersink_angle_deg=82.0),
        FeatureSpec("blind", (-10.0, 5.0), 8.0, depth=5.0))),
    PanelSpec(10.0, 10.0, 1.0),
], ids=["8-segments", "coarse-tiny-hole", "minimum-gap", "tight-convex", "tight-concave", "no-features"])
def test_extreme_specs_still_give_closed_meshes(spec):
    assert _is_closed(build_panel(spec))


def test_panel_truth_is_json_ready(panel):
    truth = json.loads(json.dumps(panel_truth(panel)))
    assert len(truth["features"]) == 11
    assert [h["index"] for h in truth["holes"]] == [0, 1, 2, 3, 5, 6, 7, 8, 9]
    assert truth["features"][10]["is_hole"] is False and truth["features"][10]["height"] == 2.0
    slot = truth["features"][4]
    assert slot["is_hole"] is False and slot["width"] == 6.0 and slot["length"] == 20.0
    assert np.linalg.norm(slot["direction"]) == pytest.approx(1.0)
    for hole in truth["holes"]:
        assert np.linalg.norm(hole["normal"]) == pytest.approx(1.0) and hole["normal"][2] > 0
        assert hole["partial"] is False and hole["arc_deg"] == 360.0
    assert truth["panel"]["curvature"] == panel.spec.curvature
    assert truth["vertices"] == len(panel.vertices) and truth["triangles"] == len(panel.triangles)


# --------------------------------------------------------------------------------------------------
# Validation


def _one(**changes):
    values = dict(kind="through", center=(0.0, 0.0), diameter=5.0)
    values.update(changes)
    return FeatureSpec(**values)


@pytest.mark.parametrize("spec, match", [
    (PanelSpec(0.0, 50.0, 3.0), r"^width must be a finite number > 0, got 0\.0"),
    (PanelSpec(50.0, 50.0, float("nan")), r"^thickness must be"),
    (PanelSpec(50.0, 50.0, 3.0, curvature="wavy"), r"^curvature must be one of flat, convex, concave"),
    (PanelSpec(50.0, 50.0, 3.0, curvature="convex"), r"^radius must be a finite number >= 30"),
    (PanelSpec(50.0, 50.0, 3.0, radius=500.0), r"^radius must be None"),
    (PanelSpec(900.0, 50.0, 3.0, curvature="convex", radius=500.0), r"^width must be at most 785"),
    (PanelSpec(50.0, 50.0, 3.0, segments=30), r"^segments must be None or an integer >= 8 divisible by 4"),
    (PanelSpec(50.0, 50.0, 3.0, features=(_one(kind="hex"),)), r"^features\[0\]\.kind must be one of"),
    (PanelSpec(50.0, 50.0, 3.0, features=(_one(diameter=-1.0),)), r"^features\[0\]\.diameter must be"),
    (PanelSpec(50.0, 50.0, 3.0, features=(_one(center=(0.0,)),)), r"^features\[0\]\.center must be 2"),
    (PanelSpec(50.0, 50.0, 3.0, features=(_one(depth=1.0),)), r"^features\[0\]\.depth must be omitted"),
    (PanelSpec(50.0, 50.0, 3.0, features=(_one(kind="blind", depth=3.0),)),
     r"^features\[0\]\.depth must be a number in \(0, thickness = 3\), got 3\.0"),
    (PanelSpec(50.0, 50.0, 3.0, features=(_one(kind="countersunk", countersink_diameter=4.0),)),
     r"^features\[0\]\.countersink_diameter must be a finite number > diameter \(5\)"),
    (PanelSpec(50.0, 50.0, 3.0, features=(_one(kind="countersunk", countersink_diameter=20.0),)),
     r"^features\[0\]\.countersink_diameter must be small enough"),
    (PanelSpec(50.0, 50.0, 3.0, features=(_one(kind="countersunk", countersink_diameter=8.0,
                                               countersink_angle_deg=170.0),)),
     r"^features\[0\]\.countersink_angle_deg must be an angle"),
    (PanelSpec(50.0, 50.0, 3.0, features=(_one(kind="counterbored", counterbore_diameter=8.0),)),
     r"^features\[0\]\.counterbore_depth must be a number in \(0, thickness"),
    (PanelSpec(50.0, 50.0, 3.0, features=(_one(kind="slot"),)), r"^features\[0\]\.diameter must be omitted"),
    (PanelSpec(50.0, 50.0, 3.0, features=(_one(kind="boss", height=0.0),)),
     r"^features\[0\]\.height must be a finite number > 0, got 0\.0"),
    (PanelSpec(50.0, 50.0, 3.0, features=(_one(height=1.0),)), r"^features\[0\]\.height must be omitted"),
    (PanelSpec(50.0, 50.0, 3.0, features=(_one(kind="slot", diameter=None, width=5.0, length=4.0),)),
     r"^features\[0\]\.length must be a finite number > width \(5\)"),
    (PanelSpec(50.0, 50.0, 3.0, features=(_one(center=(23.0, 0.0)),)),
     r"^features\[0\]\.center must be at least 0\.5 mm from the border"),
    (PanelSpec(50.0, 50.0, 3.0, features=(_one(), _one(center=(5.2, 0.0)))),
     r"^features\[1\]\.center must be at least 0\.5 mm from features\[0\]'s contour \(the gap is 0\.2\)"),
    (PanelSpec(50.0, 50.0, 3.0, features=(_one(kind="slot", diameter=None, width=5.0, length=20.0),
                                          _one(center=(0.0, 5.3)))),
     r"^features\[1\]\.center must be at least 0\.5 mm from features\[0\]'s contour"),
])
def test_invalid_specs_are_refused_naming_the_field(spec, match):
    with pytest.raises(SpecError, match=match):
        build_panel(spec)


def test_a_floor_above_a_curved_edge_is_refused():
    # Convex: the surface falls away from the tangent plane, 0.4 mm at 20 mm across the bend, so a
    # 0.2 mm deep counterbore floor would stand above the top surface at its rim.
    feature = _one(kind="counterbored", diameter=4.0, counterbore_diameter=40.0, counterbore_depth=0.2)
    spec = PanelSpec(100.0, 100.0, 3.0, "convex", 500.0, features=(feature,))
    with pytest.raises(SpecError, match=r"^features\[0\]\.counterbore_depth must put the step"):
        build_panel(spec)


# --------------------------------------------------------------------------------------------------
# TOML

TOML = """
[panel]
width = 140
height = 90
thickness = 3.0
curvature = "convex"
radius = 500.0
segments = 256

[[feature]]
kind = "countersunk"
name = "A1"
center = [-25.0, -20.0]
diameter = 4.8
countersink_diameter = 9.0
countersink_angle_deg = 100

[[feature]]
kind = "slot"
center = [50.0, -20.0]
width = 6.0
length = 20.0
direction_deg = 30.0

[[feature]]
kind = "blind"
center = [25.0, -20.0]
diameter = 3.0
depth = 2.0

[[feature]]
kind = "boss"
center = [0.0, 0.0]
diameter = 6.0
height = 2.0
"""


def test_toml_round_trip():
    spec = parse_panel_toml(TOML)
    assert spec == PanelSpec(140.0, 90.0, 3.0, "convex", 500.0, segments=256, features=(
        FeatureSpec("countersunk", (-25.0, -20.0), 4.8, countersink_diameter=9.0, name="A1"),
        FeatureSpec("slot", (50.0, -20.0), width=6.0, length=20.0, direction_deg=30.0),
        FeatureSpec("blind", (25.0, -20.0), 3.0, depth=2.0),
        FeatureSpec("boss", (0.0, 0.0), 6.0, height=2.0)))
    truth = panel_truth(build_panel(spec))
    assert [f["name"] for f in truth["features"]] == ["A1", "slot1", "blind2", "boss3"]


def test_toml_flat_defaults():
    spec = parse_panel_toml("[panel]\nwidth = 50\nheight = 40\nthickness = 2\n")
    assert spec == PanelSpec(50.0, 40.0, 2.0)
    assert isinstance(spec.width, float)


@pytest.mark.parametrize("text, match", [
    ("[panel\n", r"^invalid TOML"),
    ("[hole]\nx = 1\n", r"^unknown top-level key 'hole'"),
    ("[[feature]]\nkind = 'through'\n", r"^expected a \[panel\] table"),
    ("[panel]\nwidth = 50\nheight = 40\n", r"^panel: missing key 'thickness'"),
    ("[panel]\nwidth = 50\nheight = 40\nthickness = 2\ncolour = 'red'\n", r"^panel: unknown key 'colour'"),
    ("[panel]\nwidth = '50'\nheight = 40\nthickness = 2\n", r"^panel\.width must be a number, got '50'"),
    ("[panel]\nwidth = true\nheight = 40\nthickness = 2\n", r"^panel\.width must be a number, got True"),
    ("[panel]\nwidth = 50\nheight = 40\nthickness = 2\ncurvature = 'convex'\n",
     r"^panel: missing key 'radius' \(needed by curvature = 'convex'\)"),
    ("[panel]\nwidth = 50\nheight = 40\nthickness = 2\ncurvature = 5\n",
     r"^panel\.curvature must be one of flat, convex, concave, got 5"),
    ("[panel]\nwidth = 50\nheight = 40\nthickness = 2\nsegments = 64.0\n", r"^panel\.segments must be an integer"),
    ("[panel]\nwidth = 50\nheight = 40\nthickness = 2\n[[feature]]\nkind = 'hex'\ncenter = [0, 0]\n",
     r"^feature\[0\]\.kind must be one of"),
    ("[panel]\nwidth = 50\nheight = 40\nthickness = 2\n[[feature]]\nkind = 'through'\ncenter = [0, 0]\n",
     r"^feature\[0\]: missing key 'diameter'"),
    ("[panel]\nwidth = 50\nheight = 40\nthickness = 2\n[[feature]]\nkind = 'through'\ncenter = [0, 0]\n"
     "diameter = 5\ndepth = 1\n", r"^feature\[0\]: unknown key 'depth' for a through feature"),
    ("[panel]\nwidth = 50\nheight = 40\nthickness = 2\n[[feature]]\nkind = 'through'\ncenter = [0]\n"
     "diameter = 5\n", r"^feature\[0\]\.center must be 2 finite numbers"),
    ("[panel]\nwidth = 50\nheight = 40\nthickness = 2\n[[feature]]\nkind = 'blind'\ncenter = [0, 0]\n"
     "diameter = 5\ndepth = 2.5\n", r"^feature\[0\]\.depth must be a number in \(0, thickness = 2\)"),
    ("[panel]\nwidth = 50\nheight = 40\nthickness = 2\n[[feature]]\nkind = 'through'\ncenter = [24, 0]\n"
     "diameter = 5\n", r"^feature\[0\]\.center must be at least 0\.5 mm from the border"),
])
def test_toml_refusals_name_the_key(text, match):
    with pytest.raises(SpecError, match=match):
        parse_panel_toml(text)
