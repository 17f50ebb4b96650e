"""Coverage of holecli's uncertainties: does value +- 2u hold the truth in 93-98 % of cases?

Scenes with known truth from both simulators, parameters drawn per seed (never picked):

* ``synth_*`` (holecli.simulation.synth): a flat patch with one hole of 2-8 mm, spacing 0.02-0.1 mm,
  any pose, noise along the normal 0-30 um, with ``_inside`` 20-100 reflections in the hole; patterns
  grid, stripes (pitch 1.5-4 spacings), jittered, random;
* ``scan_*`` (holecli.simulation.profiler, the real-scan simulator): a built panel with a through or
  countersunk hole of 3-6 mm scanned by the laser profiler with its occlusion, range noise 0-30 um,
  1 um range quantisation and float32 output; ``scan_tilted`` views it 10-40 deg off the normal.

Per class it prints the number of holes, the coverage of the interval value +- 2u for the center
(each of its two coordinates in the hole's plane: twice as many intervals as holes) and the diameter,
with the median of |error| / u (0.67 for a u that is exactly the error's standard deviation,
smaller when u is wider than needed), and, not bounded, the coverage of the center along the normal
and of the normal's direction. The target of issue 14: coverage of center and diameter in
[93 %, 98 %] over each simulator's scenes. Exit status 1 when a target is missed.

Run:  python benchmarks/uncertainty.py [--seeds 30] [--classes synth_grid,...] [--jobs 2]
"""

from __future__ import annotations

import argparse
import math
import os
import sys
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from holecli.pipeline import detect  # noqa: E402
from holecli.simulation.synth import HoleSpec, SceneSpec, make_scan, random_rotation  # noqa: E402

SYNTH = ("synth_grid", "synth_stripes", "synth_jittered", "synth_random", "synth_grid_inside",
         "synth_stripes_inside", "synth_random_inside")
SCAN = ("scan_through", "scan_countersunk", "scan_tilted")
CLASSES = SYNTH + SCAN
BAND = (0.93, 0.98)
K = 2.0


def synth_scene(kind, seed):
    """(points, truth hole, unit) of a synthetic-simulator scene of class ``kind``."""
    rng = np.random.default_rng([sum(map(ord, kind)), seed, 14])
    pattern = kind.split("_")[1]
    diameter = float(rng.uniform(2.0, 8.0))
    spacing = float(np.exp(rng.uniform(np.log(0.02), np.log(0.1))))
    spacing = max(spacing, diameter / 150.0)  # keep a scene under ~0.3 M points
    half = 2.0 * diameter
    noise = float(rng.uniform(0.0, 0.03))
    inside = int(rng.integers(20, 101)) if kind.endswith("_inside") else 0
    center = tuple(rng.uniform(-0.2, 0.2, 2) * diameter)
    rotation = random_rotation(rng)
    angles = _euler_deg(rotation)
    scene = SceneSpec(holes=(HoleSpec(center=center, diameter=diameter, inside_points=inside),),
                      extent=(-half, half, -half, half), spacing=spacing, pattern=pattern,
                      line_pitch=float(rng.uniform(1.5, 4.0)) * spacing if pattern == "stripes" else None,
                      scan_angle_deg=float(rng.uniform(0, 180)), grid_offset=tuple(rng.uniform(0, spacing, 2)),
                      rotation_deg=angles, translation=tuple(rng.uniform(-100, 100, 3)), noise_normal=noise)
    scan = make_scan(scene, rng)
    return scan.points, scan.truth["holes"][0], dict(noise=noise, spacing=spacing, diameter=diameter)


def _euler_deg(rotation):
    """(a, b, c) degrees with Rz(c) Ry(b) Rx(a) = rotation (holecli.simulation.synth.rotation_matrix)."""
    b = math.asin(-max(-1.0, min(1.0, rotation[2, 0])))
    a = math.atan2(rotation[2, 1], rotation[2, 2])
    c = math.atan2(rotation[1, 0], rotation[0, 0])
    return (math.degrees(a), math.degrees(b), math.degrees(c))


