"""Tests of holecli.registration.transform: the rigid transform's views, validation, and the propagation of its covariance."""

import json

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from holecli.errors import HoleCliError
from holecli.registration.transform import (
    RegistrationError,
    RigidTransform,
    direction_covariance,
    direction_uncertainty_deg,
    point_covariance,
)


def _random_transform(rng):
    return RigidTransform(Rotation.random(random_state=rng).as_matrix(), rng.uniform(-100, 100, 3))


def _elementary(axis, degrees):
    return Rotation.from_euler(axis, degrees, degrees=True).as_matrix()


def test_apply_points_and_directions(rng):
    transform = _random_transform(rng)
    points = rng.normal(size=(5, 3))
    np.testing.assert_allclose(transform.apply_points(points), points @ transform.rotation.T + transform.translation)
    np.testing.assert_allclose(transform.apply_directions(points), points @ transform.rotation.T)
    np.testing.assert_allclose(transform.apply_points(points[0]), transform.apply_points(points)[0])
    homogeneous = np.column_stack([points, np.ones(5)]) @ transform.matrix.T
    np.testing.assert_allclose(homogeneous[:, :3], transform.apply_points(points), atol=1e-12)


def test_inverse_and_compose(rng):
    for _ in range(20):
        a, b = _random_transform(rng), _random_transform(rng)
        points = rng.normal(size=(4, 3)) * 50
        np.testing.assert_allclose(a.inverse().apply_points(a.apply_points(points)), points, atol=1e-10)
        np.testing.assert_allclose(a.compose(b).apply_points(points), a.apply_points(b.apply_points(points)), atol=1e-10)
        np.testing.assert_allclose(a.compose(b).matrix, a.matrix @ b.matrix, atol=1e-12)
        np.testing.assert_allclose(a.compose(a.inverse()).matrix, np.eye(4), atol=1e-12)


def test_from_matrix_round_trip(rng):
    transform = _random_transform(rng)
    again = RigidTransform.from_matrix(transform.matrix)
    np.testing.assert_array_equal(again.rotation, transform.rotation)
    np.testing.assert_array_equal(again.translation, transform.translation)


@pytest.mark.parametrize(
    "matrix, match",
    [
        (np.eye(3), r"\(4, 4\)"),
        (np.diag([1.0, 1.0, -1.0, 1.0]), "determinant"),
        (np.diag([1.0, 2.0, 1.0, 1.0]), "not orthonormal"),
        (np.vstack([np.eye(4)[:3], [0.0, 0.0, 1.0, 1.0]]), "last row"),
        (np.full((4, 4), np.nan), "finite"),
    ],
)
def test_from_matrix_rejects(matrix, match):
    with pytest.raises(RegistrationError, match=match) as error:
        RigidTransform.from_matrix(matrix)
    assert isinstance(error.value, ValueError) and isinstance(error.value, HoleCliError)


def test_quaternion_scalar_first_non_negative(rng):
    for _ in range(50):
        transform = _random_transform(rng)
        w, x, y, z = transform.quaternion
        assert w >= 0
        np.testing.assert_allclose(Rotation.from_quat([x, y, z, w]).as_matrix(), transform.rotation, atol=1e-12)
    # Half a turn about z: w = 0, (0, 0, 1).
    np.testing.assert_allclose(RigidTransform(_elementary("z", 180), np.zeros(3)).quaternion, [0, 0, 0, 1], atol=1e-12)


def test_roll_pitch_yaw_convention():
    roll, pitch, yaw = 10.0, -20.0, 30.0
    rotation = _elementary("z", yaw) @ _elementary("y", pitch) @ _elementary("x", roll)
    np.testing.assert_allclose(RigidTransform(rotation, np.zeros(3)).roll_pitch_yaw_deg, [roll, pitch, yaw], atol=1e-10)
    np.testing.assert_allclose(RigidTransform(_elementary("x", 15), np.zeros(3)).roll_pitch_yaw_deg, [15, 0, 0], atol=1e-10)


def test_to_dict_is_json_ready(rng):
    transform = _random_transform(rng)
    data = json.loads(json.dumps(transform.to_dict()))
    np.testing.assert_allclose(data["matrix"], transform.matrix)
    assert set(data) >= {"matrix", "rotation", "translation", "quaternion_wxyz", "roll_pitch_yaw_deg"}


def test_arrays_are_read_only(rng):
    transform = _random_transform(rng)
    with pytest.raises(ValueError):
        transform.translation[0] = 1.0


def test_point_covariance_matches_monte_carlo(rng):
    transform = _random_transform(rng)
    root = rng.normal(size=(6, 6)) * np.array([1e-3] * 3 + [1e-2] * 3)
    covariance = root @ root.T
    point = np.array([40.0, -25.0, 10.0])
    samples = rng.multivariate_normal(np.zeros(6), covariance, size=20000)
    rotations = Rotation.from_rotvec(samples[:, :3]).as_matrix()
    mapped = rotations @ (transform.rotation @ point) + transform.translation + samples[:, 3:]
    np.testing.assert_allclose(np.cov(mapped.T), point_covariance(covariance, point, transform), rtol=0.05, atol=1e-7)


def test_direction_uncertainty_is_rms_angle(rng):
    transform = RigidTransform.identity()
    sigma = np.radians(0.2)
    covariance = np.diag([sigma**2] * 3 + [1.0] * 3)
    # A rotation vector isotropic with sigma per axis tilts z by sqrt(2) sigma rms (x and y components).
    assert direction_uncertainty_deg(covariance, [0, 0, 1], transform) == pytest.approx(np.degrees(np.sqrt(2) * sigma))
    assert np.allclose(direction_covariance(covariance, [0, 0, 1], transform)[2], 0.0)


def test_free_direction_gives_infinite_only_where_it_reaches():
    transform = RigidTransform.identity()
    # Free rotation about z through the origin: a point on z does not move, one on x does (along y).
    free = np.array([[0, 0, 1.0, 0, 0, 0]])
    covariance = np.diag([1e-6] * 3 + [1e-4] * 3)
    on_axis = point_covariance(covariance, [0, 0, 5.0], transform, free)
    assert np.all(np.isfinite(on_axis))
    off_axis = point_covariance(covariance, [5.0, 0, 0], transform, free)
    assert off_axis[1, 1] == np.inf and np.isfinite(off_axis[0, 0]) and np.isfinite(off_axis[2, 2])
    assert np.isfinite(direction_uncertainty_deg(covariance, [0, 0, 1], transform, free))
    assert direction_uncertainty_deg(covariance, [1, 0, 0], transform, free) == np.inf


def test_covariance_shape_checked():
    with pytest.raises(RegistrationError, match=r"\(6, 6\)"):
        point_covariance(np.eye(3), [0, 0, 0], RigidTransform.identity())
