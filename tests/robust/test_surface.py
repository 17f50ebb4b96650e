"""Tests of holecli.robust.surface: the surface at one hole, its tangent plane on a flat and on a curved
scan, and the height of a curved surface near a hole."""

import numpy as np
import pytest

from holecli.geometry.plane import fit_plane_scatter
from holecli.robust.scene import build_scene
from holecli.robust.surface import local_normal, surface_height, tangent_of_quadric
from holecli.settings import DEFAULT_SETTINGS

R = 200.0  # the cylinder's radius (mm)


def _plate_xy(seed=2, count=12_000, hole=2.0):
    rng = np.random.default_rng(seed)
    xy = rng.uniform(-10.0, 10.0, (count, 2))
    return xy[np.hypot(*xy.T) >= hole]


def _rotation(axis, degrees):
    axis = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    t = np.radians(degrees)
    return np.eye(3) + np.sin(t) * k + (1 - np.cos(t)) * k @ k


def _in_plane(scene, world):
    return (scene.rotation @ (np.asarray(world) - scene.origin))[:2]


def test_the_local_normal_of_a_tilted_plate_is_its_normal():
    turn = _rotation((1.0, 2.0, 0.0), 25.0)
    xy = _plate_xy()
    points = np.column_stack([xy, np.zeros(len(xy))]) @ turn.T + [5.0, -3.0, 40.0]
    scene = build_scene(points, view_dir=-turn[:, 2])
    tangent, (u_height, u_normal) = local_normal(scene, _in_plane(scene, [5.0, -3.0, 40.0]), 2.0, DEFAULT_SETTINGS)
    assert abs(float(tangent.normal @ turn[:, 2])) == pytest.approx(1.0, abs=1e-9)
    assert abs(float((tangent.point - [5.0, -3.0, 40.0]) @ turn[:, 2])) < 1e-9  # on the plate
    assert 0.0 <= u_height < 1e-6 and 0.0 <= u_normal < 1e-6  # noise-free: (almost) no uncertainty


def test_no_local_normal_without_a_ring_of_points():
    xy = _plate_xy()
    scene = build_scene(np.column_stack([xy, np.zeros(len(xy))]), view_dir=(0.0, 0.0, -1.0))
    far = _in_plane(scene, [50.0, 50.0, 0.0])  # off the plate: no surface point around it
    assert local_normal(scene, far, 2.0, DEFAULT_SETTINGS) == (None, (None, None))


def _cylinder(xy):
    """Heights of a cylinder of radius R along y, its top at x = 0."""
    return R - np.sqrt(R ** 2 - xy[:, 0] ** 2)


@pytest.mark.parametrize("x", [0.0, 4.0, -6.0])
def test_the_tangent_of_a_curved_surface_is_the_cylinders(x):
    """On a cylinder the ring's plane is tilted by the mean slope around the hole and lies off the
    surface by its sag; the quadric's tangent plane touches the cylinder with its normal there."""
    rng = np.random.default_rng(3)
    angle = rng.uniform(0.0, 2 * np.pi, 3000)
    radius = np.sqrt(rng.uniform(2.0 ** 2, 6.0 ** 2, 3000))
    xy = np.column_stack([x + radius * np.cos(angle), radius * np.sin(angle)])
    points = np.column_stack([xy, -_cylinder(xy)])
    plane = fit_plane_scatter(points)
    near = np.array([x, 0.0, -_cylinder(np.array([[x, 0.0]]))[0]])
    tangent = tangent_of_quadric(points, plane, near, DEFAULT_SETTINGS.curvature_sigmas)
    truth = np.array([x, 0.0, R - _cylinder(np.array([[x, 0.0]]))[0]]) / R  # the cylinder's outward normal
    assert abs(float(tangent.normal @ truth)) == pytest.approx(1.0, abs=1e-7)
    assert abs(float((tangent.point - near) @ truth)) < 1e-5
    # the plane of the ring itself lies off the surface at the hole by about the sag r^2 / 2R
    assert abs(float((plane.point - near) @ plane.normal)) > 10 * abs(float((tangent.point - near) @ truth))


def test_the_surface_height_is_zero_on_a_flat_scan_and_follows_a_curved_one():
    xy = _plate_xy()
    flat = build_scene(np.column_stack([xy, np.zeros(len(xy))]), view_dir=(0.0, 0.0, -1.0))
    around = np.array([[2.5, 0.0], [0.0, -3.0]])
    np.testing.assert_array_equal(surface_height(flat, np.zeros(2), 2.0, DEFAULT_SETTINGS, around), 0.0)
    curved = build_scene(np.column_stack([xy, -_cylinder(xy)]), view_dir=(0.0, 0.0, -1.0))
    center = _in_plane(curved, [6.0, 0.0, -_cylinder(np.array([[6.0, 0.0]]))[0]])
    heights = surface_height(curved, center, 2.0, DEFAULT_SETTINGS, center + around)
    # the quadric's heights at the two points differ as the cylinder's do above the scene's plane
    world = (np.column_stack([center + around, heights]) @ curved.rotation) + curved.origin
    np.testing.assert_allclose(world[:, 2], -_cylinder(world[:, :2]), atol=2e-4)
