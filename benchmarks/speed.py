"""Speed and memory of holecli at every size, beside the paper's Table II and a global Delaunay.

For the paper's Table II sizes (416, 1,572, 6,733 and 9,498 points: the Table I scene at spacings
that give those counts) and for laser-stripe scans of 10^5, 10^6 and 10^7 points with five holes of
3 to 9 mm, each size runs in a fresh child process, which

* writes the scan as a binary PLY and reads it back with ``holecli.read_cloud`` (load time),
* runs ``holecli.detect`` on the loaded points several times (pipeline time: the median),
* times one global ``scipy.spatial.Delaunay`` of the same projected points (up to 10^6 points), the
  first step of the paper's segmentation, in the same process,
* reports its peak resident memory (``ru_maxrss``, which includes the Python interpreter and the
  libraries: about 100 MB before any data).

The table's "cpu s" is the pipeline's median CPU time (``time.process_time``: the machine's other load
disturbs it less than the wall time beside it), and "exponent" the scaling exponent
``log(t2 / t1) / log(n2 / n1)`` of that CPU time against the previous size of the same scan (1: linear).
Its "cad" row is a ray-cast CAD scan: ``holecli simulate panel --panel sample_clouds/panel.toml`` at
0.05 mm pitch, noise-free, float32 (about 915,000 points, 4 holes), and its "plate" row trimesh's
plate_holes.STL on a noise-free exact 0.25 mm lattice straight down (978k points, 5 holes;
``benchmarks/plate_speed.py``). ``benchmarks/pattern_speed.py`` has grid, stripes and random sampling
per size.

Also prints the load time of a 10^6-point binary PCD and a 10^6-row CSV, the time of
``import holecli`` and of ``holecli --help``, whether either imports open3d or matplotlib, and the
CPU time of a whole ``holecli detect sample_clouds/table1.ply`` process split into the interpreter's
start, the imports, the load, ``detect`` and the rest (output, exit), and the CPU of whole
``holecli detect`` processes on 10^4-point PLYs sampled as a grid, stripes and at random. The whole
processes run byte-compiled (``PYTHONPYCACHEPREFIX``, filled by a first run), as an installed holecli does.

With ``--baseline REV`` every figure is also measured on that git revision of holecli (checked out into
a temporary worktree), each case right after the current code's, with the same scans, and the ratio
baseline / current is printed: a same-run comparison on a shared machine.

Run:  python benchmarks/speed.py [--max-points 10000000] [--baseline REV] [--docs]

``--docs`` writes the table into its block of docs/validation/speed.md (``--docs-page PATH``: another page).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from benchmarks._baseline import baseline_checkout  # noqa: E402
from benchmarks._docs_table import VALIDATION, add_docs_options, docs_target, recording  # noqa: E402

# The paper's Table II: points -> seconds (MATLAB, one thread of an i7-6700).
PAPER_TABLE_II = {416: 0.20, 1572: 0.62, 6733: 2.72, 9498: 4.03}


def table1_like(points):
    """The Table I scene with the spacing that gives about ``points`` points."""
    from holecli.simulation.synth import table1_scene

    area = 64.0 - np.pi * 1.5**2
    spacing = float(np.sqrt(area / points))
    scene = table1_scene(0.1)
    from dataclasses import replace

    return replace(scene, spacing=spacing, noise_world_z=0.1 * spacing)


def stripes_scan(points):
    """A laser-stripe scan of about ``points`` points with five holes of 3 to 9 mm, 1 m from the origin."""
    from holecli.simulation.synth import HoleSpec, SceneSpec

    # 80 x 20 mm patch, scan lines 4 point spacings apart.
    spacing = float(np.sqrt(80.0 * 20.0 / points / 4.0))
    holes = tuple(HoleSpec((x, 0.0), d) for x, d in [(-30, 3.0), (-15, 4.5), (0, 6.0), (15, 7.5), (30, 9.0)])
    return SceneSpec(holes=holes, extent=(-40.0, 40.0, -10.0, 10.0), spacing=spacing, pattern="stripes",
                     line_pitch=4.0 * spacing, rotation_deg=(10.0, 5.0, 30.0), translation=(769.0, -83.6, 218.8),
                     noise_world_z=0.1 * spacing)


def cad_scan(path):
    """``holecli simulate panel``: the laser profiler's ray-cast scan of ``sample_clouds/panel.toml``
    (through, countersunk, counterbored and blind holes, a slot, a boss) at 0.05 mm pitch and profile
    pitch, noise-free, in float32 and in a robot base frame 1.2 m out: about 915,000 points, 4 holes."""
    command = [sys.executable, "-m", "holecli", "simulate", "panel", path, "--panel", str(ROOT / "sample_clouds" / "panel.toml"),
               "--spacing", "0.05", "--line-pitch", "0.05", "--translation", "1200,-300,800"]
    subprocess.run(command, check=True, capture_output=True, env=dict(os.environ, PYTHONPATH=str(ROOT)))


def child(size, kind, repeats, delaunay, source=None):
    """Measure one size in this (fresh) process, with the holecli of ``source`` (a folder; None: this
    checkout's), and print a JSON line."""
    if source:
        sys.path.insert(0, str(source))
    from scipy.spatial import Delaunay

    from holecli import detect, read_cloud
    from holecli.geometry.frame import rotation_to_z, to_plane_frame
    from holecli.io import save_points
    from holecli.simulation.synth import make_scan

    with tempfile.TemporaryDirectory() as folder:
        path = os.path.join(folder, "scan.ply")
        if kind == "cad":
            cad_scan(path)
        elif kind == "plate":
            from benchmarks.plate_speed import plate_points

            save_points(path, plate_points(0.25))
        else:
            scene = table1_like(size) if kind == "table1" else stripes_scan(size)
            save_points(path, make_scan(scene, 0).points)
        started = time.perf_counter()
        cloud = read_cloud(path)
        load = time.perf_counter() - started
    times, cpu = [], []
    for _ in range(repeats):
        started, started_cpu = time.perf_counter(), time.process_time()
        detection = detect(cloud.points)
        times.append(time.perf_counter() - started)
        cpu.append(time.process_time() - started_cpu)
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    baseline = None
    if delaunay:
        xy = to_plane_frame(cloud.points, np.array(detection.plane.point),
                            rotation_to_z(detection.plane.normal))[:, :2]
        started = time.perf_counter()
        Delaunay(xy)
        baseline = time.perf_counter() - started
    print(json.dumps({"points": len(cloud.points), "holes": len(detection.holes), "load": load,
                      "pipeline": float(np.median(times)), "cpu": float(np.median(cpu)), "delaunay": baseline,
                      "peak_mb": peak}))


def run_child(size, kind, repeats, delaunay, source=None):
    command = [sys.executable, __file__, "--child", str(size), kind, str(repeats), str(int(delaunay)), str(source or "")]
    output = subprocess.run(command, check=True, capture_output=True, text=True).stdout
    return json.loads(output.strip().splitlines()[-1])


def load_times():
    """Load time of a 10^6-point binary PCD and a 10^6-row CSV (open3d imported beforehand)."""
    code = r"""
import json, os, sys, tempfile, time
import numpy as np
sys.path.insert(0, sys.argv[1])
from holecli.io import read_cloud, save_points
rng = np.random.default_rng(0)
points = rng.uniform(-50, 50, (1_000_000, 3))
out = {}
with tempfile.TemporaryDirectory() as folder:
    for name in ("scan.pcd", "scan.csv"):
        path = os.path.join(folder, name)
        save_points(path, points)
        started = time.perf_counter(); read_cloud(path); out[name] = time.perf_counter() - started
print(json.dumps(out))
"""
    output = subprocess.run([sys.executable, "-c", code, str(ROOT)], check=True, capture_output=True, text=True)
    return json.loads(output.stdout)


def startup():
    """Time of ``import holecli`` and of ``holecli --help``, and the heavy modules each imports."""
    code = ("import sys, time; sys.path.insert(0, sys.argv[1]); t = time.perf_counter(); import holecli; "
            "dt = time.perf_counter() - t; print(dt, 'open3d' in sys.modules, 'matplotlib' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code, str(ROOT)], check=True, capture_output=True, text=True)
    import_time, o3d, mpl = out.stdout.split()
    started = time.perf_counter()
    environment = dict(os.environ, PYTHONPATH=str(ROOT))
    subprocess.run([sys.executable, "-m", "holecli", "--help"], check=True, capture_output=True, env=environment)
    help_time = time.perf_counter() - started
    code = ("import sys; sys.path.insert(0, sys.argv[1]); sys.argv = ['holecli', '--help']\n"
            "import holecli.cli\ntry:\n    holecli.cli.main()\nexcept SystemExit:\n    pass\n"
            "print('open3d' in sys.modules, 'matplotlib' in sys.modules, file=sys.stderr)")
    heavy = subprocess.run([sys.executable, "-c", code, str(ROOT)], capture_output=True, text=True).stderr.split()
    return float(import_time), o3d == "True" or mpl == "True", help_time, heavy[-2:] != ["False", "False"]


SPLIT = r"""
import json, sys, time
started = time.process_time()  # what the interpreter's start cost this process
sys.path.insert(0, sys.argv[1])
from holecli import threads
threads.start_blas_single_threaded()  # as the holecli program does first
import holecli.cli, holecli.cli.detect, holecli.pipeline, holecli.robust.method  # what detect imports
imported = time.process_time()
from holecli import detect, read_cloud
cloud = read_cloud(sys.argv[2])
loaded = time.process_time()
detect(cloud.points)
print(json.dumps({"interpreter": started, "imports": imported - started, "load": loaded - imported,
                  "detect": time.process_time() - loaded, "points": len(cloud.points)}))
"""


def _child_cpu(command, **kwargs):
    """Run ``command``; its CPU seconds (user + system, from the kernel's accounting) and its stdout."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    result = subprocess.run(command, check=True, capture_output=True, text=True, **kwargs)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime, result.stdout


def _environment(source, cache):
    """The environment of a whole holecli process: ``source``'s holecli, byte-compiled into ``cache``.
    (``python -m holecli`` puts its working folder first on the path: run it in ``source``.)"""
    environment = dict(os.environ, PYTHONPATH=str(source), PYTHONPYCACHEPREFIX=str(cache))
    for name in ("OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "PYTHONDONTWRITEBYTECODE"):
        environment.pop(name, None)  # as a user's shell has them: unset
    return environment


def one_shot_split(source, cache, runs=7):
    """CPU of the whole ``holecli detect sample_clouds/table1.ply`` process, and where it goes: the
    interpreter's start, the imports, loading the file, ``detect``; what is left (writing the record,
    the exit) is the whole minus those. Medians of ``runs`` alternating runs, after one that fills the
    bytecode ``cache``."""
    path = str(ROOT / "sample_clouds" / "table1.ply")
    environment = _environment(source, cache)
    _child_cpu([sys.executable, "-c", SPLIT, str(source), path], env=environment)
    totals, parts = [], []
    for _ in range(runs):
        totals.append(_child_cpu([sys.executable, "-m", "holecli", "detect", path], env=environment, cwd=source)[0])
        parts.append(json.loads(_child_cpu([sys.executable, "-c", SPLIT, str(source), path], env=environment)[1]))
    split = {key: float(np.median([part[key] for part in parts])) for key in ("interpreter", "imports", "load", "detect")}
    split["total"] = float(np.median(totals))
    split["rest"] = max(0.0, split["total"] - sum(split[key] for key in ("interpreter", "imports", "load", "detect")))
    split["points"], split["runs"] = parts[0]["points"], runs
    return split


def pattern_plys(folder, points=10_000):
    """``benchmarks/pattern_speed.py``'s scene sampled as a grid, stripes and at random with about
    ``points`` points, written as binary PLYs into ``folder``: {pattern: (path, points)}."""
    from dataclasses import replace

    from holecli.io import save_points
    from holecli.simulation.synth import make_scan

    plys = {}
    for pattern in ("grid", "stripes", "random"):
        scene = stripes_scan(points)
        if pattern != "stripes":
            area = (scene.extent[1] - scene.extent[0]) * (scene.extent[3] - scene.extent[2])
            spacing = float(np.sqrt(area / points))
            scene = replace(scene, pattern=pattern, line_pitch=None, spacing=spacing, noise_world_z=0.1 * spacing)
        cloud = make_scan(scene, 0).points
        cloud = cloud[np.isfinite(cloud).all(axis=1)]
        path = os.path.join(folder, f"{pattern}.ply")
        save_points(path, cloud)
        plys[pattern] = (path, len(cloud))
    return plys


def whole_process(source, cache, path, runs=7):
    """Median CPU seconds of a whole ``holecli detect PATH`` process (``source``'s holecli), after one
    run that fills the bytecode ``cache``."""
    environment = _environment(source, cache)
    command = [sys.executable, "-m", "holecli", "detect", path]
    _child_cpu(command, env=environment, cwd=source)
    return float(np.median([_child_cpu(command, env=environment, cwd=source)[0] for _ in range(runs)]))


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--max-points", type=float, default=1e7, help="largest size to run (default 1e7)")
    parser.add_argument("--baseline", default=None, help="a git revision to measure in the same run")
    parser.add_argument("--child", nargs=5, help=argparse.SUPPRESS)
    add_docs_options(parser, VALIDATION / "speed.md")
    args = parser.parse_args(argv)
    if args.child:
        size, kind, repeats, delaunay, source = args.child
        child(int(size), kind, int(repeats), bool(int(delaunay)), source or None)
        return 0
    docs = docs_target(parser, args, argv, "speed.py", ["speed"])

    with baseline_checkout(args.baseline) as base, recording() as printed, \
            tempfile.TemporaryDirectory() as scratch:
        sizes = [(416, "table1", 21), (1572, "table1", 21), (6733, "table1", 21), (9498, "table1", 21),
                 (100_000, "stripes", 5), (1_000_000, "stripes", 5), (10_000_000, "stripes", 1), (915_000, "cad", 3),
                 (978_000, "plate", 3)]
        header = (f"{'scan':<8} {'points':>10} {'holes':>5} {'load s':>7} {'pipeline s':>10} {'cpu s':>7} {'exponent':>8} "
                  f"{'vs Table II':>11} {'Delaunay s':>10} {'vs Delaunay':>11} {'peak MB':>7}")
        print(header + (f" {'base cpu s':>10} {'base/now':>8}" if base else ""))
        previous = {}
        for size, kind, repeats in sizes:
            if size > args.max_points:
                continue
            row = run_child(size, kind, repeats, delaunay=size <= 1_000_000)
            paper = PAPER_TABLE_II.get(size)
            versus_paper = f"{paper / row['pipeline']:>10.0f}x" if paper else f"{'':>11}"
            if row["delaunay"] is not None:
                versus_delaunay = f"{row['delaunay'] / row['pipeline']:>10.1f}x"
                delaunay = f"{row['delaunay']:>10.4f}"
            else:
                versus_delaunay, delaunay = f"{'':>11}", f"{'':>10}"
            exponent = ""
            if kind in previous:
                before = previous[kind]
                exponent = f"{math.log(row['cpu'] / before['cpu']) / math.log(row['points'] / before['points']):.2f}"
            previous[kind] = row
            line = (f"{kind:<8} {row['points']:>10,} {row['holes']:>5} {row['load']:>7.3f} {row['pipeline']:>10.4f} "
                    f"{row['cpu']:>7.3f} {exponent:>8} {versus_paper} {delaunay} {versus_delaunay} {row['peak_mb']:>7.0f}")
            if base:
                was = run_child(size, kind, repeats, delaunay=False, source=base)
                line += f" {was['cpu']:>10.3f} {was['cpu'] / row['cpu']:>7.2f}x"
            print(line, flush=True)
        loads = load_times()
        print(f"load 10^6 points: binary PCD {loads['scan.pcd']:.3f} s, CSV {loads['scan.csv']:.3f} s")
        import_time, heavy_import, help_time, heavy_help = startup()
        print(f"import holecli: {import_time:.3f} s, open3d/matplotlib imported: {heavy_import}")
        print(f"holecli --help: {help_time:.3f} s (whole process), open3d/matplotlib imported: {heavy_help}")
        cache = Path(scratch) / "pycache"
        for label, source in [("now", ROOT), ("base", base)]:
            if source is None:
                continue
            split = one_shot_split(source, cache / label)
            print(f"holecli detect on a {split['points']:,}-point PLY, CPU s (median of {split['runs']} runs, {label}): "
                  f"whole process {split['total']:.3f} = interpreter {split['interpreter']:.3f} + imports "
                  f"{split['imports']:.3f} + load {split['load']:.3f} + detect {split['detect']:.3f} + output and exit "
                  f"{split['rest']:.3f}")
        print("whole process holecli detect of a 10^4-point PLY, CPU s (median of 7 runs, byte-compiled):")
        for pattern, (path, points) in pattern_plys(scratch).items():
            now = whole_process(ROOT, cache / "now", path)
            line = f"  {pattern:<8} {points:>7,} points: {now:.3f}"
            if base:
                was = whole_process(base, cache / "base", path)
                line += f" (base {was:.3f}, base/now {was / now:.2f}x)"
            print(line, flush=True)
    if docs:
        docs.write("speed", printed.text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
