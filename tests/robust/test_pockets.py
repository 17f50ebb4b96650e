"""Shallow round pockets are not holes (issue 24, item 2; the check ``pocket``): a round recess milled to
a flat floor less than ``pocket_max_depth_ratio`` (0.15) diameters deep (a spot face) is reported as
a rejection, while blind holes, whose floors no drill leaves shallower than its point (0.30 diameters
for 118 degrees), and through holes beside it are measured. The panel simulator makes the class
(``FeatureSpec(kind="pocket")``), seen by the exact lattice of a CAD cloud and by the profiler."""

import math

import numpy as np
import pytest

from holecli.pipeline import detect
from holecli.simulation.cad_cloud import cad_cloud
from holecli.simulation.panel import FeatureSpec as F
from holecli.simulation.panel import PanelSpec, build_panel, panel_truth
from holecli.simulation.profiler import ProfilerSpec
from holecli.simulation.scan_part import scan_part

pytestmark = pytest.mark.slow  # the quick loop: pytest -m "not slow"


def _panel(seed):
    rng = np.random.default_rng([314, seed])
    pocket = rng.uniform(6.0, 16.0)
    blind = rng.uniform(3.0, 6.0)
    features = (F("pocket", (-12.0, 0.0), diameter=pocket, depth=pocket * rng.uniform(0.02, 0.12)),
                F("blind", (6.0, 4.0), diameter=blind, depth=blind * rng.uniform(0.2, 0.9)),
                F("through", (8.0, -6.0), diameter=rng.uniform(3.0, 6.0)))
    panel = build_panel(PanelSpec(48, 30, 6, segments=256, features=features))
    return panel, panel_truth(panel)["features"], rng


def _cloud(seed):
    panel, features, rng = _panel(seed)
    if seed % 2 == 0:
        return cad_cloud(panel.vertices, panel.triangles, "lattice", rng.uniform(0.08, 0.15)), features
    tilt = math.radians(rng.uniform(0.0, 20.0))
    spec = ProfilerSpec(view=(0.0, math.sin(tilt), -math.cos(tilt)), line_length=46.0, scan_length=28.0,
                        point_pitch=0.08, line_pitch=0.12, range_noise=float(rng.choice([0.0, 0.005])))
    return scan_part(panel.vertices, panel.triangles, features, spec, rng=seed).scan.points, features


def test_pockets_are_not_holes_and_blind_holes_are():
    for seed in range(8):
        points, features = _cloud(seed)
        result = detect(points)
        pocket, blind, through = features
        near = {f["kind"]: [h for h in result.holes if np.hypot(*np.subtract(h.center, f["center"])[:2]) < 1.0]
                for f in features}
        assert near["pocket"] == [], (seed, near["pocket"])
        assert any(r.check == "pocket" for r in result.rejected), seed
        assert [h.type for h in near["blind"]] == ["blind"], seed
        assert [h.type for h in near["through"]] == ["through"], seed
