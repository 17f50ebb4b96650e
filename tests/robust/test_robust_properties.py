"""Invariance of the robust method: rigid motions, uniform scaling and the order of the points.

The result of ``detect(points, method="robust")`` must move with the cloud: under a rigid motion
``p -> R p + t`` the centers move the same way, the diameters stay (within 1e-3 h) and the normals
rotate (up to the sign convention); under a uniform scaling every length scales; and a permutation of
the rows changes nothing beyond round-off (1e-6 h). Clouds: the Table I-like panel of the scene suite
on a grid and on stripes, with 10 % of h noise on the world z and without noise; random and jittered
sampling with noise.
"""

from dataclasses import replace

import numpy as np
import pytest

from holecli.pipeline import detect
from holecli.simulation.synth import HoleSpec, SceneSpec, make_scan, random_rotation

pytestmark = pytest.mark.slow  # the quick loop: pytest -m "not slow"

H = 0.1
RIGID = 1e-3  # units of h: centers and diameters under a rigid motion
ROUND_OFF = 1e-6  # units of h: permutations and scalings
NORMAL_DEG = 1e-3


def panel(pattern, noise):
    """A 9 x 9 mm patch with a 3 mm hole off the lattice (as in test_robust_scenes.panel)."""
    scene = SceneSpec(holes=(HoleSpec(center=(0.37, -0.21), diameter=3.0),), extent=(-4.5, 4.5, -4.5, 4.5),
                      spacing=H, pattern=pattern, rotation_deg=(32.0, 0.0, 20.0), translation=(3.0, 4.0, 5.0),
                      noise_world_z=noise * H)
    if pattern == "stripes":
        scene = replace(scene, line_pitch=3 * H, scan_angle_deg=17.0)
    return scene


CLOUDS = {}


def cloud(pattern, noise):
    """The scan's points (cached: the generator is deterministic)."""
    key = (pattern, noise)
    if key not in CLOUDS:
        CLOUDS[key] = make_scan(panel(pattern, noise), 0).points
    return CLOUDS[key]


def robust(points):
    return detect(points, method="robust").holes


def axis_angle_deg(a, b):
    """Angle between two lines (normals up to sign), degrees."""
    cosine = abs(float(np.dot(a, b))) / (np.linalg.norm(a) * np.linalg.norm(b))
    return float(np.degrees(np.arccos(min(1.0, cosine))))


def rigid_motion(seed):
    rng = np.random.default_rng(seed)
    return random_rotation(rng), rng.uniform(-500.0, 500.0, 3)


def rigid_differences(pattern, noise, seeds):
    """Largest center and diameter change (units of h) and normal change (degrees) over the motions."""
    points = cloud(pattern, noise)
    reference = robust(points)
    assert len(reference) == 1
    worst = np.zeros(3)
    for seed in seeds:
        rotation, shift = rigid_motion(seed)
        moved = robust(points @ rotation.T + shift)
        assert len(moved) == len(reference), seed
        for before, after in zip(reference, moved):
            expected = rotation @ np.asarray(before.center) + shift
            worst = np.maximum(worst, [
                np.linalg.norm(np.asarray(after.center) - expected) / H,
                abs(after.diameter - before.diameter) / H,
                axis_angle_deg(after.normal, rotation @ np.asarray(before.normal)),
            ])
    return worst


@pytest.mark.parametrize("pattern, noise", [
    pytest.param("grid", 0.0, id="grid"),
    pytest.param("stripes", 0.0, id="stripes"),
    pytest.param("grid", 0.1, id="grid-noise-10pct"),
    pytest.param("stripes", 0.1, id="stripes-noise-10pct"),
    pytest.param("random", 0.1, id="random-noise-10pct"),
    pytest.param("jittered", 0.1, id="jittered-noise-10pct"),
])
def test_result_moves_with_a_rigid_motion(pattern, noise):
    center, diameter, normal = rigid_differences(pattern, noise, seeds=range(5))
    assert center < RIGID, center
    assert diameter < RIGID, diameter
    assert normal < NORMAL_DEG, normal


@pytest.mark.parametrize("pattern, noise, factor", [
    pytest.param("grid", 0.1, 0.001, id="grid-noise-10pct-x0.001"),
    pytest.param("grid", 0.1, 25.4, id="grid-noise-10pct-x25.4"),
    pytest.param("stripes", 0.1, 0.001, id="stripes-noise-10pct-x0.001"),
    pytest.param("stripes", 0.1, 25.4, id="stripes-noise-10pct-x25.4"),
    pytest.param("grid", 0.0, 0.001, id="grid-x0.001"),
    pytest.param("grid", 0.0, 1000.0, id="grid-x1000"),
    pytest.param("stripes", 0.0, 0.001, id="stripes-x0.001"),
    pytest.param("stripes", 0.0, 25.4, id="stripes-x25.4"),
])
def test_result_scales_with_the_cloud(pattern, noise, factor):
    points = cloud(pattern, noise)
    reference = robust(points)
    scaled = robust(points * factor)
    assert len(scaled) == len(reference) == 1
    for before, after in zip(reference, scaled):
        center = np.linalg.norm(np.asarray(after.center) / factor - before.center) / H
        diameter = abs(after.diameter / factor - before.diameter) / H
        assert max(center, diameter) < ROUND_OFF, (center, diameter)
        assert axis_angle_deg(after.normal, before.normal) < 1e-6
        assert after.partial == before.partial and after.scan_lines == before.scan_lines


@pytest.mark.parametrize("pattern, noise", [
    pytest.param("grid", 0.1, id="grid-noise-10pct"),
    pytest.param("stripes", 0.1, id="stripes-noise-10pct"),
    pytest.param("grid", 0.0, id="grid"),
    pytest.param("stripes", 0.0, id="stripes"),
    pytest.param("random", 0.1, id="random-noise-10pct"),
])
def test_result_does_not_depend_on_the_point_order(pattern, noise):
    points = cloud(pattern, noise)
    reference = robust(points)
    for seed in range(4):
        order = np.random.default_rng(seed).permutation(len(points))
        permuted = robust(points[order])
        assert len(permuted) == len(reference), seed
        for before, after in zip(reference, permuted):
            center = np.linalg.norm(np.subtract(after.center, before.center)) / H
            diameter = abs(after.diameter - before.diameter) / H
            assert max(center, diameter) < ROUND_OFF, (seed, center, diameter)
            assert axis_angle_deg(after.normal, before.normal) < 1e-6
            assert (after.partial, after.arc_deg, after.scan_lines) == (before.partial, before.arc_deg,
                                                                        before.scan_lines)


def test_transforms_compose_on_an_exact_grid():
    """Without noise everything is exact: a rigid motion then a scaling by 25.4 gives the result moved."""
    points = cloud("grid", 0.0)
    reference = robust(points)[0]
    rotation, shift = rigid_motion(7)
    moved = robust((points @ rotation.T + shift) * 25.4)[0]
    expected = (rotation @ np.asarray(reference.center) + shift) * 25.4
    assert np.linalg.norm(np.asarray(moved.center) - expected) / (25.4 * H) < 1e-6
    assert abs(moved.diameter / 25.4 - reference.diameter) / H < 1e-6
