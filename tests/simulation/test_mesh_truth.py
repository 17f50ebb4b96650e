"""Tests of holecli.simulation.mesh_truth: hole truth from CAD triangle meshes built here with numpy."""

import json
import math

import numpy as np
import pytest
from scipy.spatial import Delaunay
from scipy.spatial.transform import Rotation

from holecli.simulation import panel
from holecli.simulation.mesh_truth import MeshError, mesh_holes, mesh_truth

W, H, T = 60.0, 40.0, 5.0   # plate extent (mm): x in [-W/2, W/2], y in [-H/2, H/2], z in [-T, 0]
N = 96                      # segments per hole polygon


def _rings(kind, **p):
    """Loops (radius, z) from the top surface down, and whether a floor closes the hole."""
    if kind == "through":
        return [(p["r"], 0.0), (p["r"], -T)], False
    if kind == "countersunk":
        R, r, angle = p["R"], p["r"], p["angle"]
        depth = (R - r) / math.tan(math.radians(angle / 2))
        return [(R, 0.0), (r, -depth), (r, -T)], False
    if kind == "counterbored":
        return [(p["R"], 0.0), (p["R"], -p["dc"]), (p["r"], -p["dc"]), (p["r"], -T)], False
    if kind == "blind":
        return [(p["r"], 0.0), (p["r"], -p["d"])], True
    raise ValueError(kind)


def _strip(a, b):
    a1, b1 = np.roll(a, -1), np.roll(b, -1)
    return np.concatenate([np.stack([a, a1, b], 1), np.stack([a1, b1, b], 1)])


def _face(points2d, ids, inside):
    """Delaunay of a face's points, dropping triangles whose centroid is inside a feature."""
    tri = Delaunay(points2d).simplices
    centroid = points2d[tri].mean(axis=1)
    return ids[tri[~inside(centroid)]]


def plate(features, slot=None):
    """A closed plate mesh with the given features: list of (kind, (x, y), params).

    ``slot``: ((x, y), length, width) of a rounded slot through the plate along x.
    """
    verts, tris = [], []
    count = [0]

    def add(p):
        p = np.asarray(p, dtype=np.float64).reshape(-1, 3)
        verts.append(p)
        count[0] += len(p)
        return np.arange(count[0] - len(p), count[0])

    # Rectangle border with a few points per side, counter-clockwise.
    s = np.linspace(0, 1, 5)[:-1]
    border = np.concatenate([
        np.stack([-W / 2 + W * s, np.full_like(s, -H / 2)], 1),
        np.stack([np.full_like(s, W / 2), -H / 2 + H * s], 1),
        np.stack([W / 2 - W * s, np.full_like(s, H / 2)], 1),
        np.stack([np.full_like(s, -W / 2), H / 2 - H * s], 1)])
    top_b = add(np.column_stack([border, np.zeros(len(border))]))
    bot_b = add(np.column_stack([border, np.full(len(border), -T)]))
    tris.append(_strip(top_b, bot_b))

    phi = 2 * np.pi * np.arange(N) / N
    top_pts, top_ids = [border], [top_b]
    bot_pts, bot_ids = [border], [bot_b]
    discs = []  # (center, radius) of each top and bottom opening, for dropping triangles
    for kind, (x, y), params in features:
        rings, floor = _rings(kind, **params)
        ids = [add(np.column_stack([x + r * np.cos(phi), y + r * np.sin(phi), np.full(N, z)]))
               for r, z in rings]
        for a, b in zip(ids, ids[1:]):
            tris.append(_strip(a, b))
        top_pts.append(np.column_stack([x + rings[0][0] * np.cos(phi), y + rings[0][0] * np.sin(phi)]))
        top_ids.append(ids[0])
        discs.append((np.array([x, y]), rings[0][0], "top"))
        if floor:
            # A drill point: the floor is a cone of included angle tip_angle down to its tip.
            tip = 0.0
            if "tip_angle" in params:
                tip = rings[-1][0] / math.tan(math.radians(params["tip_angle"] / 2))
            c = add([x, y, rings[-1][1] - tip])[0]
            last = ids[-1]
            tris.append(np.stack([np.full(N, c), last, np.roll(last, -1)], 1))
        else:
            bot_pts.append(np.column_stack([x + rings[-1][0] * np.cos(phi),
                                            y + rings[-1][0] * np.sin(phi)]))
            bot_ids.append(ids[-1])
            discs.append((np.array([x, y]), rings[-1][0], "bottom"))
    if slot is not None:
        (x, y), length, width = slot
        r, half = width / 2, (length - width) / 2
        arc = np.linspace(-np.pi / 2, np.pi / 2, 25)
        side = np.linspace(half, -half, 12)[1:-1]
        outline = np.concatenate([
            np.column_stack([half + r * np.cos(arc), r * np.sin(arc)]),          # right end
            np.column_stack([side, np.full_like(side, r)]),                       # top side
            np.column_stack([-half + r * np.cos(arc + np.pi), r * np.sin(arc + np.pi)]),  # left end
            np.column_stack([-side, np.full_like(side, -r)])]) + [x, y]           # bottom side
        a = add(np.column_stack([outline, np.zeros(len(outline))]))
        b = add(np.column_stack([outline, np.full(len(outline), -T)]))
        tris.append(_strip(a, b))
        top_pts.append(outline), top_ids.append(a)
        bot_pts.append(outline), bot_ids.append(b)

    def inside(c, where):
        hit = np.zeros(len(c), bool)
        for centre, radius, w in discs:
            if w == where:
                hit |= np.linalg.norm(c - centre, axis=1) < radius
        if slot is not None:
            (x, y), length, width = slot
            half = (length - width) / 2
            u = np.clip(c[:, 0] - x, -half, half)
            hit |= np.hypot(c[:, 0] - x - u, c[:, 1] - y) < width / 2
        return hit

    tris.append(_face(np.concatenate(top_pts), np.concatenate(top_ids), lambda c: inside(c, "top")))
    tris.append(_face(np.concatenate(bot_pts), np.concatenate(bot_ids), lambda c: inside(c, "bottom")))
    return np.concatenate(verts), np.concatenate(tris).astype(np.int64)