def scan_scene(kind, seed):
    """(points, truth hole, unit) of a real-scan-simulator scene of class ``kind``."""
    from holecli.simulation.panel import FeatureSpec, PanelSpec, build_panel, panel_truth
    from holecli.simulation.profiler import ProfilerSpec
    from holecli.simulation.scan_part import scan_part

    rng = np.random.default_rng([sum(map(ord, kind)), seed, 14])
    diameter = float(rng.uniform(3.0, 6.0))
    pitch = float(np.exp(rng.uniform(np.log(0.02), np.log(0.2))))
    pitch = max(pitch, diameter / 120.0)
    noise = float(rng.uniform(0.0, 0.03))
    thickness = float(rng.uniform(2.0, 6.0))
    feature_kind = "countersunk" if kind == "scan_countersunk" else (
        str(rng.choice(["through", "countersunk"])) if kind == "scan_tilted" else "through")
    if feature_kind == "countersunk":
        angle = float(rng.choice([82.0, 90.0, 100.0, 110.0]))
        depth = min(0.45 * thickness, 0.8)
        feature = FeatureSpec(kind="countersunk", center=(0.0, 0.0), diameter=diameter,
                              countersink_diameter=diameter + 2.0 * depth * math.tan(math.radians(angle) / 2.0),
                              countersink_angle_deg=angle)
    else:
        feature = FeatureSpec(kind="through", center=(0.0, 0.0), diameter=diameter)
    size = 8.0 * diameter
    panel = build_panel(PanelSpec(width=size, height=size, thickness=thickness, features=(feature,),
                                  chord_error=1e-4))
    view = (0.0, 0.0, -1.0)
    if kind == "scan_tilted":
        tilt = math.radians(float(rng.uniform(10.0, 40.0)))
        view = (0.0, math.sin(tilt), -math.cos(tilt))
    else:
        tilt = 0.0
    reach = 5.0 * diameter
    spec = ProfilerSpec(target=(0.0, 0.0, 0.0), standoff=100.0, view=view, line=(1.0, 0.0, 0.0), line_length=reach,
                        scan_length=reach, point_pitch=pitch, line_pitch=pitch, fan=bool(rng.integers(2)),
                        triangulation_deg=25.0, range_noise=noise, range_quantum=0.001, float32=True)
    scanned = scan_part(panel.vertices, panel.triangles, panel_truth(panel)["features"], spec, rng=seed)
    points = scanned.scan.points
    points = points[np.isfinite(points).all(axis=1)]
    truth = next(h for h in scanned.truth["holes"] if h["inside_scan"])
    return points, truth, dict(noise=noise, spacing=pitch, diameter=diameter, view_tilt_deg=math.degrees(tilt))


def measure(task):
    """Errors and uncertainties of one scene: a dict, or None when no hole matched the truth."""
    kind, seed = task
    points, truth, description = (synth_scene if kind.startswith("synth") else scan_scene)(kind, seed)
    holes = detect(points).holes
    if not holes:
        return None
    hole = min(holes, key=lambda h: np.linalg.norm(np.subtract(h.center, truth["center"])))
    error = np.subtract(hole.center, truth["center"])
    if np.linalg.norm(error) > 0.25 * truth["diameter"] or hole.uncertainty is None:
        return None
    normal = np.asarray(truth.get("normal", hole.normal), dtype=float)
    normal /= np.linalg.norm(normal)
    along = float(error @ normal)
    in_plane = error - along * normal
    first = np.cross(normal, [1.0, 0.0, 0.0] if abs(normal[0]) < 0.9 else [0.0, 1.0, 0.0])
    first /= np.linalg.norm(first)
    second = np.cross(normal, first)
    u = hole.uncertainty
    angle = math.degrees(math.atan2(np.linalg.norm(np.cross(hole.normal, normal)), abs(float(np.dot(hole.normal, normal)))))
    return dict(description, kind=kind, seed=seed, estimator=u.estimator,
                center=[float(in_plane @ first), float(in_plane @ second)], u_center=u.center_in_plane,
                diameter=float(hole.diameter - truth["diameter"]), u_diameter=u.diameter,
                along=along, u_along=u.center_along_normal, angle=angle, u_angle=u.normal_deg,
                bias_correction=hole.bias_correction, warnings=[w.code for w in hole.warnings],
                holes_found=len(holes), fit_rms=hole.fit_rms, rim_points=hole.rim_points,
                view_tilt_deg=description.get("view_tilt_deg", 0.0))


