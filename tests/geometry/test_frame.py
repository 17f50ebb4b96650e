"""Tests of holecli.geometry.frame: the rotation onto z (not the paper's Eq. (9)/(10)), the plane frame, the view's angle."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from holecli.errors import PointsError
from holecli.geometry.frame import (
    from_plane_frame,
    check_view_angle,
    rotation_to_z,
    to_plane_frame,
)

Z = np.array([0.0, 0.0, 1.0])


def _random_unit_vectors(rng, count):
    vectors = rng.normal(size=(count, 3))
    return vectors / np.linalg.norm(vectors, axis=1, keepdims=True)


def _rodrigues(normal):
    """Textbook Rodrigues: R = cos t I + sin t [k]x + (1 - cos t) k k^T, k = n x z / |n x z|."""
    n = normal / np.linalg.norm(normal)
    axis = np.cross(n, Z)
    angle = np.arctan2(np.linalg.norm(axis), n @ Z)
    k = axis / np.linalg.norm(axis)
    kx = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.cos(angle) * np.eye(3) + np.sin(angle) * kx + (1.0 - np.cos(angle)) * np.outer(k, k)


def _assert_proper_rotation_onto_z(rotation, normal):
    n = np.asarray(normal, dtype=float) / np.linalg.norm(normal)
    np.testing.assert_allclose(rotation @ n, Z, atol=1e-12)
    np.testing.assert_allclose(rotation @ rotation.T, np.eye(3), atol=1e-12)
    assert np.linalg.det(rotation) == pytest.approx(1.0, abs=1e-12)


def test_rotation_to_z_random_normals(rng):
    for normal in _random_unit_vectors(rng, 200):
        _assert_proper_rotation_onto_z(rotation_to_z(normal), normal)


def test_rotation_to_z_is_the_standard_rodrigues_rotation(rng):
    # The paper's printed Eq. (9)/(10) is not orthogonal; the module must give the textbook rotation.
    for normal in _random_unit_vectors(rng, 50):
        np.testing.assert_allclose(rotation_to_z(normal), _rodrigues(normal), atol=1e-12)


def test_rotation_to_z_is_the_shortest_rotation_of_scipy(rng):
    for normal in _random_unit_vectors(rng, 50):
        expected, _ = Rotation.align_vectors([Z], [normal])
        np.testing.assert_allclose(rotation_to_z(normal), expected.as_matrix(), atol=1e-12)


def test_rotation_to_z_keeps_the_in_plane_axis_perpendicular_to_n_and_z(rng):
    # A minimal rotation leaves the axis n x z fixed.
    for normal in _random_unit_vectors(rng, 20):
        axis = np.cross(normal, Z)
        np.testing.assert_allclose(rotation_to_z(normal) @ axis, axis, atol=1e-12)


def test_rotation_to_z_of_plus_z_is_the_identity():
    np.testing.assert_array_equal(rotation_to_z([0.0, 0.0, 1.0]), np.eye(3))


def test_rotation_to_z_of_minus_z_is_a_proper_half_turn():
    rotation = rotation_to_z([0.0, 0.0, -1.0])
    _assert_proper_rotation_onto_z(rotation, [0.0, 0.0, -1.0])
    # A half turn: rotation angle pi (trace -1) and its own inverse.
    assert np.trace(rotation) == pytest.approx(-1.0, abs=1e-12)
    np.testing.assert_allclose(rotation @ rotation, np.eye(3), atol=1e-12)


@pytest.mark.parametrize(
    "normal",
    [
        (1e-15, 0.0, 1.0),
        (0.0, -1e-15, 1.0),
        (1e-15, 1e-15, -1.0),
        (-1e-15, 0.0, -1.0),
        (1e-9, 0.0, -1.0),
        (0.0, 1e-9, 1.0),
    ],
)
def test_rotation_to_z_nearly_parallel_to_z(normal):
    rotation = rotation_to_z(normal)
    assert np.all(np.isfinite(rotation))
    _assert_proper_rotation_onto_z(rotation, normal)


@pytest.mark.parametrize("scale", [1e-6, 3.0, 1e6])
def test_rotation_to_z_does_not_need_a_unit_vector(rng, scale):
    normal = _random_unit_vectors(rng, 1)[0]
    np.testing.assert_allclose(rotation_to_z(scale * normal), rotation_to_z(normal), atol=1e-12)
    np.testing.assert_allclose(rotation_to_z([0.0, 0.0, -scale]), rotation_to_z([0.0, 0.0, -1.0]), atol=0)


@pytest.mark.parametrize(
    "normal, match",
    [
        ((0.0, 0.0, 0.0), "zero vector"),
        ((1.0, 0.0), "3-vector"),
        ((np.nan, 0.0, 1.0), "finite"),
        ((np.inf, 0.0, 1.0), "finite"),
    ],
)
def test_rotation_to_z_refuses_bad_normals(normal, match):
    with pytest.raises(PointsError, match=match):
        rotation_to_z(normal)


def test_the_first_two_rows_are_the_in_plane_basis(rng):
    normal = _random_unit_vectors(rng, 1)[0]
    e1, e2 = rotation_to_z(normal)[:2]
    np.testing.assert_allclose([e1 @ normal, e2 @ normal, e1 @ e2], 0.0, atol=1e-12)
    np.testing.assert_allclose(np.cross(e1, e2), normal, atol=1e-12)


def test_plane_frame_round_trip(rng):
    normal = _random_unit_vectors(rng, 1)[0]
    rotation = rotation_to_z(normal)
    origin = np.array([769.0, -83.6, 218.8])
    points = origin + rng.normal(scale=10.0, size=(500, 3))
    local = to_plane_frame(points, origin, rotation)
    np.testing.assert_allclose(from_plane_frame(local, origin, rotation), points, rtol=0, atol=1e-12)
    # Distances are kept and the local z is the height above the plane.
    np.testing.assert_allclose(np.linalg.norm(local, axis=1), np.linalg.norm(points - origin, axis=1), atol=1e-12)
    np.testing.assert_allclose(local[:, 2], (points - origin) @ normal, atol=1e-12)


def test_points_on_the_plane_have_zero_local_z(rng):
    normal = _random_unit_vectors(rng, 1)[0]
    e1, e2 = rotation_to_z(normal)[:2]
    origin = np.array([3.0, 4.0, 5.0])
    uv = rng.uniform(-5, 5, size=(100, 2))
    points = origin + uv[:, :1] * e1 + uv[:, 1:] * e2
    local = to_plane_frame(points, origin, rotation_to_z(normal))
    np.testing.assert_allclose(local[:, 2], 0.0, atol=1e-12)
    np.testing.assert_allclose(local[:, :2], uv, atol=1e-12)


@pytest.mark.parametrize(
    "direction",
    [
        (1.0, 0.0, 0.0),  # in the plane
        (0.0, 1.0, 0.0),
        (1.0, 0.0, np.tan(np.radians(2.0))),  # 2 degrees off the plane
    ],
)
def test_a_view_grazing_the_plane_is_refused(direction):
    with pytest.raises(PointsError, match="surface plane found"):
        check_view_angle(direction)


def test_a_steep_enough_view_is_accepted():
    check_view_angle((1.0, 0.0, np.tan(np.radians(5.0))))
    check_view_angle((0.0, 0.0, -1.0))


def test_the_zero_view_is_refused():
    with pytest.raises(PointsError, match="zero vector"):
        check_view_angle((0.0, 0.0, 0.0))


def test_sign_of_the_sum_of_cubes_is_that_of_the_powers():
    """canonical_rotation turns its major axis by the sign of the inliers' third moment: the sign
    from cheap products must be the one the powers give, also on symmetric surfaces where the sum is
    round-off (there the powers decide)."""
    from holecli.geometry.frame import _negative_sum_of_cubes

    rng = np.random.default_rng(7)
    for trial in range(400):
        values = rng.normal(0.0, 10.0 ** rng.uniform(-3, 3), int(rng.integers(1, 5000)))
        if trial % 2:  # symmetric: every value and its opposite, in any order
            values = rng.permutation(np.concatenate([values, -values]))
        assert _negative_sum_of_cubes(values) == (float(np.sum(values ** 3)) < 0.0)
