"""Write a validation suite of clouds made from CAD meshes the way engineers make them (issue 24, item 2).

    python scripts/make_cad_suite.py OUT_DIR [--seeds N] [--only TEXT] [--list]

Every part (flat panels built by holecli.simulation.panel, and trimesh's plate_holes.STL from
tests/data/cad) is turned into clouds by holecli.simulation.cad_cloud: the mesh's own vertices (a CAD
export's: points only along edges), even surface sampling with and without the walls, and an exact
square lattice straight down, each without noise and with 5 um of Gaussian noise along the view. The
folder gets the scans (binary PLY, float64), a NAME.truth.json beside each in the format of
../shared/validation/realistic, and cases.json, so that the validation scorer scores it:

    python ../shared/validation/score.py OUT_DIR [--view-dir]

--seeds N repeats every noisy or random case with N seeds (each seed also moves the lattice by a random
fraction of its pitch); --only keeps the cases whose name contains TEXT; --list prints the names only;
--segments N tessellates the panels' circles with N segments instead of 64 (benchmarks/uncertainty.py
uses 1024: edges round within 0.05 um, so that each hole has one diameter to cover).
"""

from __future__ import annotations

import dataclasses
import json
import math
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from holecli.io import save_points  # noqa: E402
from holecli.simulation.cad_cloud import cad_cloud, cad_truth, cloud_pitch  # noqa: E402
from holecli.simulation.panel import FeatureSpec as F  # noqa: E402
from holecli.simulation.panel import PanelSpec, build_panel, panel_truth  # noqa: E402

NOISE = 0.005  # mm, Gaussian along the view
SEGMENTS = 64  # segments per circle of the panels (a CAD export's tessellation, not the panel's 0.1 um default)

# name: (PanelSpec, lattice pitch, region (target u, v, line_length, scan_length) or None, frame rotation or None)
PARTS = {
    "plain": (PanelSpec(50, 40, 3, segments=SEGMENTS, features=(
        F("through", (-14, 0), diameter=3.0), F("through", (0, 0), diameter=5.0),
        F("through", (14, 0), diameter=8.0))), 0.1, None, None),
    "csk": (PanelSpec(40, 30, 3, segments=SEGMENTS, features=(
        F("countersunk", (-8, 0), diameter=4.0, countersink_diameter=7.0, countersink_angle_deg=100.0),
        F("countersunk", (8, 0), diameter=5.0, countersink_diameter=9.0, countersink_angle_deg=82.0))), 0.1, None, None),
    "cbore": (PanelSpec(40, 30, 4, segments=SEGMENTS, features=(
        F("counterbored", (-8, 0), diameter=4.0, counterbore_diameter=7.0, counterbore_depth=1.5),
        F("counterbored", (8, 0), diameter=6.0, counterbore_diameter=10.0, counterbore_depth=1.0))), 0.1, None, None),
    "small": (PanelSpec(30, 20, 2, segments=48, features=(
        F("through", (-6, 0), diameter=2.5), F("through", (6, 0), diameter=2.5))), 0.25, None, None),
    "small4": (PanelSpec(40, 30, 3, segments=SEGMENTS, features=(
        F("through", (-8, 0), diameter=4.0), F("countersunk", (8, 0), diameter=4.0, countersink_diameter=6.0))),
        0.4, None, None),
    "slots": (PanelSpec(60, 40, 3, segments=SEGMENTS, features=(
        F("through", (-18, 8), diameter=4.0), F("slot", (0, 8), width=4.0, length=12.0),
        F("cutout", (-12, -9), width=8.0, length=14.0, corner_radius=1.0),
        F("through", (10, -9), diameter=5.0), F("slot", (20, 6), width=3.0, length=10.0, direction_deg=90.0))),
        0.1, None, None),
    # the scanned region cuts a cut-out and a hole (the region's border, not the part's)
    "slots_cut": (PanelSpec(60, 40, 3, segments=SEGMENTS, features=(
        F("through", (-18, 8), diameter=4.0), F("cutout", (4, 0), width=8.0, length=14.0, corner_radius=1.0),
        F("through", (-4, -12), diameter=5.0))), 0.1, (-9.0, 0.0, 30.0, 24.0), None),
    "bosses": (PanelSpec(50, 40, 3, segments=SEGMENTS, features=(
        F("boss", (-12, 0), diameter=5.0, height=3.0), F("boss", (12, 8), diameter=8.0, height=2.0),
        F("through", (8, -8), diameter=4.0))), 0.1, None, None),
    # shallow round pockets (spot faces) beside a blind and a through hole: the pockets are no holes
    "pockets": (PanelSpec(50, 40, 5, segments=SEGMENTS, features=(
        F("pocket", (-12, 6), diameter=12.0, depth=0.6), F("pocket", (-10, -10), diameter=8.0, depth=0.4),
        F("blind", (10, 8), diameter=5.0, depth=2.5), F("through", (12, -8), diameter=4.0))), 0.1, None, None),
    # a 30 mm block with a 10 mm bore: with the walls, most of the surface is the bore's and the sides'
    "deep": (PanelSpec(24, 24, 30, segments=SEGMENTS, features=(F("through", (0, 0), diameter=10.0),)), 0.1, None, None),
    # the csk panel upside down in the file's frame: its top faces -z, the sensor looks along +z
    "flipped": (PanelSpec(40, 30, 3, segments=SEGMENTS, features=(
        F("countersunk", (-8, 0), diameter=4.0, countersink_diameter=7.0, countersink_angle_deg=100.0),
        F("through", (8, 0), diameter=5.0))), 0.1, None, (180.0, 0.0, 0.0)),
}
PLATE = ROOT / "tests" / "data" / "cad" / "plate_holes.STL"
# (cloud, faces, spacing factor): spacing = factor x the part's lattice pitch
CLOUDS = (("vertices", "all", 1.0), ("surface", "all", 1.0), ("surface", "no-walls", 1.0), ("lattice", "all", 1.0))


