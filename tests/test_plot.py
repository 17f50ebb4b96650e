"""holecli.plot: the figure of a detection (its artists, its PNG), on the sample clouds."""

import io

import numpy as np
import pytest

pytest.importorskip("matplotlib")

from matplotlib.patches import Circle  # noqa: E402

from holecli import detect_file, plot  # noqa: E402
from holecli.io import read_cloud  # noqa: E402
from tests.conftest import REPO_ROOT  # noqa: E402

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module", params=["panel.ply", "table1.ply"])
def drawn(request):
    path = REPO_ROOT / "sample_clouds" / request.param
    detection = detect_file(path)
    return detection, plot.figure(detection, read_cloud(path).points)


def hole_axes(fig):
    return [ax for ax in fig.axes if (ax.get_gid() or "").startswith("hole ")]


def test_one_view_per_hole_with_its_edge_circle_and_center(drawn):
    detection, fig = drawn
    views = hole_axes(fig)
    assert len(views) == len(detection.holes) >= 1
    for ax, hole in zip(views, detection.holes):
        edges = [p for p in ax.patches if isinstance(p, Circle) and p.get_gid() == f"edge {hole.index}"]
        assert len(edges) == 1
        assert edges[0].get_radius() == pytest.approx(hole.diameter / 2)
        assert edges[0].center == (0, 0)
        assert ax.get_aspect() == 1.0
        assert "[" in ax.get_xlabel() and "[" in ax.get_ylabel()
        assert ax.collections and ax.collections[0].get_offsets().shape[0] > 50  # the points around it


def test_a_text_box_per_hole_with_its_diameter(drawn):
    detection, fig = drawn
    for hole in detection.holes:
        [box] = [ax for ax in fig.axes if ax.get_gid() == f"text {hole.index}"]
        text = "\n".join(t.get_text() for t in box.texts)
        assert f"diameter: {hole.diameter:.4f}" in text
        assert "normal: (" in text and "type: " in text and "warnings: " in text
        for warning in hole.warnings:
            assert warning.code in text


def test_the_countersink_circle_where_measured():
    path = REPO_ROOT / "sample_clouds" / "panel.ply"
    detection = detect_file(path)
    fig = plot.figure(detection, read_cloud(path).points)
    countersunk = [h for h in detection.holes if h.countersink is not None and h.countersink.diameter]
    assert countersunk
    for hole in countersunk:
        [ax] = [ax for ax in fig.axes if ax.get_gid() == f"hole {hole.index}"]
        circles = [p for p in ax.patches if p.get_gid() == f"countersink {hole.index}"]
        assert len(circles) <= 1  # drawn unless it is the edge itself
        if circles:
            assert circles[0].get_radius() == pytest.approx(hole.countersink.diameter / 2)


def test_max_panels_draws_the_first_holes():
    path = REPO_ROOT / "sample_clouds" / "panel.ply"
    detection = detect_file(path)
    fig = plot.figure(detection, read_cloud(path).points, max_panels=2)
    assert [ax.get_gid() for ax in hole_axes(fig)] == ["hole 0", "hole 1"]
    assert "first 2 shown" in fig._suptitle.get_text()


def test_edge_residuals_are_small_on_a_clean_hole():
    path = REPO_ROOT / "sample_clouds" / "table1.ply"
    detection = detect_file(path)
    hole = detection.holes[0]
    angle, residual = plot.edge_residuals(read_cloud(path).points, hole, detection.plane.rms, sectors=60)
    assert angle.size >= 50
    assert np.all(np.abs(angle) <= np.pi)
    assert np.median(np.abs(residual)) < 0.2 * hole.diameter / 2


def test_no_hole_gives_one_axes_saying_so():
    path = REPO_ROOT / "sample_clouds" / "no_hole.csv"
    detection = detect_file(path)
    assert not detection.holes
    fig = plot.figure(detection, read_cloud(path).points)
    assert [ax.get_gid() for ax in fig.axes] == ["no hole"]
    assert "no hole" in fig.axes[0].get_title()


def test_the_png_is_a_picture(drawn):
    from PIL import Image

    detection, fig = drawn
    payload = plot.png_bytes(fig, dpi=50)
    assert payload.startswith(PNG_MAGIC)
    image = np.asarray(Image.open(io.BytesIO(payload)).convert("L"), dtype=float)
    assert image.shape[1] == 14 * 50
    assert image.shape[0] == pytest.approx(4.6 * 50 * len(detection.holes), rel=0.02)
    assert image.std() > 10  # not blank


def test_plane_frame_is_orthonormal():
    for normal in ([0, 0, 1], [1, 0, 0], [0.18, -0.5, 0.85]):
        n = np.asarray(normal, float) / np.linalg.norm(normal)
        u, v = plot.plane_frame(n)
        assert np.allclose([u @ u, v @ v, u @ v, u @ n, v @ n], [1, 1, 0, 0, 0], atol=1e-12)
        assert np.allclose(np.cross(u, v), n)
