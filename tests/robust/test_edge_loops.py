"""The edge loops of a CAD export's vertices (holecli.robust.edge_loops): the diameter of the polygon's
sides, and every check that tells a hole's edge loop from the other loops of a face is needed: without
it, a slot, a boss, a part's round outline, a groove or a sampling near an edge is reported as a hole.
The classes of whole clouds are in test_cad_clouds.py (``vertices``)."""

import math

import numpy as np
import pytest

from holecli.pipeline import detect
from holecli.robust import edge_loops as E
from holecli.simulation.cad_cloud import cad_cloud, cad_truth
from holecli.simulation.panel import FeatureSpec as F
from holecli.simulation.panel import PanelSpec, build_panel

DOWN = (0.0, 0.0, -1.0)


def _ring(center, radius, count, z, phase=0.0):
    phi = phase + np.linspace(0.0, 2 * math.pi, count, endpoint=False)
    return np.column_stack([center[0] + radius * np.cos(phi), center[1] + radius * np.sin(phi), np.full(count, z)])


def _border(half, z, step=5.0):
    """A square face's outline as a CAD export gives it: corners and points along the sides."""
    t = np.arange(-half, half, step)
    sides = [np.column_stack([t, np.full_like(t, -half)]), np.column_stack([np.full_like(t, half), t]),
             np.column_stack([-t, np.full_like(t, half)]), np.column_stack([np.full_like(t, -half), -t])]
    xy = np.concatenate(sides)
    return np.column_stack([xy, np.full(len(xy), z)])


def _loops(points, **kw):
    """edge_loops on a cloud whose top face is z = 0 (the sensor above)."""
    points = np.asarray(points, float)
    return E.edge_loops(points[:, :2], points[:, 2], np.abs(points[:, 2]) < 1e-9, 1e-9, **kw)


def _without(monkeypatch, check):
    monkeypatch.setattr(E, "ACTIVE_CHECKS", tuple(c for c in E.ACTIVE_CHECKS if c != check))


@pytest.mark.parametrize("count", [8, 24, 64, 96])
def test_sides_diameter_of_a_regular_polygon(count):
    """N vertices on a circle of diameter D: the least-squares circle of the sides is
    D cos(pi/N) (a sqrt(1+a^2) + asinh a) / (2a), a = tan(pi/N) (cad_truth's edge_diameter)."""
    d = 5.0
    a = math.tan(math.pi / count)
    expected = d * math.cos(math.pi / count) * (a * math.sqrt(1 + a * a) + math.asinh(a)) / (2 * a)
    ring = _ring((1.0, -2.0), d / 2, count, 0.0)[:, :2]
    assert E.sides_diameter(ring, np.array([1.0, -2.0])) == pytest.approx(expected, rel=1e-12)


def _plate_with(*loops_and_rings, half=20.0, depth=3.0):
    return np.concatenate([_border(half, 0.0), _border(half, -depth), *loops_and_rings])


def test_a_through_hole_and_its_type():
    points = _plate_with(_ring((2.0, 1.0), 3.0, 32, 0.0), _ring((2.0, 1.0), 3.0, 32, -3.0))
    found, rejected = _loops(points)
    assert len(found) == 1 and found[0].type == "through"
    assert np.allclose(found[0].center, (2.0, 1.0), atol=1e-12)
    assert found[0].vertex_diameter == pytest.approx(6.0, abs=1e-12)


def test_countersunk_and_counterbored_types():
    csk = _plate_with(_ring((-8, 0), 3.5, 48, 0.0), _ring((-8, 0), 2.0, 48, -1.5), _ring((-8, 0), 2.0, 48, -3.0))
    (hole,), _ = _loops(csk)
    assert hole.type == "countersunk" and hole.cone_angle_deg == pytest.approx(2 * math.degrees(math.atan(1.5 / 1.5)),
                                                                                abs=1.0)
    cbore = _plate_with(_ring((8, 0), 4.0, 48, 0.0), _ring((8, 0), 4.0, 48, -1.0), _ring((8, 0), 2.5, 48, -1.0),
                        _ring((8, 0), 2.5, 48, -3.0))
    (hole,), _ = _loops(cbore)
    assert hole.type == "counterbored" and hole.counterbore_depth == pytest.approx(1.0)


def test_few_vertices_are_no_circle(monkeypatch):
    """A 6-gon: no loop of fewer than MIN_VERTICES vertices is taken for a circle."""
    points = _plate_with(_ring((0, 0), 3.0, 6, 0.0), _ring((0, 0), 3.0, 6, -3.0))
    assert _loops(points)[0] == []
    monkeypatch.setattr(E, "MIN_VERTICES", 3)
    assert len(_loops(points)[0]) == 1


