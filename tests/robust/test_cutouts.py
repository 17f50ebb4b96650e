"""Holes among slots, cut-outs and bosses (issue 24): fresh panels of ``benchmarks/cutouts.py``, built by
holecli.simulation.panel and scanned by its profiler (pitch 0.05-0.25 mm, tilt 0-25 deg, noise 0-10 um,
fan or parallel rays), six real holes each among a long slot (aspect >= 3, longer than twice the hole
spacing), a rectangular cut-out with rounded corners and a boss or a second slot, the latter often cut
by the scan's border.

Measured over seeds 0-39 (``python benchmarks/cutouts.py --seeds 40``): 239 of 240 holes within the
validation tolerances; nothing on a slot or a cut-out (117 features, 73 cut by the border); 2 reports on
bosses cut by the border (seeds 26 and 32, see the CHANGELOG), none since the ``boss`` check counts only
the part of the disk inside the scan (test below). Without ``material_in_first_circle``
(``--set max_material_dropped=1``) 5 cut-outs of the 40 scenes are reported as holes of 10-24 mm
(seeds 0, 4, 16, 29, 31). The test runs the first twelve seeds, two of which (0, 4) need the check.
"""

import importlib.util
import math
from pathlib import Path

import numpy as np
import pytest

from holecli.pipeline import detect
from holecli.simulation.panel import FeatureSpec, PanelSpec, build_panel, panel_truth
from holecli.simulation.profiler import ProfilerSpec
from holecli.simulation.scan_part import scan_part

pytestmark = pytest.mark.slow  # the quick loop: pytest -m "not slow"

_PATH = Path(__file__).resolve().parents[2] / "benchmarks" / "cutouts.py"
_SPEC = importlib.util.spec_from_file_location("cutouts", _PATH)
cutouts = importlib.util.module_from_spec(_SPEC)
_SPEC.loader.exec_module(cutouts)


def test_holes_among_slots_cutouts_and_bosses():
    results = [cutouts.measure(seed) for seed in range(12)]
    expected = sum(r["expected"] for r in results)
    within = sum(r["within"] for r in results)
    assert expected == 72
    assert within == expected, [r["misses"] for r in results if r["misses"]]
    # nothing reported on a slot, a cut-out or a boss, nor anywhere else that is not a hole
    assert sum(r["extra"] for r in results) == 0, [(r["seed"], r["extras"]) for r in results if r["extras"]]
    # the scenes do cut features by the scan's border
    assert sum(r["cut"] for r in results) >= 12


