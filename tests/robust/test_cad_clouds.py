"""Clouds made from CAD meshes the way engineers make them (issue 24, item 2): the mesh's own vertices,
even surface sampling (every face, or without the walls) and an exact square lattice straight down, made
by :mod:`holecli.simulation.cad_cloud` from fresh panels of :mod:`holecli.simulation.panel` (seeds move
the lattice's phase, draw the samples and the noise) and from trimesh's ``plate_holes.STL``.

Each cloud is scored as ``../shared/validation/score.py`` scores a scan (:func:`_score`): every full hole
found within max(0.1, p/2), its centre within max(0.02, 0.2 p) + s/2 and its diameter within
max(0.03, 0.3 p) + s + roundness/2 of the CAD edge polygon's least-squares circle; nothing reported that
is not near a hole of the surface or of another surface the cloud holds.

Measured on ``scripts/make_cad_suite.py``'s 86 clouds (score.py, before the seen-face rule): 32/86 as
expected; with --view-dir and the rule, the surface samplings went from 12/42 to 32/42. The classes still
failing are marked xfail(strict): the test fails when one of them starts passing, so that its mark is
removed.
"""

import time

import numpy as np
import pytest

from holecli.pipeline import detect
from holecli.simulation.cad_cloud import cad_cloud, cad_truth, cloud_pitch
from holecli.simulation.panel import FeatureSpec as F
from holecli.simulation.panel import PanelSpec, build_panel, panel_truth

pytestmark = pytest.mark.slow  # the quick loop: pytest -m "not slow"

DOWN = (0.0, 0.0, -1.0)


def _panel(kind, seed, segments=None):
    """A small flat panel with two holes of ``kind`` whose sizes and places vary with ``seed`` (``mixed``:
    a plain and a countersunk hole among a slot, a cut-out and a boss); ``segments`` per circle, else
    drawn from 48, 64, 96."""
    rng = np.random.default_rng(seed)
    d = float(rng.uniform(3.0, 6.0))
    x = float(rng.uniform(7.0, 9.0))
    t = float(rng.uniform(2.5, 4.0))
    hole = {"plain": lambda c: F("through", c, diameter=d),
            "csk": lambda c: F("countersunk", c, diameter=d, countersink_diameter=d + 3.0,
                               countersink_angle_deg=float(rng.choice([82.0, 90.0, 100.0]))),
            "cbore": lambda c: F("counterbored", c, diameter=d, counterbore_diameter=d + 3.0, counterbore_depth=1.0),
            "mixed": None}[kind]
    drawn = int(rng.choice([48, 64, 96]))
    segments = drawn if segments is None else segments
    if kind == "mixed":
        spec = PanelSpec(50, 36, t, segments=segments, features=(
            F("through", (-x - 4.0, 2.0), diameter=d),
            F("countersunk", (x + 4.0, -2.0), diameter=d, countersink_diameter=d + 3.0),
            F("slot", (0.0, 10.0), width=3.0, length=10.0), F("boss", (0.0, 0.0), diameter=5.0, height=2.0),
            F("cutout", (0.0, -10.0), width=5.0, length=10.0, corner_radius=1.0)))
    else:
        spec = PanelSpec(36, 26, t, segments=segments, features=(hole((-x, 1.0)), hole((x, -1.0))))
    panel = build_panel(spec)
    return panel.vertices, panel.triangles, [f for f in panel_truth(panel)["features"] if not f["is_hole"]]


