"""Noise-free and quantised profiler scans of faceted CAD holes (issue 24, cases 1 and 2), and the
validation suite's tolerances, shared by the tests of that class.

The class: a laser profiler's noise-free output (parallel rays: the uniform-X resampled output, or
fan rays) whose ranges are computed in float32 (:attr:`ProfilerSpec.float32_ranges`) and/or
rounded to a quantum of about 1e-7 of the standoff, written as float64 or float32, of a CAD part
whose holes are polygons (24 to 48 segments: a countersink is then a pyramid of flat facets).
"""

from __future__ import annotations

import math

import numpy as np

from holecli.simulation.panel import FeatureSpec, PanelSpec, build_panel, panel_truth
from holecli.simulation.profiler import ProfilerSpec
from holecli.simulation.scan_part import scan_part

STANDOFF = 100.0


def noise_free_scan(seed):
    """One fresh instance: ``(points, truth_holes, pitch, params)``.

    Drawn from ``seed``: the hole (a countersink of 82, 90 or 100 deg, or a plain through hole), its
    size (at least 12 pitches across), its polygon (24, 32 or 48 segments, or the panel's fine
    default), the pitch (0.05-0.25 mm, the line pitch 1-2 times the point pitch), the view's tilt
    (0 for half the instances, where the levels of a face square to the rays show; else 0-25 deg),
    parallel or fan rays, float32 ranges, a range quantum of 1e-7 x standoff, float32 output.
    """
    rng = np.random.default_rng([24, 1, seed])
    pitch = float(rng.uniform(0.05, 0.25))
    line_pitch = pitch * float(rng.choice([1.0, 1.5, 2.0]))
    scale = max(line_pitch, pitch)
    kind = str(rng.choice(["countersunk", "through"], p=[0.65, 0.35]))
    diameter = float(rng.uniform(max(2.5, 12 * scale), max(2.5, 12 * scale) * 1.5))
    segments = [None, 24, 32, 48][int(rng.integers(4))]
    if kind == "countersunk":
        angle = float(rng.choice([82.0, 90.0, 100.0]))
        depth = float(rng.uniform(0.15, 0.35)) * diameter
        outer = diameter + 2 * depth * math.tan(math.radians(angle / 2))
        feature = FeatureSpec(kind=kind, center=(0.0, 0.0), diameter=diameter, countersink_diameter=outer,
                              countersink_angle_deg=angle)
    else:
        angle, outer = None, diameter
        feature = FeatureSpec(kind=kind, center=(0.0, 0.0), diameter=diameter)
    thickness = max(3.0, 0.6 * diameter)
    panel = build_panel(PanelSpec(width=4 * outer, height=4 * outer, thickness=thickness, features=(feature,),
                                  segments=segments))
    tilt = 0.0 if rng.random() < 0.5 else float(rng.uniform(0.0, 25.0))
    azimuth = float(rng.uniform(0.0, 2 * math.pi))
    t = math.radians(tilt)
    view = (math.sin(t) * math.cos(azimuth), math.sin(t) * math.sin(azimuth), -math.cos(t))
    line = (math.cos(azimuth + math.pi / 2), math.sin(azimuth + math.pi / 2), 0.0)
    quantum = bool(rng.random() < 0.5)
    # a robot's frame: the part far from the origin, where float32 output has coarse levels
    shift = (float(rng.uniform(-300, 300)), float(rng.uniform(-300, 300)), float(rng.uniform(0.0, 150.0)))
    params = dict(seed=seed, kind=kind, diameter=round(diameter, 3), outer=round(outer, 3), angle=angle,
                  segments=segments, pitch=round(pitch, 4), line_pitch=round(line_pitch, 4), tilt=round(tilt, 1),
                  fan=bool(rng.random() < 0.3), float32_ranges=bool(rng.random() < 0.75),
                  range_quantum=1e-7 * STANDOFF if quantum else 0.0, float32=bool(rng.random() < 0.5),
                  shift=shift)

    spec = ProfilerSpec(standoff=STANDOFF, view=view, line=line, line_length=3.0 * outer, scan_length=3.0 * outer,
                        point_pitch=pitch, line_pitch=line_pitch, fan=params["fan"], range_noise=0.0,
                        range_quantum=params["range_quantum"], float32_ranges=params["float32_ranges"],
                        float32=params["float32"], triangulation_deg=0.0,
                        frame=((1, 0, 0, shift[0]), (0, 1, 0, shift[1]), (0, 0, 1, shift[2]), (0, 0, 0, 1)))
    scanned = scan_part(panel.vertices, panel.triangles, panel_truth(panel)["features"], spec, rng=seed)
    return scanned.scan.points, scanned.truth["holes"], scale, params


