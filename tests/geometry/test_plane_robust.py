"""Tests of holecli.geometry.plane.fit_plane_robust: the plane of the dominant surface, whatever else is scanned."""

import numpy as np
import pytest

from holecli.errors import PointsError
from holecli.geometry.plane import PlaneFit, fit_plane_robust
from holecli.simulation.synth import (
    BORE,
    COUNTERSINK,
    MATERIAL,
    HoleSpec,
    SceneSpec,
    make_scan,
    random_rotation,
    rotation_matrix,
)


def angle_deg(a, b):
    cosine = abs(float(np.dot(a, b))) / (np.linalg.norm(a) * np.linalg.norm(b))
    return float(np.degrees(np.arccos(min(1.0, cosine))))


def face(rng, count, normal_sigma=0.0, size=8.0):
    """``count`` points on z = 0 over a square of ``size``, with Gaussian noise along z."""
    xy = rng.uniform(-size / 2, size / 2, (count, 2))
    return np.column_stack([xy, rng.normal(0.0, normal_sigma, count) if normal_sigma else np.zeros(count)])


def posed(points, seed=3, shift=(769.0, -83.6, 218.8)):
    rotation = random_rotation(seed)
    return points @ rotation.T + shift, rotation @ [0.0, 0.0, 1.0]


def test_exact_on_exact_data(rng):
    points, normal = posed(face(rng, 3000))
    fit = fit_plane_robust(points)
    assert isinstance(fit, PlaneFit)
    assert angle_deg(fit.normal, normal) < 1e-9
    assert fit.normal[2] > 0  # the package's sign convention
    assert np.linalg.norm(fit.normal) == pytest.approx(1.0, abs=1e-12)
    assert abs((fit.point - points.mean(axis=0)) @ fit.normal) < 1e-9
    assert fit.rms < 1e-9
    assert fit.inliers.all()


def test_inlier_mask(rng):
    plane = face(rng, 2000, 0.01)
    outliers = np.column_stack([rng.uniform(-4, 4, (200, 2)), rng.uniform(0.5, 3.0, 200)])
    points, _ = posed(np.concatenate([plane, outliers]))
    fit = fit_plane_robust(points)
    assert fit.inliers.dtype == bool and fit.inliers.shape == (len(points),)
    assert fit.inlier_count == fit.inliers.sum()
    assert not fit.inliers[2000:].any()
    assert fit.inliers[:2000].mean() > 0.99  # within 4 robust sigma
    distance = (points - fit.point) @ fit.normal
    assert fit.rms == pytest.approx(np.sqrt(np.mean(distance[fit.inliers] ** 2)), rel=1e-9)
    np.testing.assert_allclose(fit.point, points[fit.inliers].mean(axis=0), atol=1e-9)


@pytest.mark.parametrize("sigma", [0.0, 0.01])
def test_ignores_30_percent_gross_outliers(rng, sigma):
    plane = face(rng, 3500, sigma)
    outliers = rng.uniform(-4.0, 4.0, (1500, 3))  # 30 % of all points, through and around the plane
    points, normal = posed(np.concatenate([plane, outliers]))
    fit = fit_plane_robust(points)
    assert angle_deg(fit.normal, normal) < (1e-6 if sigma == 0 else 0.05)
    # Outliers kept are only those that happen to fall within the band.
    assert fit.inliers[3500:].mean() < 0.05
    assert fit.inliers[:3500].mean() > (0.999 if sigma == 0 else 0.99)


@pytest.mark.parametrize("noise", [0.0, 0.01])
def test_ignores_bore_wall_countersink_and_inside_points(noise):
    hole = HoleSpec(center=(1.0, 1.0), diameter=3.0, bore_depth=3.0, countersink_diameter=4.0, inside_points=200)
    scene = SceneSpec(holes=(hole,), spacing=0.1, noise_normal=noise)
    scan = make_scan(scene, 0)
    fit = fit_plane_robust(scan.points)
    truth = scan.truth["holes"][0]["normal"]
    assert angle_deg(fit.normal, truth) < (1e-9 if noise == 0 else 0.02)
    assert fit.inliers[scan.labels == MATERIAL].mean() > 0.99
    assert fit.inliers[scan.labels == BORE].mean() < 0.05
    # Cone points near the surface are within the band (the noisier, the more of them).
    assert fit.inliers[scan.labels == COUNTERSINK].mean() < 0.3


@pytest.mark.parametrize("share", [0.5, 0.8])
def test_picks_the_dominant_of_two_faces(rng, share):
    """Two perpendicular faces with the same noise: the one with more points is the plane."""
    big = face(rng, 4000, 0.01)
    small = face(rng, int(share * 4000), 0.01) @ rotation_matrix((90.0, 0.0, 0.0)).T + [0.0, 4.0, 4.0]
    points, normal = posed(np.concatenate([big, small]))
    fit = fit_plane_robust(points)
    assert angle_deg(fit.normal, normal) < 0.05
    assert fit.inliers[:4000].mean() > 0.99
    assert fit.inliers[4000:].mean() < 0.05


def test_an_exact_smaller_face_does_not_beat_a_noisy_dominant_one(rng):
    big = face(rng, 4000, 0.01)
    small = face(rng, 2000) @ rotation_matrix((90.0, 0.0, 0.0)).T + [0.0, 4.0, 4.0]
    points, normal = posed(np.concatenate([big, small]))
    fit = fit_plane_robust(points)
    assert angle_deg(fit.normal, normal) < 0.05


def test_random_source_changes_nothing_beyond_round_off(rng):
    plane = face(rng, 3000, 0.01)
    outliers = rng.uniform(-4.0, 4.0, (600, 3))
    points, _ = posed(np.concatenate([plane, outliers]))
    first = fit_plane_robust(points, rng=0)
    for seed in (1, 2, np.random.default_rng(5)):
        other = fit_plane_robust(points, rng=seed)
        assert angle_deg(other.normal, first.normal) < 1e-9
        np.testing.assert_array_equal(other.inliers, first.inliers)


@pytest.mark.parametrize("points, match", [
    (np.zeros((2, 3)), "plane needs"),
    (np.zeros((10, 2)), "plane needs"),
    (np.column_stack([np.arange(10.0)] * 3), "collinear"),
])
def test_unusable_points(points, match):
    with pytest.raises(PointsError, match=match):
        fit_plane_robust(points)
