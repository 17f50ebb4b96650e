"""Tests of holecli.simulation.panel: closed meshes of drilled panels and their truth."""

import json
import math

import numpy as np
import pytest
from scipy import integrate

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



def test_a_counterbore_step_through_a_concave_bottom_is_refused():
    # Concave: the bottom rises away from the axis, 0.76 mm at the step's 10 mm rim (R 60, 6 mm
    # thick), so a 5.5 mm deep step would pass through it there though it clears it at the bore.
    feature = _one(kind="counterbored", diameter=4.0, counterbore_diameter=20.0, counterbore_depth=5.5)
    spec = PanelSpec(40.0, 40.0, 6.0, "concave", 60.0, features=(feature,))
    with pytest.raises(SpecError, match=r"^features\[0\]\.counterbore_depth must put the step .* above the "
                                        r"bottom \(from 5\.238\)"):
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


# --------------------------------------------------------------------------------------------------
# Holes drilled off the normal

TILT, LEAN = 5.0, 30.0


def _tilted_features(tilt=TILT, lean=LEAN):
    return (
        FeatureSpec("through", (-30.0, 0.0), 5.0, tilt_deg=tilt, tilt_direction_deg=lean),
        FeatureSpec("countersunk", (-10.0, 0.0), 4.8, countersink_diameter=9.0, tilt_deg=tilt,
                    tilt_direction_deg=lean),
        FeatureSpec("counterbored", (10.0, 0.0), 4.0, counterbore_diameter=8.0, counterbore_depth=1.5,
                    tilt_deg=tilt, tilt_direction_deg=lean),
        FeatureSpec("blind", (30.0, 0.0), 3.0, depth=2.0, tilt_deg=tilt, tilt_direction_deg=lean),
    )


TILTED_SPECS = {
    "flat": PanelSpec(80.0, 30.0, THICKNESS, features=_tilted_features()),
    "convex": PanelSpec(80.0, 30.0, THICKNESS, "convex", 500.0, features=_tilted_features()),
}
_TILTED = {}


@pytest.fixture(params=sorted(TILTED_SPECS))
def tilted(request):
    if request.param not in _TILTED:
        _TILTED[request.param] = build_panel(TILTED_SPECS[request.param])
    return _TILTED[request.param]


def _expected_axis(spec, f):
    """The tilted axis from the sheet's frame at the centre, written out for the test."""
    u = f.center[0]
    if spec.curvature == "flat":
        eu, ev, n = np.array([1.0, 0, 0]), np.array([0, 1.0, 0]), np.array([0, 0, 1.0])
    else:
        phi = u / spec.radius
        sign = 1.0 if spec.curvature == "convex" else -1.0
        eu = np.array([math.cos(phi), 0.0, -sign * math.sin(phi)])
        ev = np.array([0.0, 1.0, 0.0])
        n = np.array([sign * math.sin(phi), 0.0, math.cos(phi)])
    t, lean = math.radians(f.tilt_deg), math.radians(f.tilt_direction_deg)
    return math.cos(t) * n + math.sin(t) * (math.cos(lean) * eu + math.sin(lean) * ev), n


def test_untilted_keys_give_the_identical_mesh():
    plain = PanelSpec(80.0, 30.0, THICKNESS, "convex", 500.0, features=_tilted_features(tilt=0.0, lean=0.0))
    keyed = PanelSpec(80.0, 30.0, THICKNESS, "convex", 500.0, features=_tilted_features(tilt=0.0, lean=75.0))
    a, b = build_panel(plain), build_panel(keyed)
    assert np.array_equal(a.vertices, b.vertices) and np.array_equal(a.triangles, b.triangles)
    assert np.array_equal(a.parts, b.parts) and np.array_equal(a.triangle_feature, b.triangle_feature)
    for ta, tb in zip(a.features, b.features):
        assert tb["tilt_direction_deg"] == 75.0
        assert dict(ta, tilt_direction_deg=75.0) == tb
        assert ta["axis"] == ta["normal"] and ta["perpendicularity_deg"] == 0.0 and ta["tilt_deg"] == 0.0


def test_tilted_meshes_are_closed_and_consistently_oriented(tilted):
    assert _is_closed(tilted)
    p = tilted.vertices[tilted.triangles]
    area = np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1) / 2
    assert area.min() > 0
    volume = np.einsum("ij,ij->i", p[:, 0], np.cross(p[:, 1], p[:, 2])).sum() / 6
    assert volume > 0.9 * 80 * 30 * THICKNESS