def test_a_round_outline_is_no_hole(monkeypatch):
    """A round part's outline (a disc: its top and bottom loops): nothing outside it shows a face
    around it (loop_no_face_outside)."""
    points = np.concatenate([_ring((0, 0), 20.0, 96, 0.0), _ring((0, 0), 20.0, 96, -10.0)])  # (no pocket's floor)
    found, rejected = _loops(points)
    assert found == [] and [r.check for r in rejected] == ["loop_no_face_outside"]
    _without(monkeypatch, "loop_no_face_outside")
    assert len(_loops(points)[0]) == 1


def test_a_ring_groove_is_no_hole(monkeypatch):
    """A ring groove: its outer edge holds the island's loop inside (loop_material_inside), and the
    island's edge has the groove's wider loop below it (loop_wider_below); neither is a hole."""
    points = _plate_with(_ring((0, 0), 6.0, 64, 0.0), _ring((0, 0), 4.0, 48, 0.0), _ring((0, 0), 6.0, 64, -1.0),
                         _ring((0, 0), 4.0, 48, -1.0))
    found, rejected = _loops(points)
    assert found == [] and sorted(r.check for r in rejected if r.check != "loop_not_round") == \
        ["loop_material_inside", "loop_wider_below"]
    for check in ("loop_material_inside", "loop_wider_below"):
        with monkeypatch.context() as m:
            _without(m, check)
            assert len(_loops(points)[0]) == 1, check


def test_points_sampled_near_an_edge_are_not_its_vertices(monkeypatch):
    """A face sampled on rings about a hole (a rotating sensor's pattern): the innermost ring is round
    and closed, but the face's points lie a ring pitch from it: sampled points near the edge, inside
    the material by up to a pitch, not the edge's vertices (loop_not_isolated)."""
    rings = [_ring((0, 0), 3.0 + 0.5 * k, 40 + 7 * k, 0.0, phase=0.1 * k) for k in range(8)]
    points = np.concatenate([_border(20.0, 0.0), *rings, _ring((0, 0), 3.0, 40, -3.0)])
    found, rejected = _loops(points)
    assert found == [] and "loop_not_isolated" in [r.check for r in rejected]
    _without(monkeypatch, "loop_not_isolated")
    assert len(_loops(points)[0]) >= 1


def _mixed_panel_vertices():
    spec = PanelSpec(50, 36, 3, segments=48, features=(
        F("through", (-14, 2), diameter=4.0), F("countersunk", (14, -2), diameter=4.0, countersink_diameter=7.0),
        F("slot", (0, 10), width=3.0, length=10.0), F("boss", (0, 0), diameter=5.0, height=2.0),
        F("cutout", (0, -10), width=5.0, length=10.0, corner_radius=1.0)))
    panel = build_panel(spec)
    points = cad_cloud(panel.vertices, panel.triangles, "vertices")
    truth = cad_truth(panel.vertices, panel.triangles, pitch=0.1, kind="vertices")
    return points, truth


def test_slot_cutout_boss_and_border_are_not_holes():
    """The two holes of a panel with a slot, a cut-out and a boss, each reported with the note
    edge_loops; the slot, the cut-out and the border are refused as not round, the boss's foot as a boss."""
    points, truth = _mixed_panel_vertices()
    for view in (DOWN, None):
        result = detect(points, view_dir=view)
        assert len(result.holes) == 2
        for hole, true in zip(sorted(result.holes, key=lambda h: h.center), sorted(truth["holes"], key=lambda h: h["center"])):
            assert np.allclose(hole.center, true["center"], atol=1e-6)
            assert hole.diameter == pytest.approx(true["edge_diameter"], abs=1e-6)
            assert [n.code for n in hole.notes] == ["edge_loops"] and hole.warnings == ()
            assert hole.uncertainty.estimator == "edge_loops" and 0 < hole.uncertainty.diameter < 1e-4
        assert sorted(h.type for h in result.holes) == ["countersunk", "through"]
        checks = sorted(r.check for r in result.rejected if r.check.startswith("loop_"))
        assert checks == ["loop_boss", "loop_not_round", "loop_not_round", "loop_not_round"], checks


@pytest.mark.parametrize("check", ["loop_not_round", "loop_boss"])
def test_panel_checks_are_needed(monkeypatch, check):
    points, _ = _mixed_panel_vertices()
    _without(monkeypatch, check)
    assert len(detect(points, view_dir=DOWN).holes) > 2


