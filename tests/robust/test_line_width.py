"""A laser line of finite width (issue 24): mixed pixels at a hole's edge, measured over many fresh
profiler scans (holecli.simulation.profiler, ``line_width``).

Where the line's footprint straddles the rim the sensor reads the centroid of the light it sees, and
the point stands off the surface, above it on one side of the hole and below it on the other. That
fringe is no countersink (``NotACone("unresolved")``), and where the edge lies in it enters the
diameter's u (``holecli.robust.measure._edge_fringe``) or, when the band hides it, a warning
(``blurred_edge``).
"""

import functools
import math

import numpy as np
import pytest

from holecli.pipeline import detect
from holecli.simulation.panel import FeatureSpec, PanelSpec, build_panel, panel_truth
from holecli.simulation.profiler import ProfilerSpec
from holecli.simulation.scan_part import scan_part


def _scene(seed, countersunk):
    """A panel with one plain or countersunk hole scanned with a wide line, parameters drawn per seed."""
    rng = np.random.default_rng([24, seed, int(countersunk)])
    diameter = float(rng.uniform(3.0, 6.0))
    pitch = float(rng.uniform(0.03, 0.1))
    line_pitch = pitch * float(rng.choice([1.0, 1.5, 2.0]))
    width = float(rng.choice([0.0, 0.02, 0.03, 0.04, 0.05, 0.06]))
    noise = float(rng.uniform(0.0, 0.008))
    tilt = math.radians(float(rng.uniform(0.0, 25.0)))
    thickness = 3.0
    if countersunk:
        angle = float(rng.choice([82.0, 90.0, 100.0]))
        depth = 0.5
        feature = FeatureSpec(kind="countersunk", center=(0.0, 0.0), diameter=diameter,
                              countersink_diameter=diameter + 2.0 * depth * math.tan(math.radians(angle) / 2.0),
                              countersink_angle_deg=angle)
    else:
        feature = FeatureSpec(kind="through", center=(0.0, 0.0), diameter=diameter)
    size = 6.0 * diameter
    panel = build_panel(PanelSpec(width=size, height=size, thickness=thickness, features=(feature,), chord_error=1e-4))
    points, truth = _wide_line_scan(panel, 3.0 * diameter, tilt, pitch, line_pitch, noise, width, rng, seed)
    return points, truth, dict(width=width, pitch=pitch, noise=noise)


def _wide_line_scan(panel, reach, tilt, pitch, line_pitch, noise, width, rng, seed):
    """The finite points and the hole's truth of a profiler scan of ``panel`` with a laser line ``width``
    wide (fan or parallel rays drawn from ``rng``, camera occlusion at 25 degrees, float32)."""
    spec = ProfilerSpec(target=(0.0, 0.0, 0.0), standoff=100.0, view=(0.0, math.sin(tilt), -math.cos(tilt)),
                        line=(1.0, 0.0, 0.0), line_length=reach, scan_length=reach, point_pitch=pitch,
                        line_pitch=line_pitch, fan=bool(rng.integers(2)), triangulation_deg=25.0,
                        max_incidence_deg=80.0, range_noise=noise, float32=True, line_width=width)
    scanned = scan_part(panel.vertices, panel.triangles, panel_truth(panel)["features"], spec, rng=seed)
    points = scanned.scan.points
    return points[np.isfinite(points).all(axis=1)], next(h for h in scanned.truth["holes"] if h["inside_scan"])


def _measure(seed, countersunk):
    points, truth, params = _scene(seed, countersunk)
    holes = detect(points).holes
    assert holes, (seed, params)
    hole = min(holes, key=lambda h: np.linalg.norm(np.subtract(h.center, truth["center"])))
    assert np.linalg.norm(np.subtract(hole.center, truth["center"])) < 0.1, (seed, params)
    return hole, truth, params


