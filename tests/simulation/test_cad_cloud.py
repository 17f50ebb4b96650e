"""holecli.simulation.cad_cloud and ``holecli simulate --cloud``: clouds made from a CAD mesh as engineers make
them, and their truth in the validation suite's format."""

import json
import math
from pathlib import Path

import numpy as np
import pytest

from holecli.simulation.cad_cloud import cad_cloud, cad_truth, cloud_pitch
from holecli.simulation.panel import FeatureSpec, PanelSpec, build_panel

PLATE = Path(__file__).resolve().parents[1] / "data" / "cad" / "plate_holes.STL"


@pytest.fixture(scope="module")
def panel():
    return build_panel(PanelSpec(30, 20, 3, segments=48, features=(
        FeatureSpec("through", (-6, 0), diameter=4.0),
        FeatureSpec("countersunk", (6, 0), diameter=4.0, countersink_diameter=7.0))))


def _on_an_edge(points, holes, half=(15.0, 10.0)):
    """Whether each point lies on a hole's loop (some radius about its axis) or the border."""
    border = (np.abs(np.abs(points[:, 0]) - half[0]) < 1e-9) | (np.abs(np.abs(points[:, 1]) - half[1]) < 1e-9)
    loops = np.zeros(len(points), bool)
    for x in holes:
        r = np.hypot(points[:, 0] - x, points[:, 1])
        loops |= r < 4.0
    return border | loops


def test_vertices_lie_only_along_edges(panel):
    """A CAD export's vertices: none inside a flat face (the panel's own grid and rings are left out)."""
    points = cad_cloud(panel.vertices, panel.triangles, "vertices")
    assert len(points) < len(panel.vertices) / 2
    assert _on_an_edge(points, (-6.0, 6.0)).all()
    top = points[np.abs(points[:, 2]) < 1e-9]
    radii = np.hypot(top[:, 0] + 6.0, top[:, 1])
    ring = radii < 3.0
    assert np.allclose(radii[ring], 2.0, atol=1e-9) and ring.sum() == 48  # the hole's edge polygon


def test_surface_sampling_even_and_without_walls(panel):
    """``area / spacing**2`` points, area-weighted; ``no-walls`` leaves the bores and sides out."""
    spacing = 0.2
    every = cad_cloud(panel.vertices, panel.triangles, "surface", spacing, rng=1)
    v, t = panel.vertices, panel.triangles
    area = 0.5 * np.linalg.norm(np.cross(v[t[:, 1]] - v[t[:, 0]], v[t[:, 2]] - v[t[:, 0]]), axis=1).sum()
    assert len(every) == round(area / spacing ** 2)
    # even: the top and the bottom (about the same area) get about the same share
    top, bottom = np.sum(np.abs(every[:, 2]) < 1e-9), np.sum(np.abs(every[:, 2] + 3.0) < 1e-9)
    assert abs(top - bottom) < 0.1 * bottom
    bore = np.hypot(every[:, 0] + 6.0, every[:, 1])
    on_wall = (np.abs(bore - 2.0) < 0.01) & (every[:, 2] < -1e-6) & (every[:, 2] > -3.0 + 1e-6)
    assert on_wall.sum() > 100
    no_walls = cad_cloud(panel.vertices, panel.triangles, "surface", spacing, faces="no-walls", rng=1)
    bore = np.hypot(no_walls[:, 0] + 6.0, no_walls[:, 1])
    assert not np.any((np.abs(bore - 2.0) < 0.01) & (no_walls[:, 2] < -1e-6) & (no_walls[:, 2] > -3.0 + 1e-6))
    seen = cad_cloud(panel.vertices, panel.triangles, "surface", spacing, faces="seen", rng=1)
    assert np.all(seen[:, 2] > -3.0 + 1e-9)  # nothing of the bottom


