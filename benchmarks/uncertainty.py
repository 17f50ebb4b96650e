"""Coverage of holecli's uncertainties: does value +- 2u hold the truth in 93-98 % of cases?

Four suites with known truth. Two are holecli's own simulators, scenes drawn per seed (never picked):

* ``synth`` (holecli.simulation.synth): a flat patch with one hole of 2-8 mm, spacing 0.02-0.1 mm,
  any pose, noise along the normal 0-30 um, with ``_inside`` 20-100 reflections in the hole; patterns
  grid, stripes (pitch 1.5-4 spacings), jittered, random;
* ``scan`` (holecli.simulation.profiler, the real-scan simulator): a built panel with a through or
  countersunk hole of 3-6 mm scanned by the laser profiler with its occlusion, range noise 0-30 um,
  1 um range quantisation and float32 output; ``scan_tilted`` views it 10-40 deg off the normal.

Two are files holecli's method terms never saw, matched to their truth by the validation scorer's
rules (``../shared/validation/score.py``, imported by path; without it these suites are skipped with a
note): a truth hole is found when a reported center lies within max(0.1 mm, 0.5 p), and only the full
holes found count:

* ``validation``: ``../shared/validation/realistic`` (51 scans of 9 CAD parts by an independent laser
  profiler model), measured without the view direction as the scorer does;
* ``cad``: clouds made from CAD meshes by ``scripts/make_cad_suite.py`` (vertices, surface sampling with
  and without walls, lattices; 0 and 5 um noise), made now in a temporary folder with the panels'
  circles in 1024 segments (each edge round within 0.05 um, so each hole has one diameter), or
  ``--cad-suite DIR``; measured with each cloud's view direction (``--view-dir``; a CAD cloud's bulk may
  lie on other faces than the holes').

The method terms of the uncertainty (holecli.robust.estimators.METHOD_TERMS) were calibrated on the
simulators' seeds 0-199; the default seeds (1000 on) are held out of the same generators, and the
validation and CAD suites are held out entirely: the table's last column says which.

Per class (and per suite and estimator) it prints the number of holes, the coverage of the interval
value +- 2u for the center (each of its two coordinates in the hole's plane: twice as many intervals as
holes) and the diameter (over the holes whose CAD edge is round within 2 um, as the scorer: a coarse
polygon has no single diameter), with the median of |error| / u (0.67 for a u that is exactly the
error's standard deviation, smaller when u is wider than needed), and, not bounded, the coverage of the
center along the normal and of the normal's direction. Then one table: per suite, holes, center and
diameter coverage, the medians, and whether that suite calibrated the method terms. Target (issue 24):
center and diameter coverage in [93 %, 98 %] on every suite. Exit status 1 when a target is missed.

Run:  python benchmarks/uncertainty.py [--suites synth,scan,validation,cad] [--seeds 30] [--jobs 2]
                                       [--cad-suite DIR] [--validation DIR] [--limit N] [--json OUT]
(about 12 minutes on 2 cores with the defaults)
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


# ---------------------------------------------------------------------------------------------------
# Suites of files with truth that holecli's method terms never saw: the validation suite and CAD clouds
# ---------------------------------------------------------------------------------------------------
SUITES = ("synth", "scan", "validation", "cad")
VALIDATION = Path(__file__).resolve().parents[2] / "shared" / "validation" / "realistic"
if not VALIDATION.exists():
    VALIDATION = Path("/work/shared/validation/realistic")
CAD_SEGMENTS = 1024  # the panels' circles of the CAD suite made here: round within 0.05 um
ROUND_MM = 0.002  # a CAD edge round within 2 um has one diameter (the validation scorer's limit)


def load_scorer(suite=None):
    """The validation scorer's module (score.py beside the suite, imported by path), or None."""
    import importlib.util

    candidates = [Path(suite).parent / "score.py"] if suite else []
    candidates.append(VALIDATION.parent / "score.py")
    for path in candidates:
        if path.exists():
            spec = importlib.util.spec_from_file_location("validation_score", path)
            module = importlib.util.module_from_spec(spec)
            spec.loader.exec_module(module)
            return module
    return None


