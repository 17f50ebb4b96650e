"""Speed of ``holecli batch``: --jobs 2 against --jobs 1 on 60 scans of about 10^4 points, and on a local cluster.

Writes 60 synthetic scans of about 10^4 points into a temporary folder: an 8 x 8 mm patch with a 3 mm
hole (or two 2.5 mm holes), cycling through the kinds of scan holecli is made for (grid, laser
stripes, jittered grid, random sampling, a countersunk hole with bore-wall points and outliers), with
light noise and a different pose per scan. It then runs ``python -m holecli batch`` on them with
``--jobs 1`` and with ``--jobs 2``: each the real command, start-up included, output to a file. It
prints both wall times (the best of ``--repeats`` alternating runs, since other processes on the
machine add noise) and their ratio. The target on an idle machine with 2 cores is a ratio >= 1.8.

It also runs ``holecli batch --cluster local:N`` (N = ``--jobs``; a Dask LocalCluster started and
stopped by the command, its start included) when Dask is installed, and prints the files per second
of the three: ``--jobs 1``, ``--jobs N`` and ``--cluster local:N``. The cluster has no target: it is
for archives beyond one machine, and on one machine it shows what its start and its tasks cost.

A first, untimed run compiles holecli's bytecode into a temporary cache (``PYTHONPYCACHEPREFIX``), as
an installed holecli has it: without it (``PYTHONDONTWRITEBYTECODE`` set) every run compiles the
modules again, start-up work that does not parallelize. Exit status 1 when a run fails or, with
``--check``, when the ratio is below the target.

Run:  python benchmarks/batch_speed.py [--scans 60] [--jobs 2] [--repeats 3] [--check]
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from holecli.io import save_points  # noqa: E402
from holecli.simulation import synth  # noqa: E402

TARGET_RATIO = 1.8  # issue 29: on an idle 2-core machine


def _scenes():
    """The kinds of scan the batch cycles through: holecli's sampling patterns and defects (as in
    ``sample_clouds/``), each about 10^4 points on an 8 x 8 mm patch."""
    hole = synth.HoleSpec(center=(0.0, 0.0), diameter=3.0)
    common = {"extent": (-4.0, 4.0, -4.0, 4.0), "spacing": 0.08, "noise_world_z": 0.004}
    return (
        synth.SceneSpec(holes=(hole,), **common),
        synth.SceneSpec(holes=(hole,), **dict(common, spacing=0.045), pattern="stripes", line_pitch=0.135),
        synth.SceneSpec(holes=(hole,), **common, pattern="jittered"),
        synth.SceneSpec(holes=(hole,), **common, pattern="random"),
        synth.SceneSpec(holes=(synth.HoleSpec(center=(0.0, 0.0), diameter=3.0, countersink_diameter=4.5,
                                              bore_depth=2.0),), **common, outlier_fraction=0.01),
        synth.SceneSpec(holes=(synth.HoleSpec(center=(-2.0, 0.0), diameter=2.5),
                               synth.HoleSpec(center=(2.0, 0.0), diameter=2.5)),
                        **dict(common, extent=(-5.0, 5.0, -3.0, 3.0))),
    )


def write_scans(folder, count):
    """``count`` PLY scans of about 10^4 points each, cycling through :func:`_scenes`, posed apart."""
    scenes = _scenes()
    for seed in range(count):
        scene = replace(scenes[seed % len(scenes)], rotation_deg=(10.0 + seed % 20, -5.0, 3.0 * seed),
                        translation=(100.0 + seed, 50.0, 20.0))
        save_points(Path(folder) / f"scan_{seed:03d}.ply", synth.make_scan(scene, seed).points)


def run_batch(folder, jobs, cache):
    """Wall time of one ``holecli batch`` run, seconds; the number of records it wrote. ``jobs``: the
    worker processes (``--jobs``), or ``"local:N"`` (``--cluster local:N``)."""
    where = ["--cluster", jobs] if str(jobs).startswith("local:") else ["--jobs", str(jobs)]
    output = Path(folder).parent / f"out_{str(jobs).replace(':', '')}.jsonl"
    env = dict(os.environ, PYTHONPATH=str(ROOT), PYTHONPYCACHEPREFIX=str(cache))
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    started = time.perf_counter()
    result = subprocess.run([sys.executable, "-m", "holecli", "batch", str(folder), *where, "--overwrite",
                             "--output", str(output)], capture_output=True, text=True, env=env, cwd=ROOT)
    seconds = time.perf_counter() - started
    if result.returncode not in (0, 4):
        sys.exit(f"holecli batch {' '.join(where)} failed with exit code {result.returncode}:\n{result.stderr}")
    return seconds, len(output.read_text().splitlines())


def have_dask() -> bool:
    """Whether ``--cluster`` can run here (Dask's distributed is installed)."""
    import importlib.util

    return importlib.util.find_spec("distributed") is not None


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scans", type=int, default=60, help="number of scans [60]")
    parser.add_argument("--jobs", type=int, default=2, help="workers of the parallel run [2]")
    parser.add_argument("--repeats", type=int, default=3, help="timed runs of each, the best counts [3]")
    parser.add_argument("--check", action="store_true", help=f"exit 1 when the ratio is below {TARGET_RATIO}")
    args = parser.parse_args()
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    with tempfile.TemporaryDirectory(prefix="holecli-batch-speed-") as folder:
        scans = Path(folder) / "scans"
        scans.mkdir()
        write_scans(scans, args.scans)
        cache = Path(folder) / "pycache"
        run_batch(scans, 1, cache)  # warm-up: bytecode and file cache
        times = {1: [], args.jobs: []}
        cluster = f"local:{args.jobs}"
        if have_dask():
            times[cluster] = []
        for _ in range(args.repeats):
            for jobs in times:
                seconds, records = run_batch(scans, jobs, cache)
                if records != args.scans:
                    sys.exit(f"{jobs}: expected {args.scans} records, got {records}")
                times[jobs].append(seconds)
    serial, parallel = min(times[1]), min(times[args.jobs])
    ratio = serial / parallel
    print(f"{args.scans} scans of ~10^4 points, {cores} cores available")
    print(f"--jobs 1: {serial:.2f} s (runs: {', '.join(f'{t:.2f}' for t in times[1])})")
    print(f"--jobs {args.jobs}: {parallel:.2f} s (runs: {', '.join(f'{t:.2f}' for t in times[args.jobs])})")
    print(f"files per second per core: --jobs 1 {args.scans / serial:.1f}, "
          f"--jobs {args.jobs} {args.scans / parallel / min(args.jobs, cores):.1f}")
    print(f"ratio: {ratio:.2f} (target >= {TARGET_RATIO} with --jobs 2 on 2 cores)")
    if cluster in times:
        clustered = min(times[cluster])
        print(f"--cluster {cluster}: {clustered:.2f} s (runs: {', '.join(f'{t:.2f}' for t in times[cluster])}; "
              f"the cluster's start included)")
    else:
        print(f"--cluster {cluster}: not run (Dask is not installed: pip install 'holecli[cluster]')")
    print(f"files per second: --jobs 1 {args.scans / serial:.1f}, --jobs {args.jobs} {args.scans / parallel:.1f}"
          + (f", --cluster {cluster} {args.scans / clustered:.1f}" if cluster in times else ""))
    if args.check and ratio < TARGET_RATIO:
        sys.exit(1)


if __name__ == "__main__":
    main()
