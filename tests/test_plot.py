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
        assert ("notes: " in text) == bool(hole.notes)
        for note in hole.notes:
            assert note.code in text


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


def test_the_gauge_circle_and_reading_with_a_gauge_depth():
    path = REPO_ROOT / "sample_clouds" / "panel.ply"
    detection = detect_file(path, gauge_depth=0.5)
    fig = plot.figure(detection, read_cloud(path).points)
    gauged = [h for h in detection.holes if h.countersink is not None and h.countersink.diameter_at_depth]
    assert gauged
    for hole in gauged:
        [ax] = [ax for ax in fig.axes if ax.get_gid() == f"hole {hole.index}"]
        [circle] = [p for p in ax.patches if p.get_gid() == f"gauge {hole.index}"]
        assert circle.get_radius() == pytest.approx(hole.countersink.diameter_at_depth / 2)
        assert circle.get_linestyle() == "-."
        [box] = [ax for ax in fig.axes if ax.get_gid() == f"text {hole.index}"]
        assert f"gauge: dia {hole.countersink.diameter_at_depth:.4g}" in box.texts[0].get_text()
    # without a gauge depth: no gauge circle
    plain = plot.figure(detect_file(path), read_cloud(path).points)
    assert not [p for ax in plain.axes for p in ax.patches if (p.get_gid() or "").startswith("gauge")]


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


# --- rim points, scale bar, verdict ------------------------------------------------------------


def _view(fig, index=0):
    [ax] = [ax for ax in fig.axes if ax.get_gid() == f"hole {index}"]
    return ax


def _collection(ax, gid):
    found = [c for c in ax.collections if c.get_gid() == gid]
    return found[0] if found else None


def _text(fig, index=0):
    [box] = [ax for ax in fig.axes if ax.get_gid() == f"text {index}"]
    return "\n".join(t.get_text() for t in box.texts)


@pytest.fixture(scope="module")
def inside_hole():
    """table1_inside100.csv: 100 reflections inside a 3.000 hole."""
    path = REPO_ROOT / "sample_clouds" / "table1_inside100.csv"
    detection = detect_file(path)
    return detection, read_cloud(path).points


def test_rim_points_of_a_clean_hole_are_used():
    path = REPO_ROOT / "sample_clouds" / "table1.ply"
    detection = detect_file(path)
    hole = detection.holes[0]
    rim = plot.rim_points(read_cloud(path).points, hole, detection.plane.rms, sectors=hole.rim_points)
    assert rim.used.sum() >= 0.9 * rim.used.size >= 0.8 * hole.rim_points
    assert np.all(np.abs(rim.residual[rim.used]) <= rim.limit)
    assert rim.limit < 0.2 * hole.diameter / 2
    assert rim.inside.shape[1] == 2


def test_rim_points_reject_the_reflections_inside(inside_hole):
    detection, points = inside_hole
    hole = detection.holes[0]
    rim = plot.rim_points(points, hole, detection.plane.rms, sectors=hole.rim_points)
    radius = hole.diameter / 2
    assert rim.used.sum() >= 0.8 * hole.rim_points  # the true rim, behind the reflections
    assert (~rim.used).sum() >= 10 and len(rim.inside) >= 10
    assert np.all(rim.residual[~rim.used] < -rim.limit) or np.all(np.abs(rim.residual[~rim.used]) > rim.limit)
    assert np.all(np.hypot(*rim.inside.T) < radius)


def test_the_view_draws_used_rejected_and_inside_points_with_a_legend_below(inside_hole):
    detection, points = inside_hole
    fig = plot.figure(detection, points, unit="mm")
    ax = _view(fig)
    used, rejected, inside = (_collection(ax, f"{kind} 0") for kind in ("rim used", "rim rejected", "inside"))
    assert used is not None and used.get_offsets().shape[0] >= 50
    assert rejected is not None and rejected.get_offsets().shape[0] >= 10
    assert inside is not None and inside.get_offsets().shape[0] >= 10
    assert used.get_paths()[0] is not rejected.get_paths()[0]  # two marker styles
    legend = ax.get_legend()
    labels = [t.get_text() for t in legend.get_texts()]
    assert any(label.startswith("rim points used") for label in labels)
    assert any(label.startswith("rim points rejected") for label in labels)
    assert any(label.startswith("surface points inside the hole") for label in labels)
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    canvas = FigureCanvasAgg(fig)
    fig.set_dpi(30)
    canvas.draw()  # laid out and drawn
    renderer = canvas.get_renderer()
    assert legend.get_window_extent(renderer).y1 <= ax.get_window_extent(renderer).y0 + 1  # below the view


def test_a_scale_bar_of_a_round_length_in_each_view(drawn):
    detection, fig = drawn
    for hole in detection.holes:
        ax = _view(fig, hole.index)
        bars = [a for a in ax.get_children() if a.get_gid() == f"scale bar {hole.index}"]
        assert len(bars) == 1
        label = bars[0].txt_label.get_text()
        number, unit = label.split()
        assert unit == (detection.units or ("unit" if float(number) == 1 else "units"))
        mantissa = float(number) / 10 ** np.floor(np.log10(float(number)))
        assert mantissa == pytest.approx(1) or mantissa == pytest.approx(2) or mantissa == pytest.approx(5)
        assert plot.VIEW_RADII * hole.diameter / 10 <= float(number) <= plot.VIEW_RADII * hole.diameter / 4 * 1.001
        assert "[" in ax.get_title()


