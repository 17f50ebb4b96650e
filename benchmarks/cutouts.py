"""Holes among slots, cut-outs and bosses: built panels scanned by the simulated laser profiler.

Every scene is a flat panel (holecli.simulation.panel) with six real holes (through or countersunk) in
two rows a spacing ``s`` apart and, among them, features that are not holes: a long slot between the
rows (aspect >= 3, longer than twice the hole spacing), a rectangular cut-out with rounded corners
beside them, and either a boss or a second long slot across the rows. The profiler's window is drawn
per scene, so that the cut-out, the boss and the second slot are sometimes cut by the scan's border.
Drawn per seed: pitch 0.05-0.25 mm, hole size (12 to 50 points across), the slots' and cut-out's sizes
and corner radius, the view's tilt 0-25 deg, fan or parallel rays, range noise 0-10 um.

Scored as the validation suite's score.py does (p = the scan's pitch, s = the noise sigma): a hole is
found when a reported hole's center lies within max(0.1, 0.5 p) of it, and must then lie within
max(0.02, 0.2 p) + 0.5 s (center) and max(0.03, 0.3 p) + s (diameter); every hole whose edge is wholly
inside the scan, 3 pitches from its border, must be found; a reported hole that is no hole of the part
is extra, and one on a slot, cut-out or boss is counted apart.

Run:  python benchmarks/cutouts.py [--seeds 40] [--first 0] [--set NAME=VALUE ...]
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from holecli.pipeline import detect  # noqa: E402
from holecli.settings import DEFAULT_SETTINGS  # noqa: E402
from holecli.simulation.panel import FeatureSpec, PanelSpec, build_panel, panel_truth  # noqa: E402
from holecli.simulation.profiler import ProfilerSpec  # noqa: E402
from holecli.simulation.scan_part import scan_part  # noqa: E402

# The scan window's side, mm per mm of pitch, and at most (a scene stays near 100 k points).
WINDOW_PITCHES, WINDOW_MAX = 330.0, 50.0


def scene(seed):
    """(vertices, triangles, features, ProfilerSpec, description) of scene ``seed``."""
    rng = np.random.default_rng([2024, seed])
    p = float(np.exp(rng.uniform(np.log(0.05), np.log(0.25))))  # the scan's pitch: the larger of the two
    pitch, line_pitch = p, p
    if rng.uniform() < 0.3:
        pitch = p / 1.5
    side = min(WINDOW_PITCHES * pitch, WINDOW_MAX)
    s = side / 5.0  # hole spacing
    diameter = float(np.clip(rng.uniform(0.25, 0.4) * s, 12.0 * p, 50.0 * p))
    features = []
    for u in (-s, 0.0, s):
        for v in (-1.5 * s, 1.5 * s):
            center = (u + float(rng.uniform(-0.1, 0.1)) * s, v + float(rng.uniform(-0.1, 0.1)) * s)
            if rng.uniform() < 0.5:
                features.append(FeatureSpec(kind="through", center=center, diameter=diameter))
            else:
                angle = float(rng.choice([82.0, 90.0, 100.0]))
                depth = 0.15 * diameter
                features.append(FeatureSpec(kind="countersunk", center=center, diameter=diameter,
                                            countersink_diameter=diameter + 2.0 * depth * math.tan(math.radians(angle) / 2),
                                            countersink_angle_deg=angle))
    outer = max(f.outer_radius for f in features)
    # the slot between the rows: longer than twice the hole spacing, aspect >= 3
    length = float(rng.uniform(2.05, 2.6)) * s
    width = min(float(rng.uniform(0.3, 0.7)) * s, length / 3.0, 2.0 * (1.5 * s - outer - 0.6 - 0.1 * s))
    features.append(FeatureSpec(kind="slot", center=(0.0, 0.0), width=width, length=length,
                                direction_deg=float(rng.uniform(-5.0, 5.0))))
    # the cut-out beside them, its length across the rows
    cut_width = float(rng.uniform(0.5, 0.85)) * s
    features.append(FeatureSpec(kind="cutout", center=(2.6 * s, 0.0), width=cut_width,
                                length=float(rng.uniform(1.5, 2.8)) * s,
                                corner_radius=float(rng.uniform(0.05, 0.5)) * cut_width, direction_deg=90.0))
    # a boss, or a second slot across the rows, on the other side
    if rng.uniform() < 0.5:
        features.append(FeatureSpec(kind="boss", center=(-2.5 * s, 0.0), diameter=float(rng.uniform(0.4, 0.8)) * s,
                                    height=float(rng.uniform(0.3, 2.0))))
    else:
        slot_width = float(rng.uniform(0.3, 0.6)) * s
        features.append(FeatureSpec(kind="slot", center=(-2.5 * s, 0.0), width=slot_width,
                                    length=float(rng.uniform(3.0, 4.4)) * s, direction_deg=90.0))
    thickness = float(rng.uniform(1.5, 4.0))
    panel = build_panel(PanelSpec(width=7.2 * s, height=5.4 * s, thickness=thickness, features=tuple(features),
                                  chord_error=1e-4))
    tilt = math.radians(float(rng.uniform(0.0, 25.0)))
    noise = float(rng.choice([0.0, 0.002, 0.005, 0.01]))
    # the window: every hole inside; the cut-out, the boss and the second slot whole or cut
    line_length = 2.0 * float(rng.uniform(2.0, 3.3)) * s
    scan_length = 2.0 * float(rng.uniform(1.5 * s + outer + 3 * p + 0.3, 2.5 * s))
    spec = ProfilerSpec(target=(0.0, 0.0, 0.0), standoff=120.0, view=(0.0, math.sin(tilt), -math.cos(tilt)),
                        line=(1.0, 0.0, 0.0), line_length=line_length, scan_length=scan_length, point_pitch=pitch,
                        line_pitch=line_pitch, fan=bool(rng.integers(2)), range_noise=noise)
    description = dict(pitch=p, noise=noise, diameter=diameter, spacing=s, tilt_deg=math.degrees(tilt),
                       fan=spec.fan)
    return panel.vertices, panel.triangles, panel_truth(panel)["features"], spec, description


def _on_feature(center, feature):
    """Whether a reported center lies on a slot, cut-out or boss (within its outline, plus a mm)."""
    rel = np.asarray(center[:2]) - np.asarray(feature["center"][:2])
    if feature["kind"] == "boss":
        return float(np.hypot(*rel)) <= 0.5 * feature["diameter"] + 1.0
    direction = np.asarray(feature["direction"][:2])
    along, across = abs(float(rel @ direction)), abs(float(rel[0] * direction[1] - rel[1] * direction[0]))
    return along <= 0.5 * feature["length"] + 1.0 and across <= 0.5 * feature["width"] + 1.0


def measure(seed, **settings):
    """One scene: dict with holes expected / found / within tolerance, extra holes (and those on a
    non-hole feature), the non-hole features scanned (and cut by the border), CPU time. ``settings``
    go to :func:`holecli.pipeline.detect` (RobustSettings fields)."""
    vertices, triangles, features, spec, description = scene(seed)
    scanned = scan_part(vertices, triangles, features, spec, rng=seed)
    points = scanned.scan.points
    points = points[np.isfinite(points).all(axis=1)]
    p, sigma = description["pitch"], description["noise"]
    half_line, half_scan = 0.5 * spec.line_length, 0.5 * spec.scan_length

    def clear_of_border(hole):
        u, v = hole["center"][:2]
        reach = 0.5 * hole["diameter"] + 3.0 * p
        return abs(u) + reach <= half_line and abs(v) + reach <= half_scan

    started = time.process_time()
    detection = detect(points, settings=replace(DEFAULT_SETTINGS, **settings))
    cpu = time.process_time() - started
    unmatched = list(detection.holes)
    expected = [hole for hole in scanned.truth["holes"] if hole["inside_scan"] and clear_of_border(hole)]
    found, within, misses = 0, 0, []
    for hole in scanned.truth["holes"]:
        near = [h for h in unmatched if np.linalg.norm(np.subtract(h.center, hole["center"])) <= max(0.1, 0.5 * p)]
        if not near:
            if any(hole is e for e in expected):
                misses.append(f"d{hole['diameter']:.2f} not found")
            continue
        match = min(near, key=lambda h: np.linalg.norm(np.subtract(h.center, hole["center"])))
        unmatched.remove(match)
        if not any(hole is e for e in expected):
            continue
        found += 1
        center_error = float(np.linalg.norm(np.subtract(match.center, hole["center"])))
        diameter_error = float(match.diameter - hole["diameter"])
        ok = (center_error <= max(0.02, 0.2 * p) + 0.5 * sigma and abs(diameter_error) <= max(0.03, 0.3 * p) + sigma
              and not match.partial)
        within += ok
        if not ok:
            misses.append(f"d{hole['diameter']:.2f}: center {center_error * 1e3:.1f} um, diameter "
                          f"{diameter_error * 1e3:+.1f} um, partial {match.partial}")
    others = scanned.truth["features"]
    on_features = [h for h in unmatched if any(_on_feature(h.center, f) for f in others)]
    return dict(description, seed=seed, expected=len(expected), found=found, within=within, extra=len(unmatched),
                on_features=len(on_features), features=len(others), cut=sum(f["partial"] for f in others),
                extras=[f"d{h.diameter:.2f} at {np.round(h.center[:2], 2).tolist()}" for h in unmatched],
                misses=misses, cpu=cpu, points=len(points))


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=40, help="scenes")
    parser.add_argument("--first", type=int, default=0, help="first seed")
    parser.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                        help="a RobustSettings field for detect (e.g. max_material_dropped=1 turns that check off)")
    args = parser.parse_args(argv)
    settings = {name: float(value) for name, value in (item.split("=", 1) for item in args.set)}
    results = []
    for seed in range(args.first, args.first + args.seeds):
        r = measure(seed, **settings)
        results.append(r)
        print(f"seed {seed:3d} p {r['pitch']:.3f} noise {r['noise'] * 1e3:4.1f} um tilt {r['tilt_deg']:4.1f} "
              f"{'fan' if r['fan'] else 'par'} {r['points']:7d} pts: holes {r['within']}/{r['found']}/{r['expected']} "
              f"(within/found/expected), features {r['features']} ({r['cut']} cut), extra {r['extra']} "
              f"({r['on_features']} on them), {r['cpu']:.1f} s {'; '.join(r['misses'] + r['extras'])}", flush=True)
    expected = sum(r["expected"] for r in results)
    within = sum(r["within"] for r in results)
    features = sum(r["features"] for r in results)
    cut = sum(r["cut"] for r in results)
    extra = sum(r["extra"] for r in results)
    on = sum(r["on_features"] for r in results)
    clean = sum(r["within"] == r["expected"] and r["extra"] == 0 for r in results)
    print(f"\nholes within the tolerances: {within} of {expected}; reported on slots/cut-outs/bosses: {on} "
          f"(of {features} scanned, {cut} cut by the border); extra in all: {extra}; scenes all right: "
          f"{clean} of {len(results)}")
    return 0 if within == expected and extra == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