def test_tilted_walls_are_exact_about_the_tilted_axis(tilted):
    spec = tilted.spec
    for k, f in enumerate(spec.features):
        center, axis = _axis_frame(tilted, k)
        expected_axis, _ = _expected_axis(spec, f)
        np.testing.assert_allclose(axis, expected_axis, atol=1e-15)
        radial, axial = _radial_axial(_part_vertices(tilted, WALL, k), center, axis)
        r = f.diameter / 2
        if f.kind in ("through", "blind"):
            np.testing.assert_allclose(radial, r, atol=1e-9)
        elif f.kind == "counterbored":
            rb, h = f.counterbore_diameter / 2, f.counterbore_depth
            on_bore, on_counterbore = np.abs(radial - r) < 1e-9, np.abs(radial - rb) < 1e-9
            assert (on_bore | on_counterbore).all()
            # The counterbore's wall ends at the step, the bore's starts there.
            assert axial[on_counterbore].min() == pytest.approx(-h, abs=1e-12)
            assert axial[on_bore].max() == pytest.approx(-h, abs=1e-12)
        else:
            half = math.radians(f.countersink_angle_deg) / 2
            h = tilted.features[k]["countersink_depth"]
            assert h == pytest.approx((f.countersink_diameter - f.diameter) / 2 / math.tan(half), abs=1e-15)
            cone = axial > -h + 1e-9
            # Cone: radius r at the lower edge (depth h along the axis), growing by tan(half) upward.
            np.testing.assert_allclose(radial[cone], r + (axial[cone] + h) * math.tan(half), atol=1e-9)
            np.testing.assert_allclose(radial[~cone], r, atol=1e-9)
            # The cone's diameter in the plane through the centre perpendicular to the axis.
            assert r + h * math.tan(half) == pytest.approx(f.countersink_diameter / 2, abs=1e-12)


def test_tilted_levels_are_perpendicular_to_the_axis_at_their_depths(tilted):
    for k, f in enumerate(tilted.spec.features):
        if f.kind not in ("blind", "counterbored", "countersunk"):
            continue
        center, axis = _axis_frame(tilted, k)
        if f.kind == "countersunk":
            # The cone's lower edge: the WALL vertices that are neither on the top nor the bottom.
            loop = tilted.edge_loops[k]
            walls = _part_vertices(tilted, WALL, k)
            radial, axial = _radial_axial(walls, center, axis)
            h = tilted.features[k]["countersink_depth"]
            edge = (np.abs(radial - f.diameter / 2) < 1e-9) & (axial > -(h + THICKNESS) / 2)
            assert edge.sum() == len(loop)
            np.testing.assert_allclose(axial[edge], -h, atol=1e-12)
            continue
        radial, axial = _radial_axial(_part_vertices(tilted, FLOOR, k), center, axis)
        depth = f.depth if f.kind == "blind" else f.counterbore_depth
        np.testing.assert_allclose(axial, -depth, atol=1e-12)
        outer = f.diameter / 2 if f.kind == "blind" else f.counterbore_diameter / 2
        assert radial.max() == pytest.approx(outer, abs=1e-12)
        key = "floor_depth" if f.kind == "blind" else "counterbore_depth"
        assert tilted.features[k][key] == depth


def test_tilted_edges_and_bottoms_lie_on_the_surfaces(tilted):
    spec = tilted.spec
    for k, f in enumerate(spec.features):
        edge = tilted.vertices[tilted.edge_loops[k]]
        if spec.curvature == "flat":
            np.testing.assert_allclose(edge[:, 2], 0.0, atol=1e-12)
        else:
            np.testing.assert_allclose(_distance_from_bend_axis(tilted, edge), spec.radius, atol=1e-9)
    bottom = tilted.vertices[np.unique(tilted.triangles[tilted.parts == BOTTOM])]
    if spec.curvature == "flat":
        np.testing.assert_allclose(bottom[:, 2], -THICKNESS, atol=1e-12)
    else:
        np.testing.assert_allclose(_distance_from_bend_axis(tilted, bottom), spec.radius - THICKNESS, atol=1e-9)