def test_the_fringe_of_a_wide_line_is_not_a_countersink():
    """The case of issue 24: a 40 um line at 0.05 x 0.1 mm pitch, 2 um noise; the mixed pixels on one
    side of the hole lie below the surface like a 63-degree cone a few hundredths deep; without the
    resolved-span check the hole is reported countersunk, 20 um too large with u of 1 um."""
    feature = FeatureSpec(kind="through", center=(0.0, 0.0), diameter=4.8)
    panel = build_panel(PanelSpec(width=40.0, height=40.0, thickness=3.0, features=(feature,), chord_error=1e-4))
    spec = ProfilerSpec(target=(0.0, 0.0, 0.0), standoff=100.0, line_length=16.0, scan_length=16.0,
                        point_pitch=0.05, line_pitch=0.1, triangulation_deg=25.0, max_incidence_deg=80.0,
                        range_noise=0.002, float32=True, line_width=0.04)
    points = scan_part(panel.vertices, panel.triangles, panel_truth(panel)["features"], spec, rng=0).scan.points
    (hole,) = detect(points).holes
    assert hole.type != "countersunk" and hole.uncertainty.estimator != "cone"
    error = hole.diameter - 4.8
    assert abs(error) <= 2.0 * hole.uncertainty.diameter, (error, hole.uncertainty.diameter)


@pytest.mark.slow
def test_wide_lines_over_many_scans_plain_holes_stay_plain_and_u_covers():
    """Fresh scans, line widths 0-60 um, pitches 0.03-0.1 mm (line pitch 1-2x), views 0-25 deg off the
    normal, noise 0-8 um, fan or parallel rays: no plain hole is reported countersunk, every
    countersink is found as one, and diameter +- 2u holds the truth (or the hole warns
    blurred_edge) in at least 90 % of the holes."""
    rows = []
    for seed in range(24):
        for countersunk in (False, True):
            hole, truth, params = _measure(seed, countersunk)
            if countersunk:
                assert hole.type == "countersunk", (seed, params)
            else:
                assert hole.type != "countersunk" and hole.uncertainty.estimator != "cone", (seed, params)
            error = hole.diameter - truth["diameter"]
            warned = any(w.code == "blurred_edge" for w in hole.warnings)
            rows.append((abs(error) <= 2.0 * hole.uncertainty.diameter, warned, params["width"], error,
                         hole.uncertainty.diameter))
    covered = np.mean([c for c, *_ in rows])
    honest = np.mean([c or w for c, w, *_ in rows])
    print(f"diameter +- 2u covers {covered:.1%} of {len(rows)}, covered or warned {honest:.1%}")
    assert honest >= 0.9, rows


# --- wide lines and noise: the fringe in u, blurred_edge, and what neither catches -----------------


def _plain_scene(seed, widths, noises):
    """A plain through hole (3-6 mm) in a 3 mm panel, scanned at pitch 0.04-0.1 mm (line pitch 1-2x),
    0-25 deg off the normal, fan or parallel rays, float32 output, the line's width and the range
    noise drawn uniformly from ``widths`` and ``noises`` (mm). Returns (points, truth)."""
    rng = np.random.default_rng([7, seed])
    diameter = float(rng.uniform(3.0, 6.0))
    pitch = float(rng.uniform(0.04, 0.1))
    line_pitch = pitch * float(rng.choice([1.0, 1.5, 2.0]))
    width = float(rng.uniform(*widths))
    noise = float(rng.uniform(*noises))
    tilt = math.radians(float(rng.uniform(0.0, 25.0)))
    feature = FeatureSpec(kind="through", center=(0.0, 0.0), diameter=diameter)
    panel = build_panel(PanelSpec(width=6.0 * diameter, height=6.0 * diameter, thickness=3.0, features=(feature,),
                                  chord_error=1e-4))
    return _wide_line_scan(panel, 2.5 * diameter, tilt, pitch, line_pitch, noise, width, rng, seed)


