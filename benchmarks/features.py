"""The whole drilled hole: countersink, counterbore, bore, floor, axis and perpendicularity on profiler scans.

Every scene is a panel (holecli.simulation.panel) with one hole at its middle, scanned by the laser
profiler (holecli.simulation.profiler) over a region of 3 outer diameters around it, with occlusion
(the camera 25 deg from the laser), 1 um range quantisation and float32 output. Drawn per seed, not
picked: the hole's kind (classes ``cs82``, ``cs90``, ``cs100``, ``cs110``: countersunk at that included
angle; ``counterbored``, ``blind``, ``through``), its diameter (3-6 mm), the sheet's thickness (3-6 mm),
the angle it was drilled off the normal (0, 2 or 5 deg, toward any direction), the sensor's tilt from
the normal (0-40 deg, any direction), the pitch (0.03-0.1 mm) and the range noise (0, 2, 5 or 10 um):
the conditions of issue 12's targets. Two more classes draw the hole's kind too: ``curved``, on a
convex or concave sheet of R 500-2000 mm, and ``robot_frame``, the scan in metres in a robot's base
frame (any heading, tilted up to 45 deg, 1-2 m from the origin). ``mesh``: the panel written as an STL
file and scanned by the command a user runs, ``holecli simulate panel --mesh``, its truth read off the mesh
(``holecli.simulation.mesh_truth``; holes drilled along the normal, as that truth needs circular loops).

Per class it prints the holes found and typed right. Then, per measured value, over every scene that
has it: how many scenes gave it (a value the points cannot support is null, with a warning), the
median and worst error, the target and whether it is met (median within the target, every case within
3 x the target). Bore diameters count where the scan saw at least 90 deg of the wall (holecli reports
null otherwise). Exit status 1 when a target is missed.

Run:  python benchmarks/features.py [--seeds 4] [--classes cs82,cs90,...] [--docs]

``--docs`` writes the table into its block of docs/method/robust.md (``--docs-page PATH``: another page).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from benchmarks._docs_table import add_docs_options, docs_target, recording  # noqa: E402
from holecli.io import read_cloud  # noqa: E402
from holecli.pipeline import detect  # noqa: E402
from holecli.simulation.panel import FeatureSpec, PanelSpec, build_panel, panel_truth  # noqa: E402
from holecli.simulation.profiler import ProfilerSpec  # noqa: E402
from holecli.simulation.scan_part import scan_part  # noqa: E402
from realistic import robot_frame  # noqa: E402  (benchmarks/, the script's folder, is on the path)

CLASSES = ("cs82", "cs90", "cs100", "cs110", "counterbored", "blind", "through", "curved", "robot_frame", "mesh")
EXPECTED_TYPE = {"counterbored": "counterbored", "blind": "blind", "through": "through"}
# value: (target, unit label, scale from mm to the unit)
TARGETS = {
    "countersink angle": (0.5, "deg", 1.0),
    "countersink depth": (10.0, "um", 1e3),
    "countersink diameter": (10.0, "um", 1e3),
    "counterbore depth": (10.0, "um", 1e3),
    "floor depth": (10.0, "um", 1e3),
    "bore diameter": (10.0, "um", 1e3),
    "perpendicularity": (0.1, "deg", 1.0),
}


def scene(kind, seed, drill_tilt=None):
    """(panel, ProfilerSpec, description) of one scene of class ``kind`` (``drill_tilt``: instead of the
    drawn angle off the normal)."""
    rng = np.random.default_rng([sum(map(ord, kind)), seed, 12])
    diameter = float(rng.uniform(3.0, 6.0))
    thickness = float(rng.uniform(3.0, 6.0))
    curvature, radius, frame, scale = "flat", None, None, 1.0
    if kind in ("curved", "robot_frame"):
        if kind == "curved":
            curvature, radius = str(rng.choice(["convex", "concave"])), float(rng.uniform(500.0, 2000.0))
        else:
            frame, scale = robot_frame(rng, np.pi / 4)
        kind = str(rng.choice(CLASSES[:7]))
    drawn_tilt = float(rng.choice([0.0, 2.0, 5.0]))
    drill_tilt = drawn_tilt if drill_tilt is None else drill_tilt
    drill_direction = float(rng.uniform(0.0, 360.0))
    tilt = {"tilt_deg": drill_tilt, "tilt_direction_deg": drill_direction}
    if kind.startswith("cs"):
        angle = float(kind[2:])
        depth = float(rng.uniform(0.6, 1.0)) * min(0.45 * thickness, 1.2)
        feature = FeatureSpec(kind="countersunk", center=(0.0, 0.0), diameter=diameter,
                              countersink_diameter=diameter + 2.0 * depth * math.tan(math.radians(angle) / 2.0),
                              countersink_angle_deg=angle, **tilt)
        outer = feature.countersink_diameter
    elif kind == "counterbored":
        feature = FeatureSpec(kind="counterbored", center=(0.0, 0.0), diameter=diameter,
                              counterbore_diameter=float(rng.uniform(1.4, 1.8)) * diameter,
                              counterbore_depth=float(rng.uniform(0.2, 0.4)) * thickness, **tilt)
        outer = feature.counterbore_diameter
    elif kind == "blind":
        feature = FeatureSpec(kind="blind", center=(0.0, 0.0), diameter=diameter,
                              depth=float(rng.uniform(0.3, 0.7)) * thickness, **tilt)
        outer = diameter
    else:
        feature = FeatureSpec(kind="through", center=(0.0, 0.0), diameter=diameter, **tilt)
        outer = diameter
    size = 6.0 * outer
    panel = build_panel(PanelSpec(width=size, height=size, thickness=thickness, curvature=curvature, radius=radius,
                                  features=(feature,), chord_error=1e-4))
    view_tilt = math.radians(float(rng.uniform(0.0, 40.0)))
    azimuth = float(rng.uniform(0.0, 2.0 * math.pi))
    view = (math.sin(view_tilt) * math.cos(azimuth), math.sin(view_tilt) * math.sin(azimuth), -math.cos(view_tilt))
    # the laser line perpendicular to the view
    line = np.cross(view, (math.sin(azimuth), -math.cos(azimuth), 0.0))
    line = tuple(line / np.linalg.norm(line))
    pitch = float(np.exp(rng.uniform(np.log(0.03), np.log(0.1))))
    reach = 3.0 * outer
    pitch = max(pitch, reach / 400.0)  # keep a scene under ~0.2 M rays
    noise = float(rng.choice([0.0, 0.002, 0.005, 0.01]))
    spec = ProfilerSpec(target=(0.0, 0.0, 0.0), standoff=100.0, view=view, line=line, line_length=reach,
                        scan_length=reach, point_pitch=pitch, line_pitch=pitch, fan=bool(rng.integers(2)),
                        triangulation_deg=25.0, range_noise=noise, range_quantum=0.001, frame=frame,
                        unit_scale=scale, float32=True)
    description = dict(pitch=pitch, noise=noise, diameter=diameter, drill_tilt=drill_tilt,
                       view_tilt=math.degrees(view_tilt), kind=kind, curvature=curvature, unit_scale=scale)
    return panel, spec, description


def errors_of(hole, truth, scale=1.0):
    """(name, measured - true in mm or degrees) of every value the hole gives that the truth has
    (``scale``: file units per mm)."""
    out = []
    cs = hole.countersink
    if truth["kind"] == "countersunk" and cs is not None:
        if cs.angle_deg is not None:
            out.append(("countersink angle", cs.angle_deg - truth["countersink_angle_deg"]))
        if cs.diameter is not None:
            true_diameter = truth.get("countersink_diameter") or truth["diameter"]  # the mesh truth's edge
            out.append(("countersink diameter", (cs.diameter - true_diameter) / scale))
        if cs.depth is not None:
            out.append(("countersink depth", (cs.depth - truth["countersink_depth"]) / scale))
    if truth["kind"] == "counterbored" and hole.counterbore is not None:
        out.append(("counterbore depth", (hole.counterbore.depth - truth["counterbore_depth"]) / scale))
    if truth["kind"] == "blind" and hole.bore is not None and hole.bore.floor_depth is not None:
        out.append(("floor depth", (hole.bore.floor_depth - truth["floor_depth"]) / scale))
    if hole.bore is not None and hole.bore.diameter is not None:
        out.append(("bore diameter", (hole.bore.diameter - truth["bore_diameter"]) / scale))
    if hole.perpendicularity_deg is not None:
        true_axis = np.asarray(truth["axis"])
        axis = np.asarray(hole.axis)
        # the axis's direction error, and the perpendicularity's
        normal = np.asarray(truth["normal"])
        true_perpendicularity = math.degrees(math.acos(min(1.0, abs(float(true_axis @ normal)))))
        out.append(("perpendicularity", hole.perpendicularity_deg - true_perpendicularity))
        out.append(("axis direction", math.degrees(math.acos(min(1.0, abs(float(axis @ true_axis)))))))
    return out


def measure_mesh(seed):
    """The ``mesh`` class: a panel of any kind exported as an STL file and scanned by the real command,
    ``holecli simulate panel --mesh``, whose truth is what ``holecli.simulation.mesh_truth`` reads off the
    mesh alone (drilled along the normal: the mesh truth needs circular loops)."""
    import open3d as o3d

    rng = np.random.default_rng([seed, 77])
    kind = str(rng.choice(CLASSES[:7]))
    panel, spec, description = scene(kind, seed, drill_tilt=0.0)
    with tempfile.TemporaryDirectory(prefix="holecli-features-") as folder:
        part, scan = Path(folder) / "part.stl", Path(folder) / "scan.ply"
        mesh = o3d.geometry.TriangleMesh(o3d.utility.Vector3dVector(panel.vertices),
                                         o3d.utility.Vector3iVector(panel.triangles.astype(np.int32)))
        mesh.compute_triangle_normals()
        o3d.io.write_triangle_mesh(str(part), mesh)
        vector = lambda v: ",".join(f"{x:.12g}" for x in v)  # noqa: E731
        command = [sys.executable, "-m", "holecli", "simulate", "panel", str(scan), "--mesh", str(part),
                   "--spacing", f"{spec.point_pitch:.12g}", "--line-pitch", f"{spec.line_pitch:.12g}",
                   "--view", vector(spec.view), "--line", vector(spec.line), "--target", "0,0,0",
                   "--line-length", f"{spec.line_length:.12g}", "--scan-length", f"{spec.scan_length:.12g}",
                   "--range-noise", f"{spec.range_noise:.12g}", "--range-quantum", "0.001", "--seed", str(seed)]
        if not spec.fan:
            command.append("--parallel-rays")
        subprocess.run(command, check=True, capture_output=True, cwd=ROOT,
                       env=dict(os.environ, PYTHONPATH=str(ROOT)))
        points = read_cloud(scan).points
        truths = json.loads(scan.with_suffix(".truth.json").read_text())["holes"]
    return _score(points, truths[0] if truths else None, dict(description, kind=kind))


def measure(kind, seed):
    if kind == "mesh":
        return measure_mesh(seed)
    panel, spec, description = scene(kind, seed)
    truth = panel_truth(panel)["features"][0]
    scanned = scan_part(panel.vertices, panel.triangles, [truth], spec, rng=seed)
    points = scanned.scan.points
    points = points[np.isfinite(points).all(axis=1)]
    return _score(points, scanned.truth["holes"][0], description)


def _score(points, true_scan, description):
    """Detect the holes of ``points`` and score the one nearest the truth's center."""
    if true_scan is None:
        return dict(description, found=False, typed=False, type=None, errors=[], warnings=[], notes=[], cpu=0.0,
                    points=len(points))
    started = time.process_time()
    detection = detect(points)
    cpu = time.process_time() - started
    match = min(detection.holes, key=lambda h: np.linalg.norm(np.subtract(h.center, true_scan["center"])), default=None)
    if match is not None and np.linalg.norm(np.subtract(match.center, true_scan["center"])) > 0.5 * true_scan["diameter"]:
        match = None
    expected_type = EXPECTED_TYPE.get(description["kind"], "countersunk")
    return dict(description, found=match is not None, typed=match is not None and match.type == expected_type,
                type=None if match is None else match.type,
                errors=[] if match is None else errors_of(match, true_scan, description["unit_scale"]),
                warnings=[] if match is None else [w.code for w in match.warnings],
                notes=[] if match is None else [note.code for note in match.notes], cpu=cpu, points=len(points))


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=4, help="scenes per class")
    parser.add_argument("--classes", default=",".join(CLASSES))
    parser.add_argument("--verbose", action="store_true", help="print every scene")
    add_docs_options(parser, ROOT / "docs" / "method" / "robust.md")
    args = parser.parse_args(argv)
    docs = docs_target(parser, args, argv, "features.py", ["features"])
    with recording() as printed:
        collected = {}
        print(f"{'class':<13} {'found':>6} {'typed':>6} {'cpu s':>6}  warnings | notes")
        for kind in args.classes.split(","):
            rows = [measure(kind, seed) for seed in range(args.seeds)]
            for seed, row in enumerate(rows):
                for name, error in row["errors"]:
                    collected.setdefault(name, []).append((error, kind, seed))
                if args.verbose:
                    print(f"  {kind} seed {seed}: {row['type']} pitch {row['pitch']:.3f} noise {row['noise']:.3f} "
                          f"view {row['view_tilt']:.0f} drill {row['drill_tilt']:.0f} "
                          + " ".join(f"{n}={e:+.4f}" for n, e in row["errors"]) + f" {row['warnings']} {row['notes']}")
            warnings = sorted({code for row in rows for code in row["warnings"]})
            notes = sorted({code for row in rows for code in row["notes"]})
            print(f"{kind:<13} {sum(r['found'] for r in rows):>3}/{len(rows):<2} {sum(r['typed'] for r in rows):>3}/{len(rows):<2} "
                  f"{np.median([r['cpu'] for r in rows]):>6.2f}  {', '.join(warnings) or 'none'} | {', '.join(notes)}",
                  flush=True)
        print()
        print(f"{'value':<21} {'scenes':>6} {'median':>9} {'worst':>9} {'target':>8}  met")
        missed = False
        for name, (target, unit, scale) in TARGETS.items():
            values = collected.get(name, [])
            if not values:
                print(f"{name:<21} {0:>6}")
                continue
            errors = np.abs([v[0] for v in values]) * scale
            median, worst = float(np.median(errors)), float(np.max(errors))
            met = median <= target and worst <= 3.0 * target
            missed |= not met
            print(f"{name:<21} {len(values):>6} {median:>7.3f} {unit:<2}{worst:>7.3f} {unit:<2}{target:>5g} {unit:<3} "
                  f"{'yes' if met else 'NO'}")
        values = collected.get("axis direction", [])
        if values:
            errors = np.abs([v[0] for v in values])
            print(f"{'(axis direction)':<21} {len(values):>6} {np.median(errors):>7.3f} deg{np.max(errors):>6.3f} deg")
    if docs:
        docs.write("features", printed.text)
    return 1 if missed else 0


if __name__ == "__main__":
    sys.exit(main())