def test_tilted_truth_axis_normal_and_perpendicularity(tilted):
    truth = json.loads(json.dumps(panel_truth(tilted)))
    for f, hole in zip(tilted.spec.features, truth["holes"]):
        axis, normal = _expected_axis(tilted.spec, f)
        np.testing.assert_allclose(hole["axis"], axis, atol=1e-15)
        np.testing.assert_allclose(hole["normal"], normal, atol=1e-15)
        assert hole["perpendicularity_deg"] == pytest.approx(TILT, abs=1e-12)
        assert math.degrees(math.acos(np.dot(hole["axis"], hole["normal"]))) == pytest.approx(TILT, abs=1e-6)
        assert hole["tilt_deg"] == TILT and hole["tilt_direction_deg"] == LEAN
        assert hole["bore_diameter"] == f.diameter
        assert hole["edge_diameter_min"] <= hole["diameter"] <= hole["edge_diameter_max"]
        assert 2 * hole["polygon_inradius"] <= hole["edge_diameter_min"] + 1e-12


def _chord_mean(radius_in_direction):
    """Mean over directions psi in [0, pi) of the chord through the centre, rho(psi) + rho(psi + pi)."""
    value, _ = integrate.quad(lambda psi: radius_in_direction(psi) + radius_in_direction(psi + math.pi),
                              0.0, math.pi, epsabs=1e-13, epsrel=1e-13, limit=200)
    return value / math.pi


@pytest.mark.parametrize("tilt", [5.0, 25.0])
def test_tilted_bore_edge_is_an_ellipse_scored_by_its_chord_mean(tilt):
    feature = FeatureSpec("through", (0.0, 0.0), 5.0, tilt_deg=tilt, tilt_direction_deg=45.0)
    truth = build_panel(PanelSpec(30.0, 30.0, THICKNESS, features=(feature,))).features[0]
    # The bore meets the flat top in an ellipse about the centre: semi-axes r across the lean and
    # r / cos(t) along it.
    r = 2.5
    a, b = r / math.cos(math.radians(tilt)), r

    def ellipse(psi):
        return 1.0 / math.hypot(math.cos(psi) / a, math.sin(psi) / b)

    expected = _chord_mean(ellipse)
    assert 2 * b < expected < 2 * a
    assert truth["diameter"] == pytest.approx(expected, abs=1e-12)
    # Directions every 2 pi / 4096 hit both axes of an ellipse leaning at 45 degrees.
    assert truth["edge_diameter_min"] == pytest.approx(2 * b, abs=1e-12)
    assert truth["edge_diameter_max"] == pytest.approx(2 * a, abs=1e-12)
    np.testing.assert_allclose(truth["edge_axial_offset"], 0.0, atol=1e-12)
    assert truth["nominal_diameter"] == 5.0 and truth["perpendicularity_deg"] == pytest.approx(tilt, abs=1e-12)


def test_tilted_countersink_edge_is_the_cone_cut_by_the_surface():
    f = FeatureSpec("countersunk", (0.0, 0.0), 4.8, countersink_diameter=9.0, countersink_angle_deg=90.0,
                    tilt_deg=10.0, tilt_direction_deg=-60.0)
    truth = build_panel(PanelSpec(30.0, 30.0, THICKNESS, features=(f,))).features[0]
    axis = np.asarray(truth["axis"])
    rc, slope = f.countersink_diameter / 2, math.tan(math.radians(f.countersink_angle_deg) / 2)

    def cone(psi):
        # A point rho w of the top plane (w a unit direction in it) is on the cone where its distance
        # from the axis is rc + slope times its offset along the axis.
        along = math.cos(psi) * axis[0] + math.sin(psi) * axis[1]
        return rc / (math.sqrt(1.0 - along * along) - along * slope)

    assert truth["diameter"] == pytest.approx(_chord_mean(cone), abs=1e-12)
    assert truth["countersink_diameter"] == 9.0 and truth["countersink_angle_deg"] == 90.0


def test_tilted_flat_volume_is_the_sheet_minus_the_oblique_bores():
    features = (
        FeatureSpec("through", (-20.0, 0.0), 5.0, tilt_deg=12.0, tilt_direction_deg=200.0),
        FeatureSpec("counterbored", (0.0, 0.0), 4.0, counterbore_diameter=7.0, counterbore_depth=1.2,
                    tilt_deg=8.0, tilt_direction_deg=90.0),
        FeatureSpec("blind", (20.0, 0.0), 3.0, depth=2.0, tilt_deg=20.0, tilt_direction_deg=-10.0),
    )
    panel = build_panel(PanelSpec(60.0, 20.0, THICKNESS, features=features))
    p = panel.vertices[panel.triangles]
    volume = np.einsum("ij,ij->i", p[:, 0], np.cross(p[:, 1], p[:, 2])).sum() / 6
    removed = 0.0
    for f, truth in zip(features, panel.features):
        n = truth["segments"]
        # A prism about the axis cut by planes holds its cross-section's area times the length of
        # its axis between them; the flat bottom is t / cos(tilt) along the axis from the centre.
        length_to_bottom = THICKNESS / math.cos(math.radians(f.tilt_deg))
        r = f.diameter / 2
        if f.kind == "through":
            round_volume = math.pi * r * r * length_to_bottom
        elif f.kind == "blind":
            round_volume = math.pi * r * r * f.depth
        else:
            rb, h = f.counterbore_diameter / 2, f.counterbore_depth
            round_volume = math.pi * (rb * rb * h + r * r * (length_to_bottom - h))
        removed += n * math.sin(2 * math.pi / n) / (2 * math.pi) * round_volume
    assert volume == pytest.approx(60.0 * 20.0 * THICKNESS - removed, rel=1e-11)
    assert _is_closed(panel)


