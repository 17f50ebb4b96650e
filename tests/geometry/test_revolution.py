"""holecli.geometry.revolution: cylinder and cone fits with a free axis, trimmed."""

import numpy as np
import pytest

from holecli.geometry.revolution import fit_cone, fit_cylinder, frame_about


def _tilted(tilt_deg, toward_deg):
    t, p = np.radians(tilt_deg), np.radians(toward_deg)
    return np.array([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)])


def _cylinder_points(rng, axis, point, radius, count, angles=(0.0, 2 * np.pi), depths=(-3.0, -0.5), noise=0.0):
    theta = rng.uniform(*angles, count)
    along = rng.uniform(*depths, count)
    local = np.column_stack([radius * np.cos(theta), radius * np.sin(theta), along])
    return point + local @ frame_about(axis) + rng.normal(0.0, noise, (count, 3)) if noise else \
        point + local @ frame_about(axis)


def _cone_points(rng, axis, point, radius, half_angle, count, depth, angles=(0.0, 2 * np.pi), noise=0.0):
    theta = rng.uniform(*angles, count)
    along = rng.uniform(-depth, 0.0, count)
    rho = radius + along * np.tan(half_angle)
    local = np.column_stack([rho * np.cos(theta), rho * np.sin(theta), along])
    return point + local @ frame_about(axis) + rng.normal(0.0, noise, (count, 3))


def test_frame_about_is_a_rotation_whose_last_row_is_the_direction():
    for direction in ([0, 0, 1], [1, 0, 0], [0.3, -0.2, 0.9]):
        rotation = frame_about(direction)
        assert np.allclose(rotation @ rotation.T, np.eye(3))
        assert np.isclose(np.linalg.det(rotation), 1.0)
        assert np.allclose(rotation[2], np.asarray(direction) / np.linalg.norm(direction))


@pytest.mark.parametrize("seed", range(4))
def test_a_tilted_cylinder_is_recovered_from_a_guess_along_the_normal(seed):
    rng = np.random.default_rng(seed)
    axis = _tilted(rng.uniform(0.0, 8.0), rng.uniform(0.0, 360.0))
    point = np.array([rng.uniform(-0.1, 0.1), rng.uniform(-0.1, 0.1), 0.0])
    radius = rng.uniform(1.5, 3.0)
    points = _cylinder_points(rng, axis, point, radius, 3000, noise=0.003)
    cylinder = fit_cylinder(points, np.zeros(3), [0.0, 0.0, 1.0], 0.9 * radius, floor=0.003)
    assert abs(cylinder.radius - radius) < 3e-4
    assert np.degrees(np.arccos(abs(cylinder.axis @ axis))) < 0.02
    # the fitted axis passes through the true one
    offset = (cylinder.point - point) - ((cylinder.point - point) @ axis) * axis
    assert np.linalg.norm(offset) < 1.5e-3
    assert 0.002 < cylinder.rms < 0.004


def test_a_cylinder_seen_over_a_quarter_turn_still_gives_its_radius():
    rng = np.random.default_rng(5)
    axis = _tilted(3.0, 40.0)
    points = _cylinder_points(rng, axis, np.zeros(3), 2.0, 2000, angles=(0.0, np.pi / 2), noise=0.002)
    cylinder = fit_cylinder(points, np.zeros(3), [0.0, 0.0, 1.0], 1.8, floor=0.002)
    assert abs(cylinder.radius - 2.0) < 2e-3


def test_the_trimming_sets_stray_points_aside():
    """Points of another surface (a floor across the bore's bottom) would pull a plain least-squares
    fit; trimmed, they are left out and the radius stays."""
    rng = np.random.default_rng(2)
    axis = np.array([0.0, 0.0, 1.0])
    wall = _cylinder_points(rng, axis, np.zeros(3), 2.0, 2000, noise=0.002)
    rho, theta = 1.5 * np.sqrt(rng.random(300)), rng.uniform(0.0, 2 * np.pi, 300)
    stray = np.column_stack([rho * np.cos(theta), rho * np.sin(theta), np.full(300, -3.0)])
    points = np.vstack([wall, stray])
    trimmed = fit_cylinder(points, np.zeros(3), axis, 1.9, floor=0.002)
    untrimmed = fit_cylinder(points, np.zeros(3), axis, 1.9, floor=0.002, rounds=1)
    assert abs(trimmed.radius - 2.0) < 1e-3
    assert not trimmed.kept[len(wall):].any()
    assert abs(untrimmed.radius - 2.0) > 10 * abs(trimmed.radius - 2.0)


def test_a_fixed_axis_keeps_the_direction_given():
    rng = np.random.default_rng(3)
    axis = _tilted(4.0, 0.0)
    points = _cylinder_points(rng, axis, np.array([0.05, 0.0, 0.0]), 2.0, 1000, depths=(-0.4, -0.2))
    cylinder = fit_cylinder(points, np.zeros(3), axis, 1.9, fixed_axis=True)
    assert np.allclose(cylinder.axis, axis)
    assert abs(cylinder.radius - 2.0) < 1e-6


@pytest.mark.parametrize("angle", [82.0, 90.0, 100.0, 110.0])
def test_a_tilted_cone_gives_its_angle_radius_and_axis(angle):
    rng = np.random.default_rng(int(angle))
    axis = _tilted(5.0, angle)
    half = np.radians(angle / 2.0)
    point = np.array([0.05, -0.03, 0.0])
    points = _cone_points(rng, axis, point, 3.5, half, 4000, depth=1.5 / np.tan(half), noise=0.003)
    cone = fit_cone(points, np.zeros(3), [0.0, 0.0, 1.0], 3.3, np.radians(45.0), floor=0.003)
    assert abs(np.degrees(2 * cone.half_angle) - angle) < 0.05
    assert np.degrees(np.arccos(cone.axis @ axis)) < 0.05
    # the radius at the true reference point's axial position
    assert abs(cone.radius_at((point - cone.point) @ cone.axis) - 3.5) < 2e-3
