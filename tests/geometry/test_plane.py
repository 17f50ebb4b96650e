"""Tests of holecli.geometry.plane: the paper's SVD plane fit and the sign convention of normals."""

import numpy as np
import pytest

from holecli.errors import PointsError
from holecli.geometry.plane import fit_plane_svd, orient_normal
from holecli.simulation import synth


def _plane_points(rng, normal, origin, count=400, extent=5.0, noise=0.0):
    """Points on the plane (origin, normal), uniform over a square, with Gaussian noise along the normal."""
    normal = np.asarray(normal, dtype=float) / np.linalg.norm(normal)
    e1 = np.cross(normal, [1.0, 0.0, 0.0] if abs(normal[0]) < 0.9 else [0.0, 1.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(normal, e1)
    uv = rng.uniform(-extent, extent, size=(count, 2))
    heights = rng.normal(0.0, noise, count) if noise else np.zeros(count)
    return np.asarray(origin) + uv[:, :1] * e1 + uv[:, 1:] * e2 + heights[:, None] * normal


def _same_axis(a, b):
    """1 - |cos| of the angle between two unit vectors (0 when parallel or antiparallel)."""
    return 1.0 - abs(float(np.dot(a, b)))


@pytest.mark.parametrize("normal", [(0.0, 0.0, 1.0), (0.3, -0.2, 0.9), (1.0, 2.0, -0.5), (0.0, 1.0, 0.0)])
def test_exact_on_exact_planar_points(rng, normal):
    points = _plane_points(rng, normal, origin=(1.0, -2.0, 3.0))
    fit = fit_plane_svd(points)
    unit = np.asarray(normal) / np.linalg.norm(normal)
    np.testing.assert_allclose(fit.normal, orient_normal(unit), atol=1e-12)
    np.testing.assert_allclose(fit.point, points.mean(axis=0), atol=1e-12)
    assert np.linalg.norm(fit.normal) == pytest.approx(1.0, abs=1e-12)
    assert fit.rms < 1e-12


def test_invariant_under_rigid_transforms(rng):
    points = _plane_points(rng, (0.2, 0.1, 1.0), origin=(0.0, 0.0, 0.0), noise=0.01)
    reference = fit_plane_svd(points)
    for seed in range(10):
        rotation = synth.random_rotation(seed)
        shift = rng.normal(0.0, 100.0, 3)
        fit = fit_plane_svd(points @ rotation.T + shift)
        assert _same_axis(fit.normal, rotation @ reference.normal) < 1e-12
        # Same axis and the sign given by the convention, not by the SVD.
        np.testing.assert_allclose(fit.normal, orient_normal(rotation @ reference.normal), atol=1e-12)
        np.testing.assert_allclose(fit.point, rotation @ reference.point + shift, atol=1e-9)
        assert fit.rms == pytest.approx(reference.rms, rel=1e-9)


@pytest.mark.parametrize(
    "normal, expected",
    [
        ((0.1, 0.2, -0.9), (-0.1, -0.2, 0.9)),  # z decides
        ((0.1, 0.2, 0.9), (0.1, 0.2, 0.9)),
        ((-0.6, -0.8, 0.0), (0.6, 0.8, 0.0)),  # z == 0: y decides
        ((0.6, 0.8, 0.0), (0.6, 0.8, 0.0)),
        ((-1.0, 0.0, 0.0), (1.0, 0.0, 0.0)),  # z == y == 0: x decides
        ((0.8, -0.6, 1e-14), (-0.8, 0.6, -1e-14)),  # z below the tolerance counts as 0
        ((0.8, 0.6, -1e-10), (-0.8, -0.6, 1e-10)),  # above it, z decides
    ],
)
def test_orient_normal_convention(normal, expected):
    np.testing.assert_array_equal(orient_normal(normal), expected)


def test_normal_points_up_whatever_the_side_of_the_cloud(rng):
    points = _plane_points(rng, (0.3, 0.4, -0.8), origin=(0.0, 0.0, 0.0))
    for flip in (1.0, -1.0):
        assert fit_plane_svd(flip * points).normal[2] > 0


def test_rms_is_the_rms_distance_from_the_plane(rng):
    sigma = 0.05
    points = _plane_points(rng, (0.5, -0.5, 1.0), origin=(10.0, 20.0, 30.0), count=4000, noise=sigma)
    fit = fit_plane_svd(points)
    residuals = (points - fit.point) @ fit.normal
    assert fit.rms == pytest.approx(np.sqrt(np.mean(residuals**2)), rel=1e-10)
    # and it estimates the noise: 4000 residuals give sigma to about 1 / sqrt(2 n) = 1.1 %
    assert fit.rms == pytest.approx(sigma, rel=0.05)


def test_fit_minimises_the_squared_distances(rng):
    points = _plane_points(rng, (0.0, 0.3, 1.0), origin=(0.0, 0.0, 0.0), noise=0.1)
    fit = fit_plane_svd(points)

    def rms(normal):
        normal = normal / np.linalg.norm(normal)
        return np.sqrt(np.mean(((points - fit.point) @ normal) ** 2))

    for _ in range(20):
        assert rms(fit.normal + rng.normal(scale=1e-3, size=3)) > fit.rms


@pytest.mark.parametrize(
    "points, match",
    [
        (np.outer(np.arange(10.0), (1.0, 2.0, 3.0)) + (4.0, 5.0, 6.0), "collinear"),
        (np.outer(np.linspace(-1, 1, 7), (0.1, 0.3, 0.7)), "collinear"),
        (np.tile((1.0, 2.0, 3.0), (5, 1)), "collinear"),
        (np.zeros((10, 2)), r"shape \(10, 2\)"),
        (np.zeros((10, 4)), r"shape \(10, 4\)"),
        (np.zeros(9), r"shape \(9,\)"),
        (np.zeros((2, 3)), r"n >= 3.*shape \(2, 3\)"),
        (np.zeros((0, 3)), r"shape \(0, 3\)"),
    ],
)
def test_degenerate_inputs_raise(points, match):
    with pytest.raises(PointsError, match=match):
        fit_plane_svd(points)


def test_precise_far_from_the_origin(rng):
    normal = np.array([0.2, -0.1, 1.0])
    normal /= np.linalg.norm(normal)
    origin = np.array([769.0, -683.6, 218.8])
    assert np.linalg.norm(origin) > 1000.0
    points = _plane_points(rng, normal, origin, count=2000, extent=4.0)
    fit = fit_plane_svd(points)
    assert np.linalg.norm(fit.normal - normal) < 1e-9
    assert fit.rms < 1e-9


def test_accepts_lists_and_integers():
    fit = fit_plane_svd([[0, 0, 1], [1, 0, 1], [0, 1, 1], [1, 1, 1]])
    np.testing.assert_allclose(fit.normal, (0.0, 0.0, 1.0), atol=1e-15)
    np.testing.assert_allclose(fit.point, (0.5, 0.5, 1.0))