def _rotation(angles):
    from holecli.simulation.synth import rotation_matrix

    frame = np.eye(4)
    frame[:3, :3] = rotation_matrix(angles)
    return frame


def _cases(seeds):
    """(name, part, cloud, faces, spacing, noise, seed)."""
    out = []
    for part, (_, pitch, _, _) in list(PARTS.items()) + [("plate", (None, 0.25, None, None))]:
        for cloud, faces, factor in CLOUDS:
            if part == "plate" and cloud == "surface" and faces == "no-walls":
                continue
            for noise in (0.0, NOISE):
                random = noise > 0 or cloud in ("surface", "lattice")
                for seed in (range(seeds) if random else (0,)):
                    if cloud == "lattice" and noise == 0 and part == "plate" and seed > 0:
                        continue
                    name = (f"{part}_{cloud}{'' if faces == 'all' else '_' + faces}_p{pitch * factor * 1000:03.0f}"
                            f"_n{noise * 1000:02.0f}_s{seed}")
                    out.append((name, part, cloud, faces, pitch * factor, noise, seed))
    return out


def _part(part, segments=None):
    if part == "plate":
        from holecli.simulation.profiler import load_mesh

        vertices, triangles = load_mesh(PLATE)
        return vertices, triangles, [], None, None
    spec, _, region, rotation = PARTS[part]
    if segments is not None:
        spec = dataclasses.replace(spec, segments=segments)
    panel = build_panel(spec)
    not_holes = [f for f in panel_truth(panel)["features"] if not f["is_hole"]]
    return panel.vertices, panel.triangles, not_holes, region, None if rotation is None else _rotation(rotation)


def main(argv):
    if not argv or argv[0].startswith("-"):
        print(__doc__)
        return 2
    out = Path(argv[0])
    seeds = int(argv[argv.index("--seeds") + 1]) if "--seeds" in argv else 1
    only = argv[argv.index("--only") + 1] if "--only" in argv else None
    segments = int(argv[argv.index("--segments") + 1]) if "--segments" in argv else None
    cases = [c for c in _cases(seeds) if only is None or only in c[0]]
    if "--list" in argv:
        print("\n".join(c[0] for c in cases))
        return 0
    out.mkdir(parents=True, exist_ok=True)
    index, meshes = [], {}
    for name, part, cloud, faces, spacing, noise, seed in cases:
        if part not in meshes:
            meshes[part] = _part(part, segments)
        vertices, triangles, not_holes, region, frame = meshes[part]
        rng = np.random.default_rng(seed)
        view, line = np.array([0.0, 0.0, -1.0]), np.array([1.0, 0.0, 0.0])
        middle = 0.5 * (vertices.min(axis=0) + vertices.max(axis=0))
        target = np.array([middle[0], middle[1], vertices[:, 2].max()])
        line_length = scan_length = None
        if region is not None:
            target = np.array([region[0], region[1], vertices[:, 2].max()])
            line_length, scan_length = region[2], region[3]
        if cloud == "lattice" and seed > 0:  # the lattice's phase against the holes
            target = target + np.append(rng.random(2) * spacing, 0.0)
        kw = dict(view=view, line=line, target=target, line_length=line_length, scan_length=scan_length)
        points = cad_cloud(vertices, triangles, cloud, spacing, faces=faces, noise=noise, rng=rng, **kw)
        pitch = cloud_pitch(points, cloud, spacing)
        truth = cad_truth(vertices, triangles, pitch=pitch, faces=faces, kind=cloud, frame=frame,
                          not_holes=not_holes, **kw)
        if frame is not None:
            points = points @ frame[:3, :3].T + frame[:3, 3]
        truth.update(scan=f"{name}.ply", part=part, seed=seed, noise=noise, points=len(points))
        save_points(out / f"{name}.ply", points)
        (out / f"{name}.truth.json").write_text(json.dumps(truth, indent=1) + "\n")
        tags = [cloud, faces, part, "zero_noise" if noise == 0 else "noise"]
        index.append({"scan": f"{name}.ply", "truth": f"{name}.truth.json", "mesh": part, "units": "mm",
                      "points": len(points), "pitch": pitch, "point_pitch": pitch, "line_pitch": pitch,
                      "noise": noise, "view_dir": truth["view_dir"], "tags": tags,
                      "expected_full": sum(h["status"] == "full" for h in truth["holes"]),
                      "holes": [{"status": h["status"], "type": h["type"], "edge_diameter": h["edge_diameter"]}
                                for h in truth["holes"]]})
        print(f"{name}: {len(points)} points, {len(truth['holes'])} holes, pitch {pitch:.3g}", flush=True)
    (out / "cases.json").write_text(json.dumps({"generator": "holecli.simulation.cad_cloud (scripts/make_cad_suite.py)",
                                                "cases": index}, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
