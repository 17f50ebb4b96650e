"""Tests of holecli.robust.curved: a hole of a curved panel measured again on its flattened
neighbourhood, which puts its center on the surface and its normal along the surface's."""

from dataclasses import replace

import numpy as np
import pytest

from holecli.robust.candidate import Measured
from holecli.robust.candidates import find_voids
from holecli.robust.curved import on_curved_surface
from holecli.robust.measure import measure_candidate
from holecli.robust.scene import build_scene
from holecli.settings import DEFAULT_SETTINGS

R = 150.0   # the cylinder's radius
RADIUS = 2.0
HOLE_X = 12.0  # the hole's distance from the cylinder's top line


def _scene(curved):
    """A 40 x 20 mm panel randomly sampled, bent (a cylinder along y) or flat, with a 4 mm hole at
    x = HOLE_X; and that hole, measured in the scene's plane frame."""
    rng = np.random.default_rng(5)
    xy = rng.uniform([-20.0, -10.0], [20.0, 10.0], (16_000, 2))
    xy = xy[np.hypot(xy[:, 0] - HOLE_X, xy[:, 1]) >= RADIUS]
    z = np.sqrt(R ** 2 - xy[:, 0] ** 2) - R if curved else np.zeros(len(xy))
    scene = build_scene(np.column_stack([xy, z]), view_dir=(0.0, 0.0, -1.0))
    found = [measure_candidate(scene, void, DEFAULT_SETTINGS) for void in find_voids(scene.grid)]
    return scene, max((m for m in found if isinstance(m, Measured)), key=lambda m: m.radius)


def test_a_flat_panels_hole_is_not_measured_again():
    scene, hole = _scene(curved=False)
    assert on_curved_surface(scene, hole, DEFAULT_SETTINGS, None, 0) is None


def test_a_curved_panels_hole_lies_on_the_surface_along_its_normal():
    scene, hole = _scene(curved=True)
    found = on_curved_surface(scene, hole, DEFAULT_SETTINGS, None, 0)
    assert found is not None
    x, y, z = found.center
    assert abs(y) < 0.05 and abs(x - HOLE_X) < 0.05
    assert z == pytest.approx(np.sqrt(R ** 2 - x ** 2) - R, abs=1e-3)  # on the cylinder
    radial = np.array([x, 0.0, np.sqrt(R ** 2 - x ** 2)]) / R
    assert float(np.asarray(found.normal) @ radial) == pytest.approx(1.0, abs=1e-5)
    assert found.diameter == pytest.approx(2 * RADIUS, abs=0.1)


def test_the_ring_and_the_crop_from_the_holes_neighbourhood_are_the_scenes():
    """Measured again from the points its measurement gathered around it (``Measured.around``) or
    from the whole scan: the same hole to the last bit."""
    scene, hole = _scene(curved=True)
    assert hole.around is not None
    gathered = on_curved_surface(scene, hole, DEFAULT_SETTINGS, None, 0)
    assert gathered == on_curved_surface(scene, replace(hole, around=None), DEFAULT_SETTINGS, None, 0)
