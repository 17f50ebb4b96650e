"""A countersink seen on a tilted, coarse profiler scan, with the bore's wall in view on one side.

The points within the edge's search window then hold the cone and, at the bore's radius, a column
of wall points millimetres deep: as many as the cone's on a coarse scan. A least-squares hinge bends
to the wall's slope (steeper than any countersink: the hole was taken for a counterbore and its
diameter read 0.1-0.2 mm small); such a hinge is fitted again from a least-median start
(:func:`holecli.robust.estimators.cone._least_median_hinge`), taken only when its points below the surface
spread over the radii (``wall_column``), and the free-center cone fit takes only the points on the cone."""

import math

import numpy as np
import pytest

from holecli.pipeline import detect
from holecli.robust.estimators.cone import Cone, fit_cone_edge
from holecli.simulation.panel import FeatureSpec, PanelSpec, build_panel, panel_truth
from holecli.simulation.profiler import ProfilerSpec
from holecli.simulation.scan_part import scan_part


def _cone_with_wall(rng, wall_points):
    """rho, depth of a 90-degree countersink's cone (edge 2.5, slope 1, down to the bore at 1.7),
    the flat surface beyond the edge, and ``wall_points`` on the bore's wall 0.8-4 mm deep."""
    rho_cone = np.sqrt(rng.uniform(1.7 ** 2, 2.5 ** 2, 700))
    rho_flat = np.sqrt(rng.uniform(2.5 ** 2, 2.9 ** 2, 500))
    rho_wall = rng.uniform(1.68, 1.72, wall_points)
    rho = np.concatenate([rho_cone, rho_flat, rho_wall])
    depth = np.concatenate([2.5 - rho_cone, np.zeros(len(rho_flat)), rng.uniform(0.8, 4.0, wall_points)])
    return rho, depth + rng.normal(0.0, 0.01, len(rho))


@pytest.mark.parametrize("seed", range(5))
def test_a_bore_wall_on_one_side_does_not_bend_the_cone(seed):
    rng = np.random.default_rng([91, seed])
    rho, depth = _cone_with_wall(rng, wall_points=500)
    cone = fit_cone_edge(rho, depth, radius=2.45, width=0.4, noise=0.01)
    assert isinstance(cone, Cone), cone
    assert abs(cone.radius - 2.5) < 0.01 and abs(cone.slope - 1.0) < 0.02


def test_a_bore_wall_alone_is_no_cone():
    # a column of wall points at one radius fits a hinge through its median depth too
    rng = np.random.default_rng(93)
    rho = np.concatenate([rng.uniform(1.5, 1.9, 800), 1.5 + rng.normal(0, 0.004, 400)])
    depth = np.concatenate([rng.normal(0, 0.004, 800), rng.uniform(0.05, 2.0, 400)])
    cone = fit_cone_edge(rho, depth, radius=1.5, width=0.2, noise=0.004)
    assert not isinstance(cone, Cone), cone


def _coarse_tilted_countersink(seed):
    rng = np.random.default_rng([92, seed])
    diameter, angle = float(rng.uniform(3.0, 6.0)), float(rng.choice([82.0, 90.0, 100.0]))
    depth = 0.8
    feature = FeatureSpec(kind="countersunk", center=(0.0, 0.0), diameter=diameter, countersink_angle_deg=angle,
                          countersink_diameter=diameter + 2 * depth * math.tan(math.radians(angle) / 2))
    panel = build_panel(PanelSpec(width=8 * diameter, height=8 * diameter, thickness=float(rng.uniform(3.0, 6.0)),
                                  features=(feature,), chord_error=1e-4))
    tilt = math.radians(rng.uniform(20.0, 40.0))
    pitch = float(rng.uniform(0.08, 0.16))
    spec = ProfilerSpec(view=(0.0, math.sin(tilt), -math.cos(tilt)), line_length=5 * diameter,
                        scan_length=5 * diameter, point_pitch=pitch, line_pitch=pitch,
                        range_noise=float(rng.uniform(0.01, 0.025)), range_quantum=0.001, float32=True)
    scanned = scan_part(panel.vertices, panel.triangles, panel_truth(panel)["features"], spec, rng=seed)
    points = scanned.scan.points
    return points[np.isfinite(points).all(axis=1)], scanned.truth["holes"][0]


@pytest.mark.slow
def test_coarse_tilted_countersinks_are_countersunk_and_measured():
    misses = []
    for seed in range(12):
        points, truth = _coarse_tilted_countersink(seed)
        holes = detect(points).holes
        hole = min(holes, key=lambda h: np.linalg.norm(np.subtract(h.center, truth["center"])))
        error = hole.diameter - truth["diameter"]
        if hole.countersink is None or abs(error) > 0.015:
            misses.append((seed, hole.countersink is not None, round(error, 4)))
    assert len(misses) <= 1, misses
