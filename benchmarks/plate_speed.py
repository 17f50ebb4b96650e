"""CPU and wall time of ``holecli.detect`` on trimesh's plate ray-cast straight down on a 0.25 mm lattice.

The cloud is ``tests/robust/test_cad_clouds.py::test_plate_holes_lattice``'s: ``tests/data/cad/plate_holes.STL``
(trimesh's, MIT) made into a noise-free, exact square lattice straight down with
:func:`holecli.simulation.cad_cloud.cad_cloud` (978k points). The points are built once; each run times
``detect(points)`` alone (``time.process_time`` and ``time.perf_counter`` around it), after one warm-up
call that pays the imports. It prints each run's CPU and wall seconds, the holes found, the median of
the runs and the median milliseconds of every stage :class:`holecli.stages.StageClock` records (wall
time: ``Detection.timing.stages``).

Run:  python benchmarks/plate_speed.py [--repeat 5] [--pitch 0.25] [--profile N]
(``--profile N`` also prints the N most expensive functions of one more run, cProfile, by cumulative
and by own time.)
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PLATE = ROOT / "tests" / "data" / "cad" / "plate_holes.STL"


def plate_points(pitch):
    """The plate's lattice cloud, (n, 3) float64."""
    from holecli.simulation.cad_cloud import cad_cloud
    from holecli.simulation.profiler import load_mesh

    vertices, triangles = load_mesh(PLATE)
    return cad_cloud(vertices, triangles, "lattice", pitch)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5, help="timed runs after the warm-up (default 5)")
    parser.add_argument("--pitch", type=float, default=0.25, help="lattice pitch, mm (default 0.25)")
    parser.add_argument("--profile", type=int, default=0, metavar="N",
                        help="also print the N most expensive functions of one more run (cProfile)")
    args = parser.parse_args(argv)

    from holecli.pipeline import detect

    points = plate_points(args.pitch)
    print(f"plate_holes.STL, lattice {args.pitch} mm: {len(points)} points")
    detect(points)  # warm-up: imports
    cpu, wall, stages = [], [], {}
    for run in range(args.repeat):
        started_cpu, started_wall = time.process_time(), time.perf_counter()
        detection = detect(points)
        cpu.append(time.process_time() - started_cpu)
        wall.append(time.perf_counter() - started_wall)
        for name, ms in detection.timing.stages:
            stages.setdefault(name, []).append(ms)
        holes = " ".join(f"{h.diameter:.4f}" for h in sorted(detection.holes, key=lambda h: h.diameter))
        print(f"run {run + 1}: {cpu[-1]:.3f} s CPU, {wall[-1]:.3f} s wall; {len(detection.holes)} holes: {holes}")
    print(f"median of {args.repeat}: {statistics.median(cpu):.3f} s CPU (min {min(cpu):.3f}), "
          f"{statistics.median(wall):.3f} s wall (min {min(wall):.3f})")
    print("stages, median ms (wall): " + ", ".join(f"{name} {statistics.median(ms):.0f}" for name, ms in stages.items()))
    if args.profile:
        import cProfile
        import pstats

        profile = cProfile.Profile()
        profile.enable()
        detect(points)
        profile.disable()
        stats = pstats.Stats(profile)
        stats.sort_stats("cumulative").print_stats(args.profile)
        stats.sort_stats("tottime").print_stats(args.profile)


if __name__ == "__main__":
    main()