@pytest.mark.parametrize("curvature, radius", [("flat", None), ("concave", 500.0)])
def test_steep_tilts_still_give_closed_meshes(curvature, radius):
    features = (
        FeatureSpec("through", (-15.0, 0.0), 5.0, tilt_deg=29.0, tilt_direction_deg=0.0),
        FeatureSpec("countersunk", (0.0, 0.0), 4.0, countersink_diameter=7.0, countersink_angle_deg=82.0,
                    tilt_deg=29.0, tilt_direction_deg=180.0),
        FeatureSpec("blind", (15.0, 0.0), 4.0, depth=1.5, tilt_deg=20.0, tilt_direction_deg=90.0),
    )
    panel = build_panel(PanelSpec(50.0, 20.0, THICKNESS, curvature, radius, features=features))
    assert _is_closed(panel)
    center, axis = _axis_frame(panel, 0)
    radial, _ = _radial_axial(_part_vertices(panel, WALL, 0), center, axis)
    np.testing.assert_allclose(radial, 2.5, atol=1e-9)


@pytest.mark.parametrize("feature, match", [
    (_one(tilt_deg=-1.0), r"^features\[0\]\.tilt_deg must be an angle in degrees from 0 to less than 30"),
    (_one(tilt_deg=30.0), r"^features\[0\]\.tilt_deg must be an angle .* got 30\.0"),
    (_one(tilt_deg=float("nan")), r"^features\[0\]\.tilt_deg must be an angle"),
    (_one(tilt_deg="5"), r"^features\[0\]\.tilt_deg must be an angle .* got '5'"),
    (_one(tilt_deg=5.0, tilt_direction_deg=float("inf")),
     r"^features\[0\]\.tilt_direction_deg must be a finite angle in degrees, got inf"),
    (_one(kind="slot", diameter=None, width=4.0, length=10.0, tilt_deg=5.0),
     r"^features\[0\]\.tilt_deg must be omitted for a slot feature, got 5\.0"),
    (_one(kind="slot", diameter=None, width=4.0, length=10.0, tilt_direction_deg=10.0),
     r"^features\[0\]\.tilt_direction_deg must be omitted for a slot feature"),
    (_one(kind="boss", height=1.0, tilt_deg=2.0), r"^features\[0\]\.tilt_deg must be omitted for a boss feature"),
    (_one(kind="countersunk", countersink_diameter=8.0, countersink_angle_deg=150.0, tilt_deg=15.0),
     r"^features\[0\]\.tilt_deg must be at most 10 for a 150 degree countersink"),
    (_one(kind="counterbored", diameter=4.0, counterbore_diameter=8.0, counterbore_depth=1.5, tilt_deg=25.0),
     r"^features\[0\]\.counterbore_depth must put the step or floor \(at depth 1\.5 along the axis\)"),
])
def test_invalid_tilts_are_refused_naming_the_field(feature, match):
    with pytest.raises(SpecError, match=match):
        build_panel(PanelSpec(50.0, 50.0, THICKNESS, features=(feature,)))


def test_a_tilted_bore_crowding_its_neighbour_on_the_bottom_is_refused():
    # 1 mm apart on top. The first axis leans 25 degrees away from the second (toward -u), so going
    # down the bore runs toward it and comes 1.4 mm nearer at the bottom, where its ellipse is also
    # 10 % longer; leaning the other way it is fine.
    lean = _one(tilt_deg=25.0, tilt_direction_deg=180.0)
    neighbour = _one(center=(6.0, 0.0))
    assert _is_closed(build_panel(PanelSpec(50.0, 50.0, THICKNESS, features=(_one(tilt_deg=25.0), neighbour))))
    with pytest.raises(SpecError, match=r"^features\[1\]\.center must be at least 0\.5 mm from features\[0\]'s "
                                        r"contour on the bottom face \(the gap is -"):
        build_panel(PanelSpec(50.0, 50.0, THICKNESS, features=(lean, neighbour)))