def _score(holes, truth, pitch, noise):
    """(failures, number of full holes) of reported ``holes`` against a validation-format ``truth``."""
    found_tol = max(0.1, 0.5 * pitch)
    fails, used = [], set()
    full = [h for h in truth["holes"] if h["status"] == "full"]
    for h in truth["holes"] + truth["holes_on_other_surfaces"]:
        r = h["edge_diameter"] / 2
        near = [(float(np.linalg.norm(np.subtract(q.center, h["center"]))), j) for j, q in enumerate(holes)
                if j not in used]
        near = [(dist, j) for dist, j in near if dist <= max(found_tol, 0.5 * r)]
        if not near:
            if any(h is f for f in full):
                fails.append(f"d{h['edge_diameter']:.2f} not found")
            continue
        dist, j = min(near)
        used.add(j)
        if not any(h is f for f in full):
            continue
        q = holes[j]
        if dist > found_tol:
            fails.append(f"d{h['edge_diameter']:.2f} center off by {dist:.3f}")
            continue
        if dist > max(0.02, 0.2 * pitch) + 0.5 * noise:
            fails.append(f"d{h['edge_diameter']:.2f} center {dist * 1e3:.0f} um")
        error = q.diameter - h["edge_diameter"]
        if abs(error) > max(0.03, 0.3 * pitch) + noise + h["edge_roundness"] / 2:
            fails.append(f"d{h['edge_diameter']:.2f} diameter {error * 1e3:+.0f} um")
    fails += [f"extra d{q.diameter:.2f} at {np.round(q.center, 2).tolist()}" for j, q in enumerate(holes) if j not in used]
    return fails, len(full)


def _run(kind, cloud, faces, spacing, noise, seed, view_dir, frame=None, segments=None):
    vertices, triangles, not_holes = _panel(kind, seed, segments)
    rng = np.random.default_rng(seed)
    target = None
    if cloud == "lattice":  # the lattice's phase against the holes
        target = np.array([*(rng.random(2) * spacing), vertices[:, 2].max()])
    points = cad_cloud(vertices, triangles, cloud, spacing, faces=faces, noise=noise, rng=rng, target=target)
    pitch = cloud_pitch(points, cloud, spacing)
    truth = cad_truth(vertices, triangles, pitch=pitch, faces=faces, kind=cloud, not_holes=not_holes, frame=frame)
    view = np.asarray(truth["view_dir"])
    if frame is not None:
        points = points @ np.asarray(frame)[:3, :3].T + np.asarray(frame)[:3, 3]
    try:
        holes = detect(points, view_dir=view if view_dir else None).holes
    except Exception as error:  # noqa: BLE001 - a refusal is a failure of the class, recorded
        return [f"{type(error).__name__}: {error}"], len(truth["holes"])
    return _score(holes, truth, pitch, noise)


def _rate(cases):
    failures = {}
    for case in cases:
        fails, _ = _run(*case)
        if fails:
            failures[case] = fails
    return failures


SEEDS = (0, 1, 2)
UPSIDE_DOWN = np.diag([1.0, -1.0, -1.0, 1.0])  # 180 deg about x: the top faces -z, the sensor looks along +z
CLASSES = {
    # straight-down lattices, noise-free and noisy, random phase against the holes
    "lattice": [(k, "lattice", "all", 0.1, n, s, False) for k in ("plain", "csk", "cbore") for n in (0.0, 0.005)
                for s in SEEDS[:2]],
    # small holes on coarse lattices: about ten points across
    "coarse lattice": [("plain", "lattice", "all", 0.4, n, s, False) for n in (0.0, 0.005) for s in SEEDS],
    # every face sampled (top, bottom, sides, walls), the view given: the face the sensor sees
    "surface, view given": [(k, "surface", f, 0.1, 0.0, s, True) for k in ("plain", "csk", "cbore")
                            for f in ("all", "no-walls") for s in SEEDS[:2]],
    # noisy surface samples of countersinks, the bottom face under the cones: it read as a counterbore's
    # floor (or, its points dropped with the sample's leftovers, no cone was left), 40-60 um small
    "surface countersink, noise": [("csk", "surface", f, 0.1, 0.005, s, True) for f in ("all", "no-walls")
                                   for s in SEEDS],
    # the same without the view: of the top and the bottom, which hold alike many points, the face a
    # sensor above +z sees (it was the face holding the most points, often the bottom)
    "surface, no view": [(k, "surface", f, 0.1, 0.0, s, False) for k in ("plain", "cbore")
                         for f in ("all", "no-walls") for s in SEEDS],
    # a CAD export's vertices (points only along the edges, none inside a face): the edge loops
    # (holecli.robust.edge_loops), 24- to 96-gons, among slots, cut-outs and bosses, with and without the view
    "vertices": [(k, "vertices", "all", 0.1, n, s, v, None, (24, 32, 48, 64, 96)[s % 5])
                 for k in ("plain", "csk", "cbore", "mixed") for n in (0.0, 0.005) for s in range(10, 15)
                 for v in (True, False)],
    # the same turned upside down, the view given
    "vertices upside down": [(k, "vertices", "all", 0.1, n, s, True, UPSIDE_DOWN, (24, 48, 96)[s % 3])
                             for k in ("csk", "mixed") for n in (0.0, 0.005) for s in range(20, 23)],
}
@pytest.mark.parametrize("name", list(CLASSES))
def test_cad_clouds_measured_right(name):
    failures = _rate(CLASSES[name])
    assert not failures, failures


