"""Tests of holecli.robust.assemble: a hole measured in the plane frame taken to the world, and a refused
candidate's place with it."""

import numpy as np
import pytest

from holecli.robust.assemble import overlaps, to_hole, to_rejection
from holecli.robust.candidate import Measured, Refusal
from holecli.robust.candidates import find_voids
from holecli.robust.measure import measure_candidate
from holecli.robust.scene import build_scene
from holecli.settings import DEFAULT_SETTINGS

RADIUS = 2.5
CENTER = np.array([12.0, -4.0, 30.0])  # the hole's center, world


def _rotation(axis, degrees):
    axis = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    t = np.radians(degrees)
    return np.eye(3) + np.sin(t) * k + (1 - np.cos(t)) * k @ k


TURN = _rotation((3.0, -1.0, 0.5), 35.0)


@pytest.fixture(scope="module")
def measured():
    """A plate randomly sampled, a 5 mm hole at its middle, turned by a known rotation and moved to
    CENTER; its hole measured in the scene's plane frame."""
    rng = np.random.default_rng(4)
    xy = rng.uniform(-10.0, 10.0, (12_000, 2))
    xy = xy[np.hypot(*xy.T) >= RADIUS]
    points = np.column_stack([xy, np.zeros(len(xy))]) @ TURN.T + CENTER
    scene = build_scene(points, view_dir=-TURN[:, 2])
    found = [measure_candidate(scene, void, DEFAULT_SETTINGS) for void in find_voids(scene.grid)]
    return scene, next(m for m in found if isinstance(m, Measured))


def test_a_hole_goes_to_the_world_by_the_scenes_rotation(measured):
    scene, hole_2d = measured
    hole = to_hole(scene, hole_2d, 3)
    assert hole.index == 3
    np.testing.assert_allclose(hole.center, CENTER, atol=0.05)
    # on the plate: no offset along its normal beyond round-off
    assert abs(float((np.asarray(hole.center) - CENTER) @ TURN[:, 2])) < 1e-9
    assert abs(float(np.asarray(hole.normal) @ TURN[:, 2])) == pytest.approx(1.0, abs=1e-9)
    assert hole.normal[2] > 0  # reported z-positive
    assert hole.diameter == 2.0 * hole_2d.radius and hole.diameter == pytest.approx(2 * RADIUS, abs=0.1)
    assert hole.rim_points == int(hole_2d.fit.kept.sum())
    assert hole.uncertainty.diameter > 0


def test_a_refusal_goes_to_the_world_at_its_place(measured):
    scene, hole_2d = measured
    refusal = Refusal(check="duplicate", value=40, limit=np.int64(60), center=hole_2d.center + [1.0, 0.0],
                      radius=0.5)
    rejection = to_rejection(scene, refusal)
    expected = CENTER + (scene.rotation.T @ np.array([*(hole_2d.center + [1.0, 0.0]), 0.0])
                         - scene.rotation.T @ np.array([*hole_2d.center, 0.0]))
    np.testing.assert_allclose(rejection.center, expected, atol=0.05)
    assert rejection.diameter == 1.0 and rejection.check == "duplicate" and rejection.reason
    assert (rejection.value, rejection.limit) == (40, 60) and type(rejection.limit) is int


def test_two_candidates_overlap_when_either_center_is_within_the_larger_radius(measured):
    _, hole_2d = measured
    near = Measured(center=hole_2d.center + [0.9 * RADIUS, 0.0], radius=0.2, bias=0.0, fit=hole_2d.fit,
                    rim_xy=hole_2d.rim_xy, partial=False, arc_deg=360.0)
    far = Measured(center=hole_2d.center + [1.1 * hole_2d.radius, 0.0], radius=0.2, bias=0.0, fit=hole_2d.fit,
                   rim_xy=hole_2d.rim_xy, partial=False, arc_deg=360.0)
    assert overlaps(hole_2d, near) and overlaps(near, hole_2d)
    assert not overlaps(hole_2d, far) and not overlaps(far, hole_2d)
