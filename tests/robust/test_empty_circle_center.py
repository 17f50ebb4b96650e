"""The largest empty circle's center on random sampling: its uncertainty covers over fresh scenes (issue 24,
item 3: on surface samples of CAD meshes, a Poisson sampling, the center was covered in 87 % of cases)."""

import numpy as np
import pytest

from holecli import detect
from holecli.robust.estimators import EMPTY_CIRCLE, METHOD_TERMS, RIM_FIT, empty_circle
from holecli.robust.estimators.empty_circle import EMPTY_CIRCLE_CENTER
from holecli.robust.uncertainty import edge_uncertainty
from holecli.simulation.synth import HoleSpec, SceneSpec, make_scan


def test_the_empty_circles_center_has_its_random_sampling_floor():
    # no synthetic holes: the floor 0.5 / (rho R) and the method term; the other estimators do not get it
    u, _ = edge_uncertainty(EMPTY_CIRCLE, None, np.zeros((0, 2)), (0.0, 0.0), 2.0, 0.1, 0.0, density=100.0)
    term = METHOD_TERMS["empty_circle"]["center"][0] * 0.1
    assert u == pytest.approx(np.hypot(EMPTY_CIRCLE_CENTER / 200.0, term))
    u, _ = edge_uncertainty(RIM_FIT, None, np.zeros((0, 2)), (0.0, 0.0), 2.0, 0.1, 0.0, density=100.0)
    assert u == 0.0


def _scene(seed):
    """A hole of 2-5 mm on Poisson points of spacing 0.1 mm (radius 10-25 spacings), no noise."""
    rng = np.random.default_rng([24, 3, seed])
    diameter = float(rng.uniform(2.0, 5.0))
    spec = SceneSpec(holes=(HoleSpec(center=tuple(rng.uniform(-0.3, 0.3, 2)), diameter=diameter),),
                     extent=(-2 * diameter, 2 * diameter, -2 * diameter, 2 * diameter), spacing=0.1,
                     pattern="random", noise_normal=0.0)
    scan = make_scan(spec, rng)
    return scan.points, scan.truth["holes"][0]


def _coverage(scenes):
    covered = []
    for seed in range(scenes):
        points, truth = _scene(seed)
        hole = min(detect(points).holes, key=lambda h: np.linalg.norm(np.subtract(h.center, truth["center"])))
        assert hole.uncertainty.estimator == "empty_circle"
        error = np.subtract(hole.center, truth["center"])[:2]  # the scene's plane is z = 0
        covered += list(np.abs(error) <= 2.0 * hole.uncertainty.center_in_plane)
    return float(np.mean(covered))


def test_the_empty_circles_center_is_covered_on_random_sampling(monkeypatch):
    # 60 scenes, 120 coordinates: 94.2 % with the floor; 90.0 % without it (the synthetic holes alone)
    assert _coverage(60) >= 0.92
    monkeypatch.setattr(empty_circle, "EMPTY_CIRCLE_CENTER", 0.0)
    assert _coverage(60) < 0.92