def suite_tasks(suite_name, folder, limit=None):
    """[(suite name, scan path, case, truth)] of a folder with cases.json and NAME.truth.json files."""
    import json

    folder = Path(folder)
    cases = json.loads((folder / "cases.json").read_text())["cases"]
    tasks = [(suite_name, str(folder / c["scan"]), c, json.loads((folder / c["truth"]).read_text())) for c in cases]
    return tasks[:limit] if limit else tasks


def _plane_axes(normal):
    normal = np.asarray(normal, dtype=float) / np.linalg.norm(normal)
    first = np.cross(normal, [1.0, 0.0, 0.0] if abs(normal[0]) < 0.9 else [0.0, 1.0, 0.0])
    first /= np.linalg.norm(first)
    return normal, first, np.cross(normal, first)


def measure_file(task, view_dir=False, scorer=None):
    """Rows (one per full truth hole found) of a file with truth, matched by the validation scorer's rules.

    Returns (rows, missed): missed counts the full truth holes not found (no coverage is counted for them).
    """
    from holecli.pipeline import detect_file

    suite_name, path, case, truth = task
    scorer = scorer or load_scorer()
    view = case.get("view_dir") if view_dir else None
    detection = detect_file(path, view_dir=view)
    reported = [h for h in detection.holes]
    doc = {"holes": [{"center": list(h.center), "diameter": h.diameter, "normal": list(h.normal), "partial": h.partial,
                      "uncertainty": ({"center_in_plane": h.uncertainty.center_in_plane, "diameter": h.uncertainty.diameter}
                                      if h.uncertainty else None)} for h in reported]}
    _, per_hole, _ = scorer.score(case, truth, doc)
    scale = 1e-3 if truth.get("units") == "m" else 1.0
    rows, missed = [], 0
    name = Path(path).name.rsplit(".", 1)[0]
    for rec, t in zip(per_hole, truth["holes"]):
        if rec["status"] != "full":
            continue
        if not rec.get("found"):
            missed += 1
            continue
        # the reported hole the scorer paired with this truth hole: the closest to it with its diameter
        hole = min((h for h in reported if h.diameter == rec["diameter"]),
                   key=lambda h: np.linalg.norm(np.subtract(h.center, t["center"])))
        if hole.uncertainty is None:
            continue
        normal, first, second = _plane_axes(t["surface_normal"])
        error = np.subtract(hole.center, t["center"])
        along = float(error @ normal)
        in_plane = error - along * normal
        u = hole.uncertainty
        angle = math.degrees(math.atan2(np.linalg.norm(np.cross(hole.normal, normal)), abs(float(np.dot(hole.normal, normal)))))
        cls = _file_class(suite_name, name, case, t)
        rows.append(dict(suite=suite_name, kind=cls, scan=name, type=t.get("type"), estimator=u.estimator,
                         center=[float(in_plane @ first) / scale, float(in_plane @ second) / scale],
                         u_center=u.center_in_plane / scale, diameter=float(hole.diameter - t["edge_diameter"]) / scale,
                         u_diameter=u.diameter / scale, along=along / scale, u_along=u.center_along_normal / scale,
                         angle=angle, u_angle=u.normal_deg, edge_roundness=t.get("edge_roundness", 0.0) / scale,
                         round=t.get("edge_roundness", 0.0) / scale <= ROUND_MM, diameter_true=t["edge_diameter"] / scale,
                         noise=case.get("noise", 0.0) / scale, spacing=case.get("pitch", 0.0) / scale,
                         warnings=[w.code for w in hole.warnings], bias_correction=hole.bias_correction / scale,
                         rim_points=hole.rim_points, fit_rms=hole.fit_rms / scale))
    return rows, missed


def _file_class(suite_name, name, case, truth_hole):
    """A class of a file's hole for the per-class lines: the CAD cloud's kind, the validation scan's part."""
    if suite_name == "cad":
        tags = case.get("tags", [])
        return f"cad_{tags[0] if tags else name.split('_')[1]}" + ("_no-walls" if "no-walls" in name else "")
    return "validation_" + name.split("_t")[0]


