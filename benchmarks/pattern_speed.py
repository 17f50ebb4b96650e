"""CPU time of ``holecli.detect`` per sampling pattern and size, against a baseline revision in the same run.

For each pattern (square grid, laser stripes 4 spacings apart, uniform random sampling) and size
(10^4, 10^5, 10^6 points by default) it builds ``benchmarks/speed.py``'s stripes scene (an 80 x 20 mm
patch with five holes of 3 to 9 mm, 1 m from the origin, 10 % noise), or the same patch and pose
sampled as a grid or at random, and times ``detect`` in a fresh child process: the
median CPU time (``time.process_time``, which the machine's other load disturbs less than wall time)
of ``--repeats`` calls after one warm-up call, and the wall time beside it. Between consecutive sizes
it prints the scaling exponent ``log(t2 / t1) / log(n2 / n1)`` (1: linear).

With ``--baseline REV`` the same is measured on that git revision of holecli (checked out into a
temporary worktree; it needs that revision's ``benchmarks/speed.py``), each case right after the
current code's, and the ratio baseline / current is printed: a same-run comparison on a shared machine.

Run:  python benchmarks/pattern_speed.py [--sizes 10000,100000,1000000] [--patterns grid,stripes,random]
                                         [--repeats 3] [--baseline REV] [--docs]

``--docs`` writes the table into its block of docs/validation/speed.md (``--docs-page PATH``: another page).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from benchmarks._baseline import baseline_checkout  # noqa: E402
from benchmarks._docs_table import VALIDATION, add_docs_options, docs_target, recording  # noqa: E402

CHILD = r"""
import json, sys, time
from dataclasses import replace
from pathlib import Path

import numpy as np

# The scene is benchmarks/speed.py's (of the holecli measured: it puts that checkout first on the path).
sys.path.insert(0, str(Path.cwd() / "benchmarks"))
from speed import stripes_scan

from holecli import detect
from holecli.simulation.synth import make_scan

pattern, points, repeats = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
scene = stripes_scan(points)
if pattern != "stripes":
    area = (scene.extent[1] - scene.extent[0]) * (scene.extent[3] - scene.extent[2])
    scene = replace(scene, pattern=pattern, line_pitch=None, spacing=float(np.sqrt(area / points)),
                    noise_world_z=0.1 * float(np.sqrt(area / points)))
cloud = make_scan(scene, 0).points
cloud = cloud[np.isfinite(cloud).all(axis=1)]
detection = detect(cloud)
cpu, wall = [], []
for _ in range(repeats):
    started_cpu, started_wall = time.process_time(), time.perf_counter()
    detection = detect(cloud)
    cpu.append(time.process_time() - started_cpu)
    wall.append(time.perf_counter() - started_wall)
print(json.dumps({"points": len(cloud), "cpu": float(np.median(cpu)), "wall": float(np.median(wall)),
                  "holes": len(detection.holes)}))
"""


def measure(source, pattern, points, repeats):
    """One case in a fresh child process running the holecli of ``source`` (a folder)."""
    env = dict(os.environ, PYTHONPATH=str(source))
    result = subprocess.run([sys.executable, "-c", CHILD, pattern, str(points), str(repeats)], env=env,
                            cwd=source, capture_output=True, text=True, check=True)
    return json.loads(result.stdout.strip().splitlines()[-1])


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="10000,100000,1000000")
    parser.add_argument("--patterns", default="grid,stripes,random")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--baseline", default=None, help="a git revision to measure in the same run")
    add_docs_options(parser, VALIDATION / "speed.md")
    args = parser.parse_args(argv)
    docs = docs_target(parser, args, argv, "pattern_speed.py", ["pattern_speed"])
    sizes = [int(s) for s in args.sizes.split(",")]
    with baseline_checkout(args.baseline) as baseline_dir, recording() as printed:
        header = f"{'pattern':<8} {'points':>10} {'holes':>5} {'cpu s':>8} {'wall s':>8} {'exponent':>8}"
        if baseline_dir:
            header += f" {'base cpu s':>10} {'base exp':>8} {'base/now':>8}"
        print(header)
        for pattern in args.patterns.split(","):
            previous = previous_base = None
            for points in sizes:
                now = measure(ROOT, pattern, points, args.repeats)
                exponent = "" if previous is None else \
                    f"{math.log(now['cpu'] / previous['cpu']) / math.log(now['points'] / previous['points']):8.2f}"
                line = (f"{pattern:<8} {now['points']:>10,} {now['holes']:>5} {now['cpu']:8.3f} {now['wall']:8.3f} "
                        f"{exponent:>8}")
                if baseline_dir:
                    base = measure(baseline_dir, pattern, points, args.repeats)
                    base_exponent = "" if previous_base is None else \
                        f"{math.log(base['cpu'] / previous_base['cpu']) / math.log(base['points'] / previous_base['points']):8.2f}"
                    line += f" {base['cpu']:10.3f} {base_exponent:>8} {base['cpu'] / now['cpu']:7.2f}x"
                    previous_base = base
                print(line, flush=True)
                previous = now
    if docs:
        docs.write("pattern_speed", printed.text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