def test_scale_bar_label_has_the_unit_asked_for():
    path = REPO_ROOT / "sample_clouds" / "table1.ply"
    detection = detect_file(path)
    fig = plot.figure(detection, read_cloud(path).points, unit="mm")
    [bar] = [a for a in _view(fig).get_children() if a.get_gid() == "scale bar 0"]
    assert bar.txt_label.get_text() == "1 mm"  # 3 mm hole: a 6 mm view
    assert "[mm]" in _view(fig).get_xlabel()


@pytest.mark.parametrize("span, length", [(12.0, 2.0), (4.0, 1.0), (0.03, 0.005), (20.0, 5.0), (400.0, 100.0)])
def test_scale_length_is_round(span, length):
    assert plot.scale_length(span) == pytest.approx(length)


def _checked(path, **spec):
    from holecli.tolerance import check, nominal_spec

    detection = detect_file(path)
    return detection, check(detection.to_dict(), nominal_spec(**spec))


def test_the_text_box_without_tolerances_says_so(drawn):
    detection, fig = drawn
    for hole in detection.holes:
        assert _text(fig, hole.index).endswith("verdict: no tolerance given")


def test_the_text_box_ends_with_the_verdict_fail_and_the_check():
    path = REPO_ROOT / "sample_clouds" / "table1.ply"
    detection, record = _checked(path, diameter=3, tolerance="+0.036/-0")
    assert record["holes"][0]["failed_checks"] == ["diameter"]
    fig = plot.figure(detection, read_cloud(path).points, checked=record["holes"], checked_unit="mm")
    text = _text(fig)
    assert text.splitlines()[-1] == "verdict: fail: diameter"
    hole = detection.holes[0]
    assert "tolerance (in mm):" in text
    assert f"diameter -0.003107 in [+0, +0.036] U {2 * hole.uncertainty.diameter:.2g}: fail" in text
    assert f"diameter: {hole.diameter:.4f} ± {2 * hole.uncertainty.diameter:.2g}" in text


def test_the_text_box_verdict_pass_and_undecided():
    path = REPO_ROOT / "sample_clouds" / "table1.ply"
    detection, record = _checked(path, diameter=3, tolerance=0.02)
    fig = plot.figure(detection, read_cloud(path).points, checked=record["holes"])
    assert _text(fig).splitlines()[-1] == "verdict: pass"
    hole = dict(record["holes"][0], in_tolerance=False, failed_checks=[], undecided_checks=["diameter"])
    assert plot.verdict_lines(hole)[-1] == "verdict: undecided: diameter"
    hole.update(failed_checks=["position"])
    assert plot.verdict_lines(hole)[-1] == "verdict: fail: position; undecided: diameter"
    assert plot.verdict_lines(dict(hole, in_tolerance=None)) == ["verdict: not checked (no nominal applies)"]
    assert plot.verdict_lines(None) == ["verdict: no tolerance given"]


# --- issue 25: the unit, the nominal and the tolerance zone ------------------------------------------


def _patch(fig, gid):
    [patch] = [patch for ax in fig.axes for patch in ax.patches if patch.get_gid() == gid]
    return patch


def test_the_nominal_circle_and_the_tolerance_zone_are_drawn():
    path = REPO_ROOT / "sample_clouds" / "table1.ply"
    detection, record = _checked(path, diameter=3, tolerance="+0.036/-0.01")
    fig = plot.figure(detection, read_cloud(path).points, checked=record["holes"], unit="mm")
    nominal, zone = _patch(fig, "nominal diameter 0"), _patch(fig, "tolerance zone diameter 0")
    assert nominal.radius == pytest.approx(1.5, abs=1e-12)
    assert zone.r == pytest.approx(3.036 / 2, abs=1e-12) and zone.width == pytest.approx(0.046 / 2, abs=1e-12)
    assert zone.get_hatch() is None and "note:" not in _text(fig)
    unchecked = plot.figure(detection, read_cloud(path).points, unit="mm")
    assert not [p for ax in unchecked.axes for p in ax.patches if "nominal" in (p.get_gid() or "")]


def test_a_u_wider_than_the_zone_is_noted_and_hatched():
    path = REPO_ROOT / "sample_clouds" / "table1.ply"
    detection, record = _checked(path, diameter=3, tolerance=0.002)  # 2U 0.019 > the 0.004 zone
    fig = plot.figure(detection, read_cloud(path).points, checked=record["holes"], unit="mm")
    text = _text(fig)
    assert "note: diameter: 2U = 0.019 is wider than its tolerance" in text and "zone 0.004" in text
    assert _patch(fig, "tolerance zone diameter 0").get_hatch() == "xx"


def test_lengths_are_drawn_in_mm_when_the_unit_is_known():
    path = REPO_ROOT / "sample_clouds" / "table1.ply"
    detection, record = _checked(path, diameter=3, tolerance=0.05)
    points = read_cloud(path).points
    in_m = plot.figure(detection, points, checked=record["holes"], unit="m", checked_unit="m")
    [view] = [ax for ax in in_m.axes if ax.get_gid() == "hole 0"]
    assert view.get_xlabel() == "in-plane offset u [mm]"
    assert _patch(in_m, "edge 0").radius == pytest.approx(1000 * detection.holes[0].diameter / 2)
    assert _patch(in_m, "nominal diameter 0").radius == pytest.approx(1500.0)
    assert f"diameter: {1000 * detection.holes[0].diameter:.4f}" in _text(in_m)
    unknown = plot.figure(detection, points)
    [view] = [ax for ax in unknown.axes if ax.get_gid() == "hole 0"]
    assert view.get_xlabel() == "in-plane offset u [units]"
    kept = plot.figure(detection, points, unit="m", picture_unit=None)
    assert _patch(kept, "edge 0").radius == pytest.approx(detection.holes[0].diameter / 2)