def run_task(task):
    """One task of any suite: ("synth_grid", seed) or (suite, path, case, truth) -> (rows, missed, error).

    A file holecli cannot measure (it raises) has all its full holes missed, and the error is returned."""
    if len(task) == 2:
        row = measure(task)
        if row is None:
            return [], 1, None
        row.update(suite=task[0].split("_")[0], round=True)
        return [row], 0, None
    try:
        return (*measure_file(task, view_dir=task[0] in RUN_OPTIONS.get("view_dir", ()), scorer=RUN_OPTIONS.get("scorer")),
                None)
    except Exception as exc:  # noqa: BLE001  (holecli's refusal of a file is a result here, not a crash)
        full = sum(h.get("status", "full") == "full" for h in task[3]["holes"])
        return [], full, f"{Path(task[1]).name}: {type(exc).__name__}: {exc}"



RUN_OPTIONS = {}


def _init(options):
    RUN_OPTIONS.update(options)
    if options.get("scorer_path"):
        RUN_OPTIONS["scorer"] = load_scorer(Path(options["scorer_path"]).parent / "realistic")


def calibration_note(suite, first_seed):
    """What the uncertainty's method terms were calibrated on, relative to this suite."""
    if suite in ("synth", "scan"):
        return ("calibrated on (seeds 0-199)" if first_seed < 200
                else "held out: same generator, seeds 0-199 calibrated, these are >= 1000" if first_seed >= 1000
                else "held out: same generator, other seeds")
    return "held out: never used"


def suite_table(rows, counts, first_seed):
    """One line per suite: holes, center and diameter coverage (median |e|/u), calibration."""
    table = []
    for suite in SUITES:
        subset = [r for r in rows if r["suite"] == suite]
        if suite not in counts:
            continue
        round_ = [r for r in subset if r.get("round", True)]
        center = coverage([c for r in subset for c in r["center"]], [r["u_center"] for r in subset for _ in (0, 1)]) \
            if subset else (float("nan"), float("nan"))
        diameter = coverage([r["diameter"] for r in round_], [r["u_diameter"] for r in round_]) \
            if round_ else (float("nan"), float("nan"))
        table.append(dict(suite=suite, holes=len(subset), holes_round=len(round_), missed=counts[suite],
                          center=center[0], center_median=center[1], diameter=diameter[0],
                          diameter_median=diameter[1], calibration=calibration_note(suite, first_seed)))
    return table