@functools.lru_cache(maxsize=None)
def _plain_sweep(seeds, widths, noises):
    """Per scene of :func:`_plain_scene`: (|error| <= 2u, warned blurred_edge, error, u) of its hole."""
    rows = []
    for seed in seeds:
        points, truth = _plain_scene(seed, widths, noises)
        holes = detect(points).holes
        hole = min(holes, key=lambda h: np.linalg.norm(np.subtract(h.center, truth["center"])))
        assert np.linalg.norm(np.subtract(hole.center, truth["center"])) < 0.1, seed
        error, u = hole.diameter - truth["diameter"], hole.uncertainty.diameter
        rows.append((abs(error) <= 2.0 * u, any(w.code == "blurred_edge" for w in hole.warnings), error, u))
    return tuple(rows)


_WIDE, _LOW_NOISE, _HIGH_NOISE = (0.04, 0.06), (0.0, 0.008), (0.01, 0.03)


@pytest.mark.slow
def test_the_edge_fringe_of_a_wide_line_enters_u():
    """Lines 40-60 um wide, noise 0-8 um: the fringe stands out of the band and its middle is taken as
    the edge; the model's own uncertainty, F / sqrt(12) on the diameter (F its width: 12-50 um here),
    is what makes +-2u hold the truth. Measured over these 24 scans: 24 covered (errors -12 to +14 um,
    u 5-21 um); without the term 21 (errors of +12, +6, -8 um with u of 2.8, 3.0, 3.1 um: seeds
    114, 120, 121), none of them warned."""
    rows = _plain_sweep(tuple(range(100, 124)), _WIDE, _LOW_NOISE)
    honest = sum(covered or warned for covered, warned, *_ in rows)
    assert honest >= 23, [(seed, round(e * 1e3, 1), round(u * 1e3, 1)) for seed, (c, w, e, u)
                           in zip(range(100, 124), rows) if not (c or w)]


@pytest.mark.slow
def test_blurred_edge_never_fires_on_clean_scans():
    """An ideal line (width 0) and noise 0-30 um: no mixed points, so the hidden fringe measures exactly
    0 on every hole (also on every scene of benchmarks/doubts.py, whose fringe_gaps column prints it),
    and blurred_edge never fires."""
    rows = _plain_sweep(tuple(range(24)), (0.0, 0.0), (0.0, 0.03))
    assert not any(warned for _, warned, *_ in rows)


_HIGH_NOISE_SEEDS = tuple(range(64))


@pytest.mark.slow
def test_wide_lines_under_noise_blurred_edge_holds_what_u_misses():
    """Lines 40-60 um wide, noise 10-30 um: the band (its half-width several sigma) hides most of the
    fringe, the hole comes out small (median -19 um over 100 scans; -1 um with an ideal line) and u
    holds no fringe term. Where the part of the fringe seen off the band exceeds
    doubt_max_hidden_fringe_gaps the hole warns blurred_edge: over these 64 scans 46 are covered, 49
    covered or warned. The warning is needed by seeds 37 and 59 (0.0186 and 0.0245 gaps of fringe seen,
    +-2u missing the truth); clean scans give exactly 0 (test above): the threshold, 0.01 gaps, lies
    between them (seeds 1 and 42, 0.0078 and 0.0099 gaps, are covered without it)."""
    rows = _plain_sweep(_HIGH_NOISE_SEEDS, _WIDE, _HIGH_NOISE)
    assert sum(covered or warned for covered, warned, *_ in rows) >= 49


@pytest.mark.slow
@pytest.mark.xfail(strict=True, reason="a fringe wholly inside a noise-widened band is neither measured nor "
                                       "warned: 15 of these 64 holes (22 of 100) miss the truth by 2u, silent")
def test_wide_lines_under_noise_every_hole_is_covered_or_warned():
    rows = _plain_sweep(_HIGH_NOISE_SEEDS, _WIDE, _HIGH_NOISE)
    assert all(covered or warned for covered, warned, *_ in rows)
