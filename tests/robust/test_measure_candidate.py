"""Tests of holecli.robust.measure: one candidate void measured, a hole or the named check that refused
it, and every candidate of a scan alike one at a time or in threads."""

import json
from dataclasses import asdict, replace

import numpy as np
import pytest

from holecli.robust import measure
from holecli.robust.candidate import Measured, Refusal
from holecli.robust.candidates import find_voids
from holecli.robust.measure import measure_candidate, measure_candidates
from holecli.robust.method import detect_robust
from holecli.robust.scene import Neighbourhood, build_scene, seen_from
from holecli.simulation.synth import HoleSpec, SceneSpec, make_scan
from holecli.settings import DEFAULT_SETTINGS
from holecli.vocabulary import ESTIMATORS, REJECTION_REASONS

RADIUS = 3.0


@pytest.fixture(scope="module")
def measured():
    """A 20 x 20 mm plate randomly sampled (spacing about 0.08 mm, noise 2 um), a 6 mm hole at the
    origin; every void of its grid, measured."""
    rng = np.random.default_rng(1)
    xy = rng.uniform(-10.0, 10.0, (12_000, 2))
    xy = xy[np.hypot(*xy.T) >= RADIUS]
    scene = build_scene(np.column_stack([xy, 0.002 * rng.standard_normal(len(xy))]), view_dir=(0.0, 0.0, -1.0))
    voids = find_voids(scene.grid)
    return scene, voids, [measure_candidate(scene, void, DEFAULT_SETTINGS) for void in voids]


def _at_origin(scene):
    return (scene.rotation @ -scene.origin)[:2]


def test_a_clean_hole_is_measured_with_its_radius(measured):
    scene, _, results = measured
    holes = [m for m in results if isinstance(m, Measured)]
    assert len(holes) == 1
    hole = holes[0]
    assert hole.radius == pytest.approx(RADIUS, abs=0.05)  # about half a spacing
    assert np.hypot(*(hole.center - _at_origin(scene))) < 0.05
    assert not hole.partial and hole.arc_deg == pytest.approx(360.0)
    assert hole.estimator in ESTIMATORS
    # the tangent plane at it: the plate's
    assert abs(hole.surface_plane.normal[2]) == pytest.approx(1.0, abs=1e-3)


def test_the_gaps_of_the_sampling_are_refused_by_a_named_check(measured):
    scene, _, results = measured
    refused = [m for m in results if isinstance(m, Refusal)]
    assert refused  # random sampling leaves gaps wider than a grid cell
    for refusal in refused:
        assert refusal.check in REJECTION_REASONS
        assert np.hypot(*(refusal.center - _at_origin(scene))) > RADIUS  # none at the hole
        assert 2.0 * refusal.radius < 0.5 * RADIUS  # each a small gap, far below the hole's size
    assert "below_min_diameter" in {refusal.check for refusal in refused}


def test_every_candidate_is_measured_alike_in_threads(measured):
    scene, voids, results = measured
    threaded = measure_candidates(scene, voids, replace(DEFAULT_SETTINGS, threads_from_points=0, threads=2))
    assert len(threaded) == len(results)
    for one, other in zip(results, threaded):
        assert type(one) is type(other)
        np.testing.assert_array_equal(one.center, other.center)
        assert one.radius == other.radius


def test_a_hole_carries_the_neighbourhood_its_measurement_gathered(measured):
    scene, _, results = measured
    hole = next(m for m in results if isinstance(m, Measured))
    assert isinstance(hole.around, Neighbourhood) and hole.around.scene is scene
    assert np.hypot(*(hole.around.center - hole.center)) < 0.05
    assert seen_from(scene, hole) is hole.around
    assert seen_from(scene, replace(hole, around=None)) is scene


def test_the_neighbourhood_changes_no_record(monkeypatch):
    """Every question the measurement of a hole asks about the points around it answered from its
    neighbourhood (:class:`holecli.robust.scene.Neighbourhood`) or from the whole scan: the same
    records to the last bit (a countersunk hole, a through hole with reflections, a tilted scan)."""
    spec = SceneSpec(holes=(HoleSpec(center=(0.0, 0.0), diameter=3.0, countersink_diameter=5.0, bore_depth=2.0),
                            HoleSpec(center=(7.0, 0.0), diameter=4.0, bore_depth=3.0, inside_points=40)),
                     extent=(-5.0, 12.0, -5.0, 5.0), spacing=0.06, noise_world_z=0.004)
    points = make_scan(spec, 0).points
    points = points[np.all(np.isfinite(points), axis=1)]

    def records():
        result = detect_robust(points)
        return [json.dumps(asdict(hole), default=repr, sort_keys=True) for hole in result.holes], result

    gathered, result = records()
    assert len(result.holes) == 2 and {hole.type for hole in result.holes} >= {"countersunk"}
    monkeypatch.setattr(measure, "_around", lambda scene, fit, settings: scene)
    assert records()[0] == gathered