def _cut_boss_scene(seed):
    """A panel whose boss is cut by the scan's border, on any of its four sides, its center from 0.3 R
    inside to 0.45 R outside it (the rim of what is inside then spans more than the 120 degrees a
    partial hole needs); a through hole cut by a border of the robot's travel (the line's border is
    blurred by the fan), its center 0.1-0.6 R inside; two whole holes. Drawn: pitch 0.05-0.25 mm
    (the line's pitch 1.5 times finer in 30 %), sizes 12-60 pitches (the cut hole 20-60: fewer rim
    points than a partial hole needs otherwise), boss height 0.3-2.5 mm, the view tilted 0-25 deg
    across a line turned anywhere on the panel, fan or parallel rays, range noise 0-10 um.
    Returns (points, truth)."""
    rng = np.random.default_rng([2411, seed])
    p = float(np.exp(rng.uniform(np.log(0.05), np.log(0.25))))
    half = min(110.0 * p, 14.0)  # the window's half side
    tilt = math.radians(rng.uniform(0.0, 25.0))
    phi = rng.uniform(0.0, 2.0 * math.pi)  # the line's direction on the panel
    line, across = np.array([math.cos(phi), math.sin(phi)]), np.array([-math.sin(phi), math.cos(phi)])
    borders = (half, half / math.cos(tilt))  # the window's half sides on the panel: along the line, across it

    def place(x, y):
        return tuple(float(c) for c in x * line + y * across)

    def size(fewest=12.0):
        return float(np.exp(rng.uniform(np.log(fewest * p), np.log(min(60.0 * p, 0.45 * half)))))

    side = int(rng.integers(4))
    boss = size()
    outside = float(rng.uniform(-0.3, 0.45)) * 0.5 * boss
    axis, sign = side % 2, (1.0 if side < 2 else -1.0)
    along = float(rng.uniform(-0.4, 0.4)) * borders[1 - axis]
    xy = [0.0, 0.0]
    xy[axis], xy[1 - axis] = sign * (borders[axis] + outside), along
    features = [FeatureSpec(kind="boss", center=place(*xy), diameter=boss, height=float(rng.uniform(0.3, 2.5)))]
    hole = size(20.0)
    if axis == 1:  # the boss on a border of the travel: the hole on the other
        hole_sign, hole_along = -sign, -math.copysign(1.0, along) * float(rng.uniform(0.1, 0.4)) * borders[0]
    else:
        hole_sign, hole_along = float(rng.choice([-1.0, 1.0])), float(rng.uniform(-0.4, 0.4)) * borders[0]
    inside = float(rng.uniform(0.1, 0.6)) * 0.5 * hole
    features.append(FeatureSpec(kind="through", center=place(hole_along, hole_sign * (borders[1] - inside)),
                                diameter=hole))
    for x in (-0.35, 0.35):
        features.append(FeatureSpec(kind="through", center=place(x * half, 0.0), diameter=size()))
    panel_half = math.hypot(*borders) + 3.0
    panel = build_panel(PanelSpec(width=2 * panel_half, height=2 * panel_half, thickness=float(rng.uniform(1.5, 4.0)),
                                  features=tuple(features), chord_error=1e-4))
    spec = ProfilerSpec(target=(0.0, 0.0, 0.0), standoff=120.0,
                        view=(-math.sin(phi) * math.sin(tilt), math.cos(phi) * math.sin(tilt), -math.cos(tilt)),
                        line=(line[0], line[1], 0.0), line_length=2.0 * half, scan_length=2.0 * half,
                        point_pitch=p / 1.5 if rng.uniform() < 0.3 else p, line_pitch=p, fan=bool(rng.integers(2)),
                        range_noise=float(rng.choice([0.0, 0.002, 0.005, 0.01])))
    scanned = scan_part(panel.vertices, panel.triangles, panel_truth(panel)["features"], spec, rng=seed)
    points = scanned.scan.points
    return points[np.isfinite(points).all(axis=1)], scanned.truth


def test_a_boss_cut_by_the_border_is_no_hole_and_a_cut_hole_still_is():
    """The ``boss`` check counts the points a boss stands over on the part of the disk inside the scan
    (the convex hull of the scanned material), not on the whole disk: a boss cut by the border is no
    partial hole, a hole cut by it still is.

    Measured over these 24 scenes: 1 boss reported (seed 13: a 0.74 mm pin 2.3 mm tall at 10 deg,
    whose top the slanted laser leaves out of the scan and whose wall it sees at more than the
    sensor's 75 deg: not one point of it is in the scan, a partial hole as far as the data tell);
    8 without the scanned part (``_scanned_fraction`` = 1: seeds 0, 2, 4, 7, 10, 13, 19, 21). Every
    cut hole reported, partial, and every whole hole found, with and without it.
    """
    on_boss, missed = [], []
    for seed in range(24):
        points, truth = _cut_boss_scene(seed)
        holes = detect(points).holes
        boss = truth["features"][0]
        assert boss["partial"]
        on_boss += [(seed, round(h.diameter, 2)) for h in holes
                    if np.hypot(*np.subtract(h.center, boss["center"])[:2]) <= 0.5 * boss["diameter"] + 1.0]
        for hole in truth["holes"]:
            near = [h for h in holes
                    if np.linalg.norm(np.subtract(h.center, hole["center"])) <= max(0.1, 0.1 * hole["diameter"])]
            if not near or near[0].partial != hole["partial"]:
                missed.append((seed, round(hole["diameter"], 2), hole["partial"]))
    assert len(on_boss) <= 1, on_boss
    assert not missed, missed