@pytest.mark.parametrize("kind", ["csk", "cbore", "plain"])
def test_upside_down_part_with_the_view(kind):
    """A panel turned upside down, its view given: measured as one facing +z (countersinks and counterbores
    too: what lies below the surface is read away from the sensor)."""
    for seed in SEEDS:
        fails, _ = _run(kind, "lattice", "all", 0.1, 0.0, seed, True, frame=UPSIDE_DOWN)
        assert not fails, (seed, fails)


@pytest.mark.xfail(strict=True, reason="issue 24 item 2: without a view, a straight-down lattice of a part "
                                       "facing -z does not show its side; +z is assumed and what lies below "
                                       "the surface is read as above it")
def test_upside_down_countersink_without_the_view_not_yet():
    fails, _ = _run("csk", "lattice", "all", 0.1, 0.0, 0, False, frame=UPSIDE_DOWN)
    assert not fails, fails


def _boss_panel_lattice():
    spec = PanelSpec(40, 30, 3, segments=64, features=(
        F("boss", (-7.0, 0.0), diameter=16.0, height=2.0), F("through", (9.0, 6.0), diameter=4.0),
        F("through", (9.0, -6.0), diameter=5.0)))
    panel = build_panel(spec)
    points = cad_cloud(panel.vertices, panel.triangles, "lattice", 0.1)
    truth = cad_truth(panel.vertices, panel.triangles, pitch=0.1,
                      not_holes=[f for f in panel_truth(panel)["features"] if not f["is_hole"]])
    return points, truth


def test_seen_face_is_the_larger_of_the_near_faces():
    """A large boss's top (a fifth of the points) is nearer the sensor than the panel's top: the view must
    not make it the surface (SEEN_FACE_SHARE); both holes of the panel's top are measured."""
    points, truth = _boss_panel_lattice()
    holes = detect(points, view_dir=DOWN).holes
    fails, full = _score(holes, truth, 0.1, 0.0)
    assert full == 2 and not fails, fails


def test_plate_holes_lattice():
    """trimesh's plate_holes.STL (MIT, tests/data/cad) ray-cast straight down on a noise-free 0.25 mm lattice
    (978k points): 5 of 5 holes, nothing else. The issue measured 0 of 5 and a phantom hole in 15.9 s CPU;
    the target is < 1.5 s CPU (measured 0.5-0.7 s here, detect alone, on a loaded machine: 1.1-1.3 s
    before the faster least-median hinge and fan cue, in the same runs; benchmarks/plate_speed.py)."""
    from pathlib import Path

    from holecli.simulation.profiler import load_mesh

    vertices, triangles = load_mesh(Path(__file__).resolve().parents[1] / "data" / "cad" / "plate_holes.STL")
    points = cad_cloud(vertices, triangles, "lattice", 0.25)
    truth = cad_truth(vertices, triangles, pitch=0.25)
    started = time.process_time()
    holes = detect(points).holes
    cpu = time.process_time() - started
    fails, full = _score(holes, truth, 0.25, 0.0)
    assert full == 5 and not fails, fails
    assert cpu < 6.0  # far from the 15.9 s the issue measured, even on a loaded machine
