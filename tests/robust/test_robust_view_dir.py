"""``--view-dir`` on real scans (issue 9, item 2.6): sliding along the sensor's ray is right for the
surface's points, whose height is range noise along the ray, and wrong for the points of a bore wall,
a cone or a floor, which really lie below the surface. Only the surface's points slide."""

import math

import numpy as np
import pytest

from holecli.pipeline import detect
from holecli.simulation.panel import FeatureSpec, PanelSpec, build_panel, panel_truth
from holecli.simulation.profiler import ProfilerSpec
from holecli.simulation.scan_part import scan_part

pytestmark = pytest.mark.slow  # the quick loop: pytest -m "not slow"


def _tilted_through_hole(seed):
    rng = np.random.default_rng([77, seed])
    diameter = rng.uniform(3.0, 6.0)
    panel = build_panel(PanelSpec(width=8 * diameter, height=8 * diameter, thickness=rng.uniform(2.0, 6.0),
                                  features=(FeatureSpec(kind="through", center=(0.0, 0.0), diameter=diameter),)))
    tilt = math.radians(rng.uniform(15.0, 40.0))
    pitch = rng.uniform(0.03, 0.08)
    view = (0.0, math.sin(tilt), -math.cos(tilt))
    spec = ProfilerSpec(view=view, line_length=5 * diameter, scan_length=5 * diameter, point_pitch=pitch,
                        line_pitch=pitch, range_noise=0.002, range_quantum=0.001)
    scanned = scan_part(panel.vertices, panel.triangles, panel_truth(panel)["features"], spec, rng=seed)
    return scanned.scan.points, scanned.truth["holes"][0], view, pitch


def test_view_dir_on_tilted_scans_with_bore_walls():
    errors, walls = [], 0
    for seed in range(12):
        points, truth, view, pitch = _tilted_through_hole(seed)
        walls += int(np.sum(points[:, 2] < -0.01))  # the tilted sensor sees into the bores
        (hole,) = detect(points, view_dir=view).holes
        errors.append((hole.diameter - truth["diameter"]) / pitch)
    assert walls > 0
    # within 0.15 of the pitch, as without --view-dir (sliding the wall points too put one of these
    # twelve 0.51 pitch off)
    assert all(abs(error) <= 0.15 for error in errors), errors