def coverage(errors, uncertainties):
    """(fraction with |e| <= K u, median |e| / u)."""
    errors, uncertainties = np.abs(np.asarray(errors, float)), np.asarray(uncertainties, float)
    ratio = errors / np.maximum(uncertainties, 1e-300)
    return float(np.mean(ratio <= K)), float(np.median(ratio))


def summary(rows):
    """Coverage and median ratios of the center (two coordinates), diameter, along-normal and normal."""
    center = coverage([c for r in rows for c in r["center"]], [r["u_center"] for r in rows for _ in (0, 1)])
    diameter = coverage([r["diameter"] for r in rows], [r["u_diameter"] for r in rows])
    along = coverage([r["along"] for r in rows], [r["u_along"] for r in rows])
    # the normal's angle error is the length of a 2D tilt: compare with K u along its worse axis
    angle = coverage([r["angle"] for r in rows], [r["u_angle"] for r in rows])
    return center, diameter, along, angle


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=30, help="scenes per class (default 30)")
    parser.add_argument("--first-seed", type=int, default=1000,
                        help="first seed (default 1000: seeds 0-199 calibrated the method terms)")
    parser.add_argument("--classes", default=",".join(CLASSES))
    parser.add_argument("--jobs", type=int, default=2, help="processes (default 2)")
    parser.add_argument("--dump", default=None, help="write every scene's errors and u to this JSON file")
    args = parser.parse_args(argv)
    kinds = args.classes.split(",")
    tasks = [(kind, seed) for kind in kinds for seed in range(args.first_seed, args.first_seed + args.seeds)]
    if args.jobs > 1:
        from multiprocessing import Pool

        with Pool(args.jobs) as pool:
            results = pool.map(measure, tasks, chunksize=1)
    else:
        results = [measure(task) for task in tasks]
    rows = [r for r in results if r is not None]
    if args.dump:
        import json

        Path(args.dump).write_text(json.dumps(rows))
    print(f"coverage of value +- {K:g}u (and median |error|/u) over {args.seeds} scenes per class")
    header = (f"{'class':<22} {'holes':>6} {'center':>14} {'diameter':>14} {'along normal':>14} {'normal':>14}")
    print(header)
    print("-" * len(header))

    def cell(pair):
        return f"{pair[0]:6.1%} ({pair[1]:4.2f})"

    for kind in kinds:
        subset = [r for r in rows if r["kind"] == kind]
        missing = sum(1 for task, r in zip(tasks, results) if task[0] == kind and r is None)
        if not subset:
            print(f"{kind:<22} {0:>6}")
            continue
        print(f"{kind:<22} {len(subset):>6} " + " ".join(f"{cell(c):>14}" for c in summary(subset))
              + (f"   ({missing} not measured)" if missing else ""))
    print()
    missed = []
    for name, prefix in (("synthetic simulator", "synth"), ("real-scan simulator", "scan")):
        subset = [r for r in rows if r["kind"].startswith(prefix)]
        if not subset:
            continue
        center, diameter, along, angle = summary(subset)
        print(f"{name:<22} {len(subset):>6} " + " ".join(f"{cell(c):>14}" for c in (center, diameter, along, angle)))
        for label, (value, _) in (("center", center), ("diameter", diameter)):
            if not BAND[0] <= value <= BAND[1]:
                missed.append(f"{name} {label} {value:.1%}")
    by_estimator = {}
    for r in rows:
        by_estimator.setdefault(r["estimator"], []).append(r)
    print()
    for estimator, subset in sorted(by_estimator.items()):
        center, diameter, along, angle = summary(subset)
        print(f"estimator {estimator:<12} {len(subset):>6} " + " ".join(f"{cell(c):>14}" for c in (center, diameter, along, angle)))
    print()
    print(f"targets (center and diameter coverage in [{BAND[0]:.0%}, {BAND[1]:.0%}] per simulator): "
          + ("met" if not missed else "MISSED: " + "; ".join(missed)))
    return 1 if missed else 0


if __name__ == "__main__":
    sys.exit(main())