THROUGH = ("through", (-18.0, -8.0), dict(r=3.0))
COUNTERSUNK = ("countersunk", (-4.0, -8.0), dict(R=4.0, r=2.0, angle=90.0))
COUNTERBORED = ("counterbored", (10.0, -8.0), dict(R=4.0, dc=2.0, r=2.5))
BLIND = ("blind", (22.0, -8.0), dict(r=2.5, d=3.0))


def expected(feature):
    kind, (x, y), p = feature
    out = {"kind": kind, "center": [x, y, 0.0], "axis": [0.0, 0.0, 1.0], "normal": [0.0, 0.0, 1.0]}
    r_top = {"through": "r", "countersunk": "R", "counterbored": "R", "blind": "r"}[kind]
    out["edge_diameter"] = 2 * p[r_top]
    out["edge_circumdiameter"] = 2 * p[r_top]
    out["edge_indiameter"] = 2 * p[r_top] * math.cos(math.pi / N)
    out["bore_diameter"] = 2 * p["r"]
    out["through"] = kind != "blind"
    out["depth"] = p.get("d", T)
    if kind == "countersunk":
        out["countersink_angle_deg"] = p["angle"]
        out["countersink_depth"] = (p["R"] - p["r"]) / math.tan(math.radians(p["angle"] / 2))
    if kind == "counterbored":
        out["counterbore_diameter"] = 2 * p["R"]
        out["counterbore_depth"] = p["dc"]
    if kind == "blind":
        out["floor_depth"] = p["d"]
    return out


def check(found, feature, rel, absolute):
    want = expected(feature)
    got = found.to_dict()
    assert got["kind"] == want.pop("kind")
    assert got["is_hole"] is True
    assert got["through"] is want.pop("through")
    for key, value in want.items():
        assert got[key] == pytest.approx(value, rel=rel, abs=absolute), key
    return got


@pytest.mark.parametrize("feature", [THROUGH, COUNTERSUNK, COUNTERBORED, BLIND],
                         ids=lambda f: f[0])
@pytest.mark.parametrize("dtype,rel,absolute", [(np.float64, 1e-9, 1e-9), (np.float32, 1e-5, 1e-5)],
                         ids=["float64", "float32"])
def test_single_hole_known_answer(feature, dtype, rel, absolute):
    v, t = plate([feature])
    holes = mesh_holes(v.astype(dtype), t)
    assert len(holes) == 1
    got = check(holes[0], feature, rel, absolute)
    assert got["segments"] == N
    assert got["view_cosine"] == pytest.approx(1.0)
    if feature[0] != "countersunk":
        assert got["countersink_angle_deg"] is None
    if feature[0] != "blind":
        assert got["floor_depth"] is None


def test_all_kinds_on_one_plate_and_a_slot():
    features = [THROUGH, COUNTERSUNK, COUNTERBORED, BLIND]
    v, t = plate(features, slot=((0.0, 10.0), 14.0, 4.0))
    holes = mesh_holes(v, t)
    assert [h.kind for h in holes] == ["through", "countersunk", "counterbored", "blind", "slot"]
    for h, f in zip(holes, features):
        check(h, f, 1e-9, 1e-9)
    slot = holes[-1]
    assert slot.is_hole is False
    assert slot.length == pytest.approx(14.0, rel=1e-9)
    assert slot.width == pytest.approx(4.0, rel=1e-9)
    assert slot.center == pytest.approx([0.0, 10.0, 0.0], abs=1e-9)
    assert abs(slot.direction[0]) == pytest.approx(1.0, rel=1e-9)