def test_lattice_straight_down_and_noise(panel):
    """An exact square lattice of the pitch (the first surface each vertical ray meets); noise along the view."""
    points = cad_cloud(panel.vertices, panel.triangles, "lattice", 0.25, target=(0.01, 0.02, 0.0))
    for axis, offset in ((0, 0.01), (1, 0.02)):
        steps = (points[:, axis] - offset) / 0.25  # centred on the target: whole or half steps from it
        steps = steps - steps.min()
        assert np.allclose(steps, np.round(steps), atol=1e-9)
    assert cloud_pitch(points, "lattice", 0.25) == 0.25
    assert np.all(points[:, 2] > -3.0 - 1e-9)
    noisy = cad_cloud(panel.vertices, panel.triangles, "lattice", 0.25, target=(0.01, 0.02, 0.0), noise=0.005, rng=3)
    assert np.allclose(noisy[:, :2], points[:, :2])
    top = np.abs(points[:, 2]) < 1e-9
    assert 0.0045 < np.std(noisy[top, 2]) < 0.0055


def test_truth_of_the_plate_matches_the_validation_suite():
    """trimesh's plate_holes.STL: 4 countersinks and a counterbore whose edge diameters are the least-squares
    circles of the 24-gons, as ../shared/validation/realistic's truth gives them (12.80441574844528 and
    11.04917742865808), and the counterbore's bore on its floor."""
    from holecli.simulation.profiler import load_mesh

    vertices, triangles = load_mesh(PLATE)
    truth = cad_truth(vertices, triangles, pitch=0.25)
    kinds = sorted(h["type"] for h in truth["holes"])
    assert kinds == ["counterbore"] + ["countersink"] * 4
    assert all(h["status"] == "full" for h in truth["holes"])
    for h in truth["holes"]:
        expected = 11.04917742865808 if h["type"] == "counterbore" else 12.80441574844528
        assert h["edge_diameter"] == pytest.approx(expected, abs=3e-5)  # float32 vertices: the 24-gons are not quite regular
        assert h["edge_roundness"] == pytest.approx(expected / 2 * (1 / math.cos(math.pi / 24) - 1), rel=0.02)
    (floor,) = truth["holes_on_other_surfaces"]
    assert floor["center"][2] == pytest.approx(6.35, abs=1e-5)


def test_truth_status_and_frame(panel):
    """A region that cuts a hole makes it partial; a frame moves centres and turns normals and the view."""
    truth = cad_truth(panel.vertices, panel.triangles, pitch=0.1, target=(-2.0, 0.0, 0.0), line_length=16.0,
                      scan_length=20.0)
    status = {round(h["center"][0]): h["status"] for h in truth["holes"]}
    assert status == {-6: "full", 6: "partial"}
    frame = np.eye(4)
    frame[1, 1] = frame[2, 2] = -1.0
    frame[:3, 3] = (100.0, 0.0, 0.0)
    turned = cad_truth(panel.vertices, panel.triangles, pitch=0.1, frame=frame)
    assert turned["view_dir"] == [0.0, 0.0, 1.0]
    assert all(h["surface_normal"][2] == pytest.approx(-1.0) for h in turned["holes"])
    assert sorted(round(h["center"][0]) for h in turned["holes"]) == [94, 106]


def test_simulate_cloud_cli(tmp_path):
    """``holecli simulate --mesh --cloud``: the cloud and a truth the validation scorer reads."""
    from click.testing import CliRunner

    from holecli.cli.simulate import simulate
    from holecli.io import load_points

    out = tmp_path / "plate.ply"
    result = CliRunner().invoke(simulate, [str(out), "--mesh", str(PLATE), "--cloud", "vertices", "--range-noise",
                                           "0.001", "--float64", "-q"])
    assert result.exit_code == 0, result.output
    truth = json.loads(out.with_suffix(".truth.json").read_text())
    assert len(truth["holes"]) == 5 and truth["cloud"] == "vertices" and truth["noise"] == 0.001
    assert truth["pitch"] > 0.5  # the vertices' own spacing: 24-gons of 12.9 mm
    cloud = load_points(str(out))
    assert 300 < len(getattr(cloud, "points", cloud)) < 1000  # the STL's vertices on its edges
    refused = CliRunner().invoke(simulate, [str(out), "--mesh", str(PLATE), "--cloud", "lattice", "--jitter", "0.1"])
    assert refused.exit_code == 2 and "--jitter" in refused.output
    no_part = CliRunner().invoke(simulate, [str(out), "--cloud", "lattice"])
    assert no_part.exit_code == 2 and "--cloud needs --panel or --mesh" in no_part.output