TILTED_TOML = """
[panel]
width = 60
height = 40
thickness = 3.0

[[feature]]
kind = "through"
center = [-10.0, 0.0]
diameter = 5
tilt_deg = 5
tilt_direction_deg = 30

[[feature]]
kind = "countersunk"
center = [10.0, 0.0]
diameter = 4.8
countersink_diameter = 9.0
tilt_deg = 2.5
"""


def test_toml_tilt_keys():
    spec = parse_panel_toml(TILTED_TOML)
    assert spec.features == (
        FeatureSpec("through", (-10.0, 0.0), 5.0, tilt_deg=5.0, tilt_direction_deg=30.0),
        FeatureSpec("countersunk", (10.0, 0.0), 4.8, countersink_diameter=9.0, tilt_deg=2.5))
    assert isinstance(spec.features[0].tilt_deg, float)
    truth = panel_truth(build_panel(spec))
    assert [h["perpendicularity_deg"] for h in truth["holes"]] == pytest.approx([5.0, 2.5], abs=1e-12)
    assert [h["tilt_direction_deg"] for h in truth["holes"]] == [30.0, 0.0]


@pytest.mark.parametrize("feature, match", [
    ("kind = 'slot'\ncenter = [0, 0]\nwidth = 4\nlength = 10\ntilt_deg = 5\n",
     r"^feature\[0\]: unknown key 'tilt_deg' for a slot feature"),
    ("kind = 'boss'\ncenter = [0, 0]\ndiameter = 4\nheight = 1\ntilt_direction_deg = 5\n",
     r"^feature\[0\]: unknown key 'tilt_direction_deg' for a boss feature"),
    ("kind = 'through'\ncenter = [0, 0]\ndiameter = 4\ntilt_deg = '5'\n",
     r"^feature\[0\]\.tilt_deg must be a number, got '5'"),
    ("kind = 'blind'\ncenter = [0, 0]\ndiameter = 4\ndepth = 1\ntilt_deg = 45\n",
     r"^feature\[0\]\.tilt_deg must be an angle in degrees from 0 to less than 30"),
])
def test_toml_tilt_refusals(feature, match):
    with pytest.raises(SpecError, match=match):
        parse_panel_toml("[panel]\nwidth = 50\nheight = 40\nthickness = 3\n[[feature]]\n" + feature)


def _panel_text_in(factor, units):
    """The sample panel (mm) with every length times ``factor`` and ``units`` declared at its top."""
    import re
    from pathlib import Path

    text = (Path(__file__).resolve().parents[2] / "sample_clouds" / "panel.toml").read_text()

    def scaled(match):
        key, value = match.group(1), match.group(2)
        if key.endswith("_deg") or key == "segments":
            return match.group(0)
        numbers = [float(v) * factor for v in re.findall(r"-?[\d.]+", value)]
        shown = f"[{', '.join(repr(n) for n in numbers)}]" if value.startswith("[") else repr(numbers[0])
        return f"{key} = {shown}"

    return f'units = "{units}"\n' + re.sub(r"^(\w+) = (\[[^\]]*\]|-?[\d.]+)$", scaled, text, flags=re.M)


@pytest.mark.parametrize("units, factor", [("in", 1 / 25.4), ("m", 1e-3), ("mm", 1.0)])
def test_a_panel_file_declares_its_unit(units, factor):
    """Issue 25: ``units`` at the top of a panel file; its lengths are converted into mm (angles not)."""
    from pathlib import Path

    reference = parse_panel_toml((Path(__file__).resolve().parents[2] / "sample_clouds" / "panel.toml").read_text())
    declared = parse_panel_toml(_panel_text_in(factor, units))
    assert declared.width == pytest.approx(reference.width) and declared.thickness == pytest.approx(reference.thickness)
    for got, want in zip(declared.features, reference.features, strict=True):
        assert got.center == pytest.approx(want.center) and got.diameter == pytest.approx(want.diameter)
        assert got.countersink_angle_deg == want.countersink_angle_deg


def test_a_panel_file_refuses_an_unknown_unit():
    with pytest.raises(SpecError, match=r"units must be one of 'mm', 'm', 'in'.*panel.*got 'cm'"):
        parse_panel_toml('units = "cm"\n[panel]\nwidth = 6\nheight = 4\nthickness = 0.3\n')