def test_stl_triangle_soup_and_mixed_winding_give_the_same_holes():
    v, t = plate([COUNTERSUNK, BLIND])
    soup = v[t].reshape(-1, 3).astype(np.float32)  # STL: every triangle's corners stored apart
    tri = np.arange(len(soup)).reshape(-1, 3)
    rng = np.random.default_rng(3)
    flip = rng.random(len(tri)) < 0.5
    tri[flip] = tri[flip][:, ::-1]
    holes = mesh_holes(soup, tri)
    assert [h.kind for h in holes] == ["countersunk", "blind"]
    check(holes[0], COUNTERSUNK, 1e-5, 1e-5)
    check(holes[1], BLIND, 1e-5, 1e-5)


def test_rigid_transform_invariance():
    rng = np.random.default_rng(11)
    features = [THROUGH, COUNTERSUNK, COUNTERBORED, BLIND]
    v, t = plate(features)
    R = Rotation.random(random_state=rng).as_matrix()
    shift = rng.uniform(-500, 500, 3)
    holes = mesh_holes(v @ R.T + shift, t, view=R @ [0.0, 0.0, -1.0])
    assert sorted(h.kind for h in holes) == sorted(f[0] for f in features)
    for f in features:
        want = expected(f)
        centre = R @ want["center"] + shift
        h = min(holes, key=lambda h: np.linalg.norm(h.center - centre))
        assert h.kind == f[0]
        assert h.center == pytest.approx(centre, abs=1e-9)
        assert h.axis == pytest.approx(R @ [0.0, 0.0, 1.0], abs=1e-9)
        assert h.edge_diameter == pytest.approx(want["edge_diameter"], rel=1e-9)
        assert h.bore_diameter == pytest.approx(want["bore_diameter"], rel=1e-9)


def test_seen_from_below():
    v, t = plate([COUNTERSUNK, COUNTERBORED, BLIND])
    holes = mesh_holes(v, t, view=(0.0, 0.0, 1.0))
    # The blind hole does not reach the bottom; the others are plain bores from that side.
    assert [h.kind for h in holes] == ["through", "through"]
    for h in holes:
        assert h.center[2] == pytest.approx(-T)
        assert h.axis == pytest.approx([0.0, 0.0, -1.0])
        assert h.normal == pytest.approx([0.0, 0.0, -1.0])
    assert holes[0].edge_diameter == pytest.approx(4.0, rel=1e-9)
    assert holes[1].edge_diameter == pytest.approx(5.0, rel=1e-9)


def test_truth_is_json_ready_and_region_box_and_callable():
    v, t = plate([THROUGH, COUNTERSUNK, BLIND])
    box = (-W, 0.5, -H, H, -10.0, 10.0)   # x <= 0.5: the through hole and the countersink (x -4, R 4)
    truth = mesh_truth(v, t, (0, 0, -2), region=box)
    text = json.dumps(truth, allow_nan=False)
    again = json.loads(text)
    assert again["view"] == [0.0, 0.0, -1.0]
    assert [h["kind"] for h in again["holes"]] == ["through", "countersunk", "blind"]
    assert [h["inside_region"] for h in again["holes"]] == [True, True, False]
    truth = mesh_truth(v, t, region=lambda p: p[:, 0] < -1.0)
    assert [h["inside_region"] for h in truth["holes"]] == [True, False, False]
    assert "inside_region" not in mesh_truth(v, t)["holes"][0]


def test_coarse_polygons_and_boxes_are_not_holes():
    # A 12-gon through hole: its vertices lie on a circle but it is a polygon, not a drilled hole.
    global N
    saved, N = N, 12
    try:
        v, t = plate([THROUGH])
    finally:
        N = saved
    assert mesh_holes(v, t) == ()


@pytest.mark.parametrize("kwargs,match", [
    (dict(vertices=np.zeros((4, 2))), "vertices must be an \\(n, 3\\) array"),
    (dict(vertices=np.full((4, 3), np.nan)), "vertices must be finite"),
    (dict(triangles=np.zeros((2, 3))), "triangles must be integer"),
    (dict(triangles=np.array([[0, 1, 9]])), "triangles must index vertices in \\[0, 4\\)"),
    (dict(triangles=np.zeros((0, 3), int)), "triangles must be an \\(m, 3\\) array"),
    (dict(view=(0, 0, 0)), "view must be a finite non-zero 3-vector"),
    (dict(angle_deg=95.0), "angle_deg must be a number in \\(0, 90\\)"),
    (dict(angle_deg="20"), "angle_deg must be a number"),
])
def test_validation(kwargs, match):
    args = dict(vertices=np.eye(4, 3), triangles=np.array([[0, 1, 2]]), view=(0, 0, -1), angle_deg=20.0)
    args.update(kwargs)
    with pytest.raises(MeshError, match=match):
        mesh_holes(args["vertices"], args["triangles"], args["view"], angle_deg=args["angle_deg"])


