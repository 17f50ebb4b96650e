"""holecli.simulation.part: a CAD part loaded, the profiler aimed at it, the frame it is moved into."""

import numpy as np
import pytest

from holecli.simulation.part import aimed_profiler, cad_scan, panel_part, rigid_frame
from tests.conftest import REPO_ROOT

PANEL_TEXT = (REPO_ROOT / "sample_clouds" / "panel.toml").read_text()

# simulate panel's defaults, as the command line passes them
DEFAULTS = dict(view=(0.0, 0.0, -1.0), line=(1.0, 0.0, 0.0), target=None, line_length=None, scan_length=None,
                rotation=None, translation=None, spacing=0.1, line_pitch=None, standoff=100.0, parallel_rays=False,
                triangulation_deg=25.0, max_incidence_deg=75.0, range_noise=0.0, range_quantum=0.0, dropout=0.0,
                jitter=0.0, line_width=0.0, keep_nan=False, metres=False, float64=False)


def test_a_panel_part_names_its_source_and_keeps_its_cutouts_apart():
    part = panel_part(PANEL_TEXT, "panel.toml")
    assert part.description["source"] == "panel.toml" and part.triangles.shape[1] == 3
    assert part.not_holes and all(not feature.get("is_hole", True) for feature in part.not_holes)
    assert len(part.not_holes) < len(part.features)


def test_the_profiler_aims_at_the_middle_of_the_part_on_its_side_facing_the_sensor():
    part = panel_part(PANEL_TEXT)
    spec = aimed_profiler(part.vertices, **DEFAULTS)
    low, high = part.vertices.min(axis=0), part.vertices.max(axis=0)
    np.testing.assert_allclose(spec.target[:2], 0.5 * (low + high)[:2])
    assert spec.target[2] == pytest.approx(high[2])  # looking down -z: the top face
    assert spec.line_length == pytest.approx(high[0] - low[0]) and spec.scan_length == pytest.approx(high[1] - low[1])
    assert spec.line_pitch == spec.point_pitch == 0.1 and spec.frame is None and spec.float32


def test_the_profiler_refuses_a_line_along_the_view():
    with pytest.raises(ValueError, match="--line must not be along --view"):
        aimed_profiler(panel_part(PANEL_TEXT).vertices, **dict(DEFAULTS, line=(0.0, 0.0, 2.0)))


def test_a_rigid_frame_rotates_then_translates_and_is_none_without_either():
    assert rigid_frame(None, None) is None
    frame = rigid_frame((0.0, 0.0, 90.0), (1.0, 2.0, 3.0))
    np.testing.assert_allclose(frame @ [1.0, 0.0, 0.0, 1.0], [1.0, 3.0, 3.0, 1.0], atol=1e-12)
    np.testing.assert_array_equal(rigid_frame(None, (1.0, 2.0, 3.0))[:3, :3], np.eye(3))


def test_a_cad_scan_is_moved_into_the_frame_and_rounded_to_single_precision():
    part = panel_part(PANEL_TEXT)
    region = dict(view=(0.0, 0.0, -1.0), line=(1.0, 0.0, 0.0), target=None, line_length=None, scan_length=None)
    here, _, pitch = cad_scan(part, "lattice", 0.5, faces="all", noise=0.0, seed=0, rotation=None, translation=None,
                              float64=True, **region)
    moved, truth, _ = cad_scan(part, "lattice", 0.5, faces="all", noise=0.0, seed=0, rotation=None,
                               translation=(1000.0, 0.0, 0.0), float64=False, **region)
    assert pitch == pytest.approx(0.5) and truth["holes"]
    np.testing.assert_allclose(moved, here + [1000.0, 0.0, 0.0], atol=1e-4)
    np.testing.assert_array_equal(moved, moved.astype(np.float32).astype(np.float64))