def tolerances(pitch, noise=0.0, truth=None):
    """The validation suite's tolerances (``../shared/validation/score.py``): found within, center
    within, |diameter error| within. ``rnd``, the radial spread of the CAD edge polygon, from the
    truth's polygon radii."""
    rnd = 0.0
    if truth is not None and truth.get("polygon_circumradius") is not None:
        rnd = truth["polygon_circumradius"] - truth["polygon_inradius"]
    return (max(0.1, 0.5 * pitch), max(0.02, 0.2 * pitch) + 0.5 * noise,
            max(0.03, 0.3 * pitch) + noise + rnd / 2.0)


def surface_levels(points, truth_holes):
    """The step between the levels the surface's heights sit on (the smallest between two distinct
    z values each held by 5 % of the points within 1 um of the surface's height, where the surface is
    square to z) when one of them holds 30 % of the points or more (a quantile or a median of the
    heights' deviations is then 0), else 0."""
    top = truth_holes[0]["center"][2]
    z = points[np.abs(points[:, 2] - top) < 1e-3, 2]
    values, counts = np.unique(z, return_counts=True)
    if len(values) > 0.2 * len(z) or counts.max() < 0.3 * len(z):
        return 0.0  # no levels, or levels dithered over many: the heights' spread is not 0
    common = values[counts >= 0.05 * len(z)]
    return float(np.min(np.diff(common))) if len(common) >= 2 else 0.0


def judge(detection, truth_holes, pitch, points=None):
    """What is wrong with a detection of a noise-free scan, as a list of strings (empty: right).

    Each truth hole found within the tolerances, nothing else reported, every standard uncertainty
    (center in plane and along the normal, diameter, normal) positive, and those of the center not
    below the resolution's, ``step / sqrt(12)`` for the step between the levels the surface's heights
    sit on (:func:`surface_levels`, given ``points``)."""
    problems = []
    holes = list(detection.holes)
    least = 0.0 if points is None else 0.99 * surface_levels(points, truth_holes) / math.sqrt(12.0)
    for truth in truth_holes:
        found_within, center_tol, diameter_tol = tolerances(pitch, truth=truth)
        distances = [float(np.linalg.norm(np.subtract(h.center, truth["center"]))) for h in holes]
        if not distances or min(distances) > found_within:
            problems.append(f"d{truth['diameter']:.3f} not found")
            continue
        hole = holes.pop(int(np.argmin(distances)))
        error = hole.diameter - truth["diameter"]
        if min(distances) > center_tol:
            problems.append(f"center off by {min(distances) * 1e3:.1f} um > {center_tol * 1e3:.1f}")
        if abs(error) > diameter_tol:
            problems.append(f"diameter off by {error * 1e3:+.1f} um > {diameter_tol * 1e3:.1f}")
        if hole.partial:
            problems.append("reported partial")
        if truth.get("kind") == "countersunk" and hole.type != "countersunk":
            problems.append(f"countersink reported {hole.type}")
        u = hole.uncertainty
        for name in ("center_in_plane", "center_along_normal", "diameter", "normal_deg"):
            value = getattr(u, name)
            if not (value is not None and math.isfinite(value) and value > 0):
                problems.append(f"u {name} = {value}")
        for name in ("center_in_plane", "center_along_normal"):
            if getattr(u, name) < least:
                problems.append(f"u {name} = {getattr(u, name):.3g} below the resolution's {least:.3g}")
    problems.extend(f"extra hole d{h.diameter:.3f} at {np.round(h.center, 3).tolist()}" for h in holes)
    return problems
