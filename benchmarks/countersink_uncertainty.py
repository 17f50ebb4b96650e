"""Coverage of the countersink's (and counterbore's) uncertainties: does value +- 2u hold the truth?

benchmarks/uncertainty.py covers a hole's center and edge diameter; this one covers the values below
the edge (issue 25): the countersink's diameter, included angle and depth, and the counterbore's depth
(its diameter is the edge's) and the bore's diameter where the lots show one, on sources with known truth:

* ``lot0``: lots of ``sample_clouds/panel.toml`` made by ``holecli simulate lot`` (the laser
  profiler ray-casting a panel whose circles have the default 0.1 um chord error), no range noise;
  part seeds 100 on (``--first-seed``);
* ``scan0`` / ``scan_noisy``: one countersunk hole of 3-6 mm (angle 82-110 deg, 64-2048 segments, view
  tilted 0-50 deg, pitch 0.02-0.15 mm) scanned by the profiler, range noise 0 / 2-10 um;
* ``cad64`` / ``cad1024``: folders made by ``scripts/make_cad_suite.py DIR --segments N`` (``--cad``);
  measured with each cloud's view direction;
* ``validation``: ``../shared/validation/realistic``, the scans whose truth has a countersink.

For each source and value: the number of holes, the coverage of value +- 2u, the median |error| / u
(0.67 when u is the error's standard deviation) and the median u. The truth of a faceted countersink
is the panel's nominal circle through the polygon's vertices (simulator) or the mesh truth's
``edge_diameter`` (file suites: the least-squares circle of the faceted edge), and ``csk_diam_vertices``
the circle through the vertices (a CAD model's nominal).

Run:  python benchmarks/countersink_uncertainty.py [--sources lot0,scan0,scan_noisy,cad64,cad1024,validation]
                                                   [--seeds 20] [--cad DIR64,DIR1024] [--json OUT]
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from holecli.pipeline import detect, detect_file  # noqa: E402

VALIDATION = ROOT.parent.parent / "shared" / "validation" / "realistic"
if not VALIDATION.exists():
    VALIDATION = Path("/work/shared/validation/realistic")
K = 2.0
VALUES = ("csk_diameter", "csk_diam_vertices", "csk_angle", "csk_depth", "cbore_depth", "bore_diameter")


def _nearest(holes, center, scale=1.0):
    if not holes:
        return None
    return min(holes, key=lambda h: np.linalg.norm(np.subtract(h.center, center) / scale))


def _rows_of(hole, truth, scale=1.0):
    """{value: (error, u)} of one measured hole against its truth (file units / scale -> mm)."""
    rows = {}
    u = hole.uncertainty
    if hole.countersink is not None and u is not None and u.countersink is not None:
        cs, uc = hole.countersink, u.countersink
        pairs = (("csk_diameter", cs.diameter, truth.get("countersink_diameter"), uc.diameter, scale),
                 ("csk_angle", cs.angle_deg, truth.get("countersink_angle_deg"), uc.angle_deg, 1.0),
                 ("csk_depth", cs.depth, truth.get("countersink_depth"), uc.depth, scale))
        for name, value, true, unc, s in pairs:
            if value is not None and true is not None and unc is not None:
                rows[name] = ((value - true * s) / s, unc / s)
        vertices = truth.get("edge_diameter_vertices")
        if cs.diameter is not None and vertices is not None and uc.diameter is not None:
            rows["csk_diam_vertices"] = ((cs.diameter - vertices * scale) / scale, uc.diameter / scale)
    if hole.counterbore is not None and u is not None and u.counterbore is not None:
        true = truth.get("counterbore_depth")
        if hole.counterbore.depth is not None and true is not None and u.counterbore.depth is not None:
            rows["cbore_depth"] = ((hole.counterbore.depth - true * scale) / scale, u.counterbore.depth / scale)
    if hole.bore is not None and hole.bore.diameter is not None and u is not None and u.bore is not None:
        true = truth.get("bore_diameter")
        if true is not None and u.bore.diameter is not None:
            rows["bore_diameter"] = ((hole.bore.diameter - true * scale) / scale, u.bore.diameter / scale)
    return rows


def lot_rows(seed, noise=0.0):
    """Rows of one 4-part lot of sample_clouds/panel.toml made by ``holecli simulate lot``."""
    out = []
    with tempfile.TemporaryDirectory() as tmp:
        lot = Path(tmp) / "lot"
        subprocess.run([sys.executable, "-m", "holecli", "simulate", "lot", str(lot), "--parts", "4", "--panel",
                        str(ROOT / "sample_clouds" / "panel.toml"), "--seed", str(seed), "--range-noise", str(noise),
                        "-q"], check=True, capture_output=True, env={**os.environ, "PYTHONPATH": str(ROOT)})
        for truth_file in sorted(lot.glob("part_*.truth.json")):
            truth = json.loads(truth_file.read_text())
            holes = detect_file(str(truth_file).replace(".truth.json", ".ply")).holes
            for t in truth["holes"]:
                if t.get("kind") not in ("countersunk", "counterbored", "through", "blind") or not t.get("inside_scan"):
                    continue
                hole = _nearest(holes, t["center"])
                if hole is None or np.linalg.norm(np.subtract(hole.center, t["center"])) > 0.25 * t["diameter"]:
                    continue
                out.append(dict(seed=seed, scan=truth_file.name, **{k: v for k, v in _rows_of(hole, t).items()}))
    return out


def scan_rows(seed, noisy):
    """Rows of one profiler scene with one countersunk hole (see the module docstring)."""
    from holecli.simulation.panel import FeatureSpec, PanelSpec, build_panel, panel_truth
    from holecli.simulation.profiler import ProfilerSpec
    from holecli.simulation.scan_part import scan_part

    rng = np.random.default_rng([25, seed, 7 if noisy else 0])
    diameter = float(rng.uniform(3.0, 6.0))
    pitch = float(np.exp(rng.uniform(np.log(0.02), np.log(0.15))))
    noise = float(rng.uniform(0.002, 0.010)) if noisy else 0.0
    thickness = float(rng.uniform(2.0, 5.0))
    angle = float(rng.choice([82.0, 90.0, 100.0, 110.0]))
    depth = float(rng.uniform(0.4, 0.45 * thickness))
    segments = int(rng.choice([64, 128, 320, 1024, 2048]))
    feature = FeatureSpec(kind="countersunk", center=(0.0, 0.0), diameter=diameter,
                          countersink_diameter=diameter + 2.0 * depth * math.tan(math.radians(angle) / 2.0),
                          countersink_angle_deg=angle)
    size = 8.0 * diameter
    panel = build_panel(PanelSpec(width=size, height=size, thickness=thickness, features=(feature,),
                                  segments=segments))
    tilt = math.radians(float(rng.uniform(0.0, 50.0)))
    view = (0.0, math.sin(tilt), -math.cos(tilt))
    reach = 4.0 * diameter
    spec = ProfilerSpec(target=(0.0, 0.0, 0.0), standoff=100.0, view=view, line=(1.0, 0.0, 0.0), line_length=reach,
                        scan_length=reach, point_pitch=pitch, line_pitch=pitch, fan=bool(rng.integers(2)),
                        triangulation_deg=25.0, range_noise=noise, range_quantum=0.001 if noisy else 0.0,
                        float32=bool(noisy))
    scanned = scan_part(panel.vertices, panel.triangles, panel_truth(panel)["features"], spec, rng=seed)
    points = scanned.scan.points
    points = points[np.isfinite(points).all(axis=1)]
    truth = next(h for h in scanned.truth["holes"] if h["inside_scan"])
    holes = detect(points).holes
    hole = _nearest(holes, truth["center"])
    if hole is None or np.linalg.norm(np.subtract(hole.center, truth["center"])) > 0.25 * truth["diameter"]:
        return []
    return [dict(seed=seed, scan=f"segments={segments} pitch={pitch:.3f} tilt={math.degrees(tilt):.0f}",
                 **_rows_of(hole, truth))]


def file_rows(folder, view_dir, only=""):
    """Rows of every countersink in a folder with cases.json and NAME.truth.json (validation format)."""
    folder = Path(folder)
    cases = json.loads((folder / "cases.json").read_text())["cases"]
    out = []
    for case in cases:
        if only not in case["scan"]:
            continue
        truth = json.loads((folder / case["truth"]).read_text())
        wanted = [t for t in truth["holes"] if t.get("status", "full") == "full"
                  and t.get("countersink_angle_deg") is not None]
        if not wanted:
            continue
        scale = 1e-3 if truth.get("units") == "m" else 1.0
        try:
            holes = detect_file(str(folder / case["scan"]), view_dir=case.get("view_dir") if view_dir else None).holes
        except Exception as error:  # noqa: BLE001 - a file holecli refuses has no rows
            print(f"  {case['scan']}: {error}", file=sys.stderr)
            continue
        for t in wanted:
            hole = _nearest(holes, t["center"], scale)
            if hole is None or np.linalg.norm(np.subtract(hole.center, t["center"])) > 0.25 * t["edge_diameter"]:
                continue
            t = dict(t, countersink_diameter=t["edge_diameter"])
            out.append(dict(scan=case["scan"], **_rows_of(hole, t, scale)))
    return out


def table(rows):
    """{value: (n, coverage, median |e|/u, median u)}."""
    out = {}
    for name in VALUES:
        pairs = [r[name] for r in rows if name in r]
        if not pairs:
            continue
        e = np.abs([p[0] for p in pairs])
        u = np.array([p[1] for p in pairs])
        ratio = e / np.maximum(u, 1e-300)
        out[name] = (len(pairs), float(np.mean(ratio <= K)), float(np.median(ratio)), float(np.median(u)))
    return out


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--sources", default="lot0,scan0,scan_noisy,cad64,cad1024,validation")
    parser.add_argument("--seeds", type=int, default=20, help="lots (4 parts each) / scenes per simulated source")
    parser.add_argument("--first-seed", type=int, default=100)
    parser.add_argument("--cad", default="", help="DIR64,DIR1024: folders made by scripts/make_cad_suite.py")
    parser.add_argument("--cad-only", default="_s0", help="measure the CAD clouds whose name contains this")
    parser.add_argument("--json", default=None, help="write every row to this file")
    options = parser.parse_args(argv)
    cad = dict(zip(("cad64", "cad1024"), options.cad.split(","))) if options.cad else {}
    seeds = range(options.first_seed, options.first_seed + options.seeds)
    everything = {}
    for source in options.sources.split(","):
        if source == "lot0":
            rows = [r for s in seeds for r in lot_rows(s)]
        elif source in ("scan0", "scan_noisy"):
            rows = [r for s in seeds for r in scan_rows(s, source == "scan_noisy")]
        elif source in ("cad64", "cad1024"):
            if source not in cad:
                print(f"{source}: skipped (no --cad folder)")
                continue
            rows = file_rows(cad[source], view_dir=True, only=options.cad_only)
        elif source == "validation":
            rows = file_rows(VALIDATION, view_dir=False)
        else:
            parser.error(f"unknown source {source}")
        everything[source] = rows
        for name, (n, cov, ratio, u) in table(rows).items():
            print(f"{source:11s} {name:13s} n={n:4d}  coverage(k=2)={100 * cov:5.1f} %  "
                  f"median|e|/u={ratio:9.3g}  median u={u:.3g}", flush=True)
    if options.json:
        Path(options.json).write_text(json.dumps(everything, indent=1))


if __name__ == "__main__":
    main()