def test_region_validation():
    v, t = plate([THROUGH])
    with pytest.raises(MeshError, match="region must be a callable or a box"):
        mesh_truth(v, t, region=(0, 1, 2))


def test_agrees_with_panel_truth():
    spec = panel.PanelSpec(width=80.0, height=50.0, thickness=4.0, segments=64, features=(
            panel.FeatureSpec(kind="through", center=(-25.0, 0.0), diameter=5.0),
            panel.FeatureSpec(kind="countersunk", center=(-8.0, 0.0), diameter=4.0,
                              countersink_diameter=8.0, countersink_angle_deg=100.0),
            panel.FeatureSpec(kind="counterbored", center=(8.0, 0.0), diameter=4.0,
                              counterbore_diameter=8.0, counterbore_depth=1.5),
            panel.FeatureSpec(kind="blind", center=(25.0, 0.0), diameter=5.0, depth=2.5)))
    built = panel.build_panel(spec)
    holes = mesh_holes(built.vertices, built.triangles)
    truth = sorted(built.features, key=lambda f: f["center"][0])
    assert [h.kind for h in holes] == [f["kind"] for f in truth]
    for h, f in zip(holes, truth):
        assert h.center == pytest.approx(f["center"], abs=1e-9)
        assert h.edge_diameter == pytest.approx(2 * f["polygon_circumradius"], rel=1e-9)
        assert h.edge_indiameter == pytest.approx(2 * f["polygon_inradius"], rel=1e-9)
        assert h.bore_diameter == pytest.approx(f["bore_diameter"], rel=1e-9)
        for key in ("countersink_angle_deg", "countersink_depth", "counterbore_diameter",
                    "counterbore_depth", "floor_depth"):
            if key in f and f[key] is not None:
                assert getattr(h, key) == pytest.approx(f[key], rel=1e-9), key


def test_blind_hole_with_a_drill_point_floor():
    drilled = ("blind", (0.0, 0.0), dict(r=2.5, d=3.0, tip_angle=118.0))
    v, t = plate([drilled])
    (hole,) = mesh_holes(v.astype(np.float32), t)
    got = check(hole, ("blind", (0.0, 0.0), dict(r=2.5, d=3.0)), 1e-5, 1e-5)
    assert got["floor_depth"] == pytest.approx(3.0, rel=1e-5)  # where the cylinder ends



@pytest.mark.parametrize("curvature", ["convex", "concave"])
def test_curved_panel_center_on_the_surface(curvature):
    # The edge of a hole in a cylindrical sheet is a saddle; its centre and the depths count from
    # where the axis meets the surface (a quadratic fit around the edge), as in the panel's truth.
    spec = panel.PanelSpec(width=60.0, height=30.0, thickness=4.0, curvature=curvature,
                               radius=300.0, segments=64, features=(
            panel.FeatureSpec(kind="through", center=(-15.0, 0.0), diameter=5.0),
            panel.FeatureSpec(kind="countersunk", center=(0.0, 0.0), diameter=4.0,
                              countersink_diameter=8.0, countersink_angle_deg=100.0),
            panel.FeatureSpec(kind="blind", center=(15.0, 0.0), diameter=5.0, depth=2.5)))
    built = panel.build_panel(spec)
    holes = mesh_holes(built.vertices, built.triangles)
    truth = sorted(built.features, key=lambda f: f["center"][0])
    assert [h.kind for h in holes] == [f["kind"] for f in truth]
    for h, f in zip(holes, truth):
        assert h.center == pytest.approx(f["center"], abs=2e-6)
        assert h.edge_axial_offset == pytest.approx(f["edge_axial_offset"], abs=2e-6)
        for key in ("countersink_depth", "floor_depth"):
            if f.get(key) is not None:
                assert getattr(h, key) == pytest.approx(f[key], abs=2e-6), key


def test_a_boss_is_not_a_hole():
    # A pin standing on the plate: its foot has the flat surface outside but a wall rising inside,
    # its top a disk inside and a wall falling outside; neither is a hole's edge.
    v, t = plate([("blind", (0.0, 0.0), dict(r=2.5, d=-3.0))])
    assert mesh_holes(v, t) == ()
    assert mesh_holes(v, t, view=(0.0, 0.0, 1.0)) == ()