def format_table(table):
    header = (f"{'suite':<11} {'holes':>6} {'center':>8} {'diameter':>14} {'median |e|/u c, d':>18}  calibration")
    lines = [header, "-" * len(header)]
    for t in table:
        lines.append(f"{t['suite']:<11} {t['holes']:>6} {t['center']:8.1%} {t['diameter']:7.1%} of {t['holes_round']:<3}"
                     f" {t['center_median']:>9.2f}, {t['diameter_median']:<6.2f}  {t['calibration']}"
                     + (f" ({t['missed']} not found)" if t["missed"] else ""))
    return "\n".join(lines)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--suites", default=",".join(SUITES), help="of synth, scan, validation, cad (default all)")
    parser.add_argument("--seeds", type=int, default=30, help="scenes per simulator class (default 30)")
    parser.add_argument("--first-seed", type=int, default=1000,
                        help="first seed (default 1000: seeds 0-199 calibrated the method terms)")
    parser.add_argument("--classes", default=",".join(CLASSES), help="simulator classes (default all)")
    parser.add_argument("--validation", default=str(VALIDATION), help="the validation suite's folder")
    parser.add_argument("--cad-suite", default=None,
                        help="a folder made by scripts/make_cad_suite.py (default: made now in a temporary folder)")
    parser.add_argument("--limit", type=int, default=None, help="first N files of each file suite (a quick look)")
    parser.add_argument("--view-dir", default="cad",
                        help="file suites whose files are measured with their viewing direction (cases.json), "
                             "comma-separated, or 'none' (default cad: a CAD cloud's bulk may lie on other faces)")
    parser.add_argument("--jobs", type=int, default=2, help="processes (default 2)")
    parser.add_argument("--json", default=None, help="write the table and every hole's errors and u to this file")
    parser.add_argument("--dump", default=None, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    suites = args.suites.split(",")
    kinds = [k for k in args.classes.split(",") if k.split("_")[0] in suites]
    tasks = [(kind, seed) for kind in kinds for seed in range(args.first_seed, args.first_seed + args.seeds)]
    notes, scorer_path, tmp = [], None, None
    if "validation" in suites or "cad" in suites:
        scorer = load_scorer(args.validation)
        scorer_path = scorer.__file__ if scorer else None
        if scorer is None:
            notes.append("validation, cad: skipped, the validation scorer (../shared/validation/score.py) is absent")
    if "validation" in suites and scorer_path:
        if (Path(args.validation) / "cases.json").exists():
            tasks += suite_tasks("validation", args.validation, args.limit)
        else:
            notes.append(f"validation: skipped, no suite at {args.validation}")
    if "cad" in suites and scorer_path:
        folder = args.cad_suite
        if folder is None:
            import subprocess
            import tempfile

            tmp = tempfile.TemporaryDirectory(prefix="holecli_cad_")
            folder = tmp.name
            subprocess.run([sys.executable, str(Path(__file__).resolve().parents[1] / "scripts" / "make_cad_suite.py"),
                            folder, "--segments", str(CAD_SEGMENTS)], check=True, stdout=subprocess.DEVNULL)
        tasks += suite_tasks("cad", folder, args.limit)
    options = {"view_dir": args.view_dir.split(","), "scorer_path": scorer_path}
    if args.jobs > 1:
        from multiprocessing import Pool

        with Pool(args.jobs, initializer=_init, initargs=(options,)) as pool:
            results = pool.map(run_task, tasks, chunksize=1)
    else:
        _init(options)
        results = [run_task(task) for task in tasks]
    if tmp is not None:
        tmp.cleanup()
    rows = [r for rs, _, _ in results for r in rs]
    notes += [f"not measured: {error}" for _, _, error in results if error]
    counts = {}
    for task, (_, missed, _) in zip(tasks, results):
        suite = task[0].split("_")[0] if len(task) == 2 else task[0]
        counts[suite] = counts.get(suite, 0) + missed
    table = suite_table(rows, counts, args.first_seed)
    if args.json or args.dump:
        import json

        Path(args.json or args.dump).write_text(json.dumps({"table": table, "notes": notes, "holes": rows}, indent=1))

    def cell(pair):
        return f"{pair[0]:6.1%} ({pair[1]:4.2f})"

    print(f"coverage of value +- {K:g}u (and median |error|/u) per class: the center's two in-plane coordinates, "
          "the diameter (of holes whose edge is round within 2 um), along the normal, the normal")
    header = (f"{'class':<34} {'holes':>6} {'center':>14} {'diameter':>14} {'along normal':>14} {'normal':>14}")
    print(header)
    print("-" * len(header))
    for kind in dict.fromkeys(r["kind"] for r in rows):
        subset = [r for r in rows if r["kind"] == kind]
        print(f"{kind:<34} {len(subset):>6} " + " ".join(f"{cell(c):>14}" for c in _summary(subset)))
    by_estimator = {}
    for r in rows:
        by_estimator.setdefault((r["suite"], r["estimator"]), []).append(r)
    print()
    for (suite, estimator), subset in sorted(by_estimator.items()):
        print(f"{suite + ' ' + estimator:<34} {len(subset):>6} " + " ".join(f"{cell(c):>14}" for c in _summary(subset)))
    print()
    print(format_table(table))
    for note in notes:
        print("note: " + note)
    missed = [f"{t['suite']} {label} {t[label]:.1%}" for t in table for label in ("center", "diameter")
              if not BAND[0] <= t[label] <= BAND[1]]
    if not table:
        print("no suite measured")
        return 1
    print(f"targets (center and diameter coverage in [{BAND[0]:.0%}, {BAND[1]:.0%}] per suite): "
          + ("met" if not missed else "MISSED: " + "; ".join(missed)))
    return 1 if missed else 0


def _summary(rows):
    """summary() with the diameter over the holes whose edge is round (the others have no one diameter)."""
    center, _, along, angle = summary(rows)
    round_ = [r for r in rows if r.get("round", True)]
    diameter = coverage([r["diameter"] for r in round_], [r["u_diameter"] for r in round_]) if round_ else (float("nan"),) * 2
    return center, diameter, along, angle


if __name__ == "__main__":
    sys.exit(main())
