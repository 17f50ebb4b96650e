"""A lattice aligned with the hole (issue 24): the scan centred on the hole's nominal position, a round
diameter on a round pitch, measured over many fresh profiler scans (holecli.simulation.profiler).

The separating circle (holecli.robust.estimators.lattice) pins the edge between the last material position and
the first missing one of each bracket; it is the middle of the radii the brackets allow. On a lattice
of random phase the truth lies anywhere in that range and the estimate is unbiased. With the lattice's
node on the hole's center the positions at one distance come in fours (stripes) or eights (a grid), so
the range is several times wider, and a round radius on a round pitch puts positions exactly on the
edge: the truth is at the range's outer end and every such hole comes out too small, by half the
range (on the validation suite, every lattice hole: -0.3 to -14.5 um). The points cannot tell where in
the range the edge lies, so that range enters u (holecli.robust.uncertainty.edge_uncertainty,
``radius_range``); without it, +-2u held the truth for 21 of the 27 such holes below (78 %).
"""

import math

import numpy as np
import pytest

from holecli.pipeline import detect
from holecli.robust.estimators.lattice import lattice_steps, separating_circle
from holecli.simulation.panel import FeatureSpec, PanelSpec, build_panel, panel_truth
from holecli.simulation.profiler import ProfilerSpec
from holecli.simulation.scan_part import scan_part


def test_the_range_holds_a_radius_on_a_lattice_radius():
    """Exact grid, hole centred on a node, radius 24 steps: the positions (+-24, 0), (0, +-24) are on
    the edge and present; the nearest missing ones are at sqrt(569) steps. The range the brackets
    allow runs between them, the truth at its top, the largest-margin circle in its middle."""
    h = 0.1
    i, j = np.meshgrid(np.arange(-40, 41), np.arange(-40, 41))
    xy = np.column_stack([i.ravel(), j.ravel()]) * h
    radius = 24 * h
    distance = np.hypot(*xy.T)
    material = xy[distance >= radius - 1e-12]
    rim = material[np.hypot(*material.T) < radius + 1.5 * h]
    steps = lattice_steps(material, (np.array([1.0, 0.0]), np.array([0.0, 1.0])), h)
    center, fitted, margin, (low, high) = separating_circle(material, rim, steps, np.array([0.003, -0.002]),
                                                            radius + 0.05, radii=True)
    inner = math.sqrt(569) * h
    assert low == pytest.approx(inner, abs=1e-6)
    assert high == pytest.approx(radius, abs=1e-6)
    # (the margin is measured on |p|^2 - r^2, so the middle is that of the squared radii: 1e-5 off)
    assert fitted == pytest.approx(0.5 * (inner + radius), abs=2e-5)
    assert np.linalg.norm(center) < 1e-6
    # the truth lies at sqrt(3) u from the estimate when u is the range's rectangular u
    assert (radius - fitted) / ((high - low) / math.sqrt(12.0)) == pytest.approx(math.sqrt(3.0), rel=0.01)


def _aligned(seed):
    """A plain hole of a whole number of point pitches in radius, scanned centred on its axis; pitch,
    stripes, rays and noise drawn per seed."""
    rng = np.random.default_rng([24, 17, seed])
    pitch = float(rng.choice([0.04, 0.05, 0.08, 0.1]))
    line_pitch = pitch * int(rng.choice([1, 2, 3]))
    diameter = 2.0 * pitch * int(rng.integers(15, 40))
    noise = float(rng.choice([0.0, 0.002, 0.005]))
    panel = build_panel(PanelSpec(width=8.0 * diameter, height=8.0 * diameter, thickness=3.0,
                                  features=(FeatureSpec(kind="through", center=(0.0, 0.0), diameter=diameter),),
                                  chord_error=1e-4))
    reach = 3.0 * diameter
    spec = ProfilerSpec(target=(0.0, 0.0, 0.0), standoff=100.0, view=(0.0, 0.0, -1.0), line=(1.0, 0.0, 0.0),
                        line_length=reach, scan_length=reach, point_pitch=pitch, line_pitch=line_pitch,
                        fan=bool(rng.integers(2)), triangulation_deg=25.0, range_noise=noise)
    scanned = scan_part(panel.vertices, panel.triangles, panel_truth(panel)["features"], spec, rng=seed)
    points = scanned.scan.points
    truth = next(h for h in scanned.truth["holes"] if h["inside_scan"])
    return points[np.isfinite(points).all(axis=1)], truth, dict(pitch=pitch, line_pitch=line_pitch, noise=noise,
                                                                 diameter=diameter)


@pytest.mark.slow
def test_aligned_lattice_diameters_are_covered():
    """30 fresh aligned scans (about 10 s): of the holes the lattice's circle measures, +-2u holds the
    truth in at least 93 % (measured: 27 of 27; 21 of 27 without the range in u); their median |error|
    is what the range leaves (measured 7.4 um, mean -6.9: the estimate is not moved), and u is not
    inflated beyond it (median u <= 10 um; measured 6.7)."""
    errors, covered, us = [], [], []
    for seed in range(30):
        points, truth, params = _aligned(seed)
        holes = detect(points).holes
        hole = min(holes, key=lambda h: np.linalg.norm(np.subtract(h.center, truth["center"])))
        assert np.linalg.norm(np.subtract(hole.center, truth["center"])) < 0.01, (seed, params)
        if hole.uncertainty.estimator != "lattice":
            continue
        error = hole.diameter - truth["diameter"]
        errors.append(error)
        us.append(hole.uncertainty.diameter)
        covered.append(abs(error) <= 2.0 * hole.uncertainty.diameter)
    assert len(errors) >= 20
    assert np.mean(covered) >= 0.93, (np.mean(covered), len(covered))
    assert np.median(np.abs(errors)) <= 0.008
    assert np.median(us) <= 0.010