def test_vertex_export_of_the_plate_stl():
    """trimesh's plate_holes.STL (float32 vertices: round to 2e-5 mm at 250 mm) given as its vertices:
    its 5 holes (four countersunk, one counterbored), nothing else."""
    from pathlib import Path

    from holecli.simulation.profiler import load_mesh

    vertices, triangles = load_mesh(Path(__file__).resolve().parents[1] / "data" / "cad" / "plate_holes.STL")
    points = cad_cloud(vertices, triangles, "vertices")
    truth = cad_truth(vertices, triangles, pitch=0.25, kind="vertices")
    holes = detect(points, view_dir=DOWN).holes
    assert len(holes) == 5
    for true in truth["holes"]:
        hole = min(holes, key=lambda h: np.linalg.norm(np.subtract(h.center, true["center"])))
        assert np.linalg.norm(np.subtract(hole.center, true["center"])) < 1e-4
        assert hole.diameter == pytest.approx(true["edge_diameter"], abs=1e-4)
        assert hole.type == {"countersink": "countersunk", "counterbore": "counterbored"}[true["type"]]


def test_sensor_sampling_is_not_looked_at():
    """The search is gated by cost only: a scan's sampling (gaps of 1-3 spacings) with more than
    SMALL_SURFACE surface points is not searched."""
    assert not E.looks_like_vertices(0.1, 0.26, E.SMALL_SURFACE + 1)
    assert E.looks_like_vertices(0.1, 0.26, E.SMALL_SURFACE)
    assert E.looks_like_vertices(0.4, 6.0, 10 ** 6)


def test_a_pocket_is_no_hole_and_a_thin_sheets_hole_is(monkeypatch):
    """loop_pocket: a loop of the edge's size below it on a floor of its own (no other vertex at that depth)
    less than 0.15 diameters deep is a pocket's floor; a through hole in a sheet as thin as that has its
    bottom loop on the bottom face, beside the part's other bottom vertices, and is a hole."""
    pocket = _plate_with(_ring((0.0, 0.0), 6.0, 48, 0.0), _ring((0.0, 0.0), 6.0, 48, -0.8))
    found, rejected = _loops(pocket)
    assert found == [] and [r.check for r in rejected if r.check != "loop_not_round"] == ["loop_pocket"]
    _without(monkeypatch, "loop_pocket")
    assert len(_loops(pocket)[0]) == 1
    monkeypatch.undo()
    thin = _plate_with(_ring((0.0, 0.0), 6.0, 48, 0.0), _ring((0.0, 0.0), 6.0, 48, -0.8), depth=0.8)
    (hole,), _ = _loops(thin)
    assert hole.type == "through"


def test_the_pocket_limit_is_the_callers_setting():
    """loop_pocket's limit is the ``pocket_max_depth_ratio`` of the settings given (no module copy of its
    default): the 0.8 mm deep floor of a 12 mm loop (0.067 diameters) is a pocket's under the default
    0.15 and a blind hole's under 0.05."""
    from dataclasses import replace

    from holecli.settings import DEFAULT_SETTINGS

    pocket = _plate_with(_ring((0.0, 0.0), 6.0, 48, 0.0), _ring((0.0, 0.0), 6.0, 48, -0.8))
    _, rejected = _loops(pocket, settings=replace(DEFAULT_SETTINGS, pocket_max_depth_ratio=0.5))
    (refused,) = [r for r in rejected if r.check == "loop_pocket"]
    assert refused.limit == 0.5
    (hole,), rejected = _loops(pocket, settings=replace(DEFAULT_SETTINGS, pocket_max_depth_ratio=0.05))
    assert "loop_pocket" not in [r.check for r in rejected]


@pytest.mark.parametrize("noise", [0.0, 0.005])
def test_pockets_of_a_panel_as_its_vertices(noise):
    """The panel simulator's pockets (kind "pocket") given as the mesh's vertices: no hole on them (with
    5 um of noise, the level of the other pocket's floor 0.2 mm away is not this floor's)."""
    panel = build_panel(PanelSpec(50, 40, 5, segments=64, features=(
        F("pocket", (-12, 6), diameter=12.0, depth=0.6), F("pocket", (-10, -10), diameter=8.0, depth=0.4),
        F("through", (12, -8), diameter=4.0))))
    holes = detect(cad_cloud(panel.vertices, panel.triangles, "vertices", noise=noise, rng=1), view_dir=DOWN).holes
    assert [(h.type, round(h.center[0])) for h in holes] == [("through", 12)]
