"""Tests of holecli.registration.rigid: exact recovery, covariance against Monte Carlo, weights, degenerate hole sets."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from holecli.registration.rigid import ROTATION_ABOUT_LINE, ROTATION_ABOUT_NORMAL, fit_rigid
from holecli.registration.transform import RegistrationError, RigidTransform


def _unit(vectors):
    return vectors / np.linalg.norm(vectors, axis=-1, keepdims=True)


def _plate(rng, count):
    """Holes on a plate about 120 mm across, normals near +z."""
    centers = np.column_stack([rng.uniform(-60, 60, (count, 2)), rng.uniform(-3, 3, count)])
    normals = _unit(np.array([0, 0, 1.0]) + rng.normal(0, 0.05, (count, 3)))
    return centers, normals


def _random_transform(rng):
    return RigidTransform(Rotation.random(random_state=rng).as_matrix(), rng.uniform(-500, 500, 3))


def _perturb_normals(rng, normals, sigma_rad):
    # Two perpendicular components, each N(0, sigma^2): the model fit_rigid's normal sigma describes.
    noise = rng.normal(0, sigma_rad, normals.shape)
    noise -= np.sum(noise * normals, axis=1, keepdims=True) * normals
    return _unit(normals + noise)


def _anisotropic_noise(rng, normals, inplane, along):
    noise = rng.normal(0, inplane, normals.shape)
    noise -= np.sum(noise * normals, axis=1, keepdims=True) * normals
    return noise + rng.normal(0, along, (len(normals), 1)) * normals


@pytest.mark.parametrize("seed", range(40))
def test_exact_recovery_of_random_transforms(seed):
    rng = np.random.default_rng(seed)
    count = 3 + seed % 3
    centers, normals = _plate(rng, count)
    truth = _random_transform(rng)
    fit = fit_rigid(centers, normals, truth.apply_points(centers), truth.apply_directions(normals))
    np.testing.assert_allclose(fit.transform.rotation, truth.rotation, atol=1e-9)
    np.testing.assert_allclose(fit.transform.translation, truth.translation, atol=1e-9)
    assert fit.rms < 1e-9 and fit.free_dofs == () and fit.dof == 5 * count - 6
    assert np.max(fit.residuals.normal_angle_deg) < 1e-6


def test_exact_recovery_from_scattered_3d_holes_and_sigmas(rng):
    for _ in range(20):
        centers = rng.uniform(-200, 200, (4, 3))
        normals = _unit(rng.normal(size=(4, 3)))
        truth = _random_transform(rng)
        fit = fit_rigid(centers, normals, truth.apply_points(centers), truth.apply_directions(normals),
                        center_sigma_inplane=[0.01, 0.02, 0.01, 0.05], center_sigma_normal=0.03, normal_sigma_deg=0.2)
        np.testing.assert_allclose(fit.transform.matrix, truth.matrix, atol=1e-9)
        assert fit.covariance_source == "sigmas" and np.all(np.isfinite(fit.covariance))


def test_covariance_matches_monte_carlo():
    rng = np.random.default_rng(7)
    centers, normals = _plate(rng, 4)
    truth = _random_transform(rng)
    measured, measured_normals = truth.apply_points(centers), truth.apply_directions(normals)
    inplane, along, normal_deg = 0.005, 0.02, 0.1
    translations, rotations, predicted = [], [], None
    for _ in range(300):
        noisy_normals = _perturb_normals(rng, measured_normals, np.radians(normal_deg))
        noisy = measured + _anisotropic_noise(rng, measured_normals, inplane, along)
        fit = fit_rigid(centers, normals, noisy, noisy_normals, center_sigma_inplane=inplane,
                        center_sigma_normal=along, normal_sigma_deg=normal_deg)
        translations.append(fit.transform.translation)
        rotations.append(Rotation.from_matrix(fit.transform.rotation @ truth.rotation.T).as_rotvec())
        predicted = fit.covariance
    ratio_t = np.std(translations, axis=0, ddof=1) / np.sqrt(np.diag(predicted)[3:])
    ratio_w = np.std(rotations, axis=0, ddof=1) / np.sqrt(np.diag(predicted)[:3])
    # 300 trials: the sample std's relative standard error is about 4 %; 15 % is about 3.5 of them.
    assert np.all(np.abs(ratio_t - 1) < 0.15), ratio_t
    assert np.all(np.abs(ratio_w - 1) < 0.15), ratio_w


def test_covariance_from_residuals_scales_with_noise():
    rng = np.random.default_rng(11)
    centers, normals = _plate(rng, 5)
    truth = _random_transform(rng)
    sigma = 0.01
    # Without sigmas the normals weigh as sigma_center / L radians (L the holes' rms spread) and the
    # residuals give the common scale: noise drawn in that ratio is the model the covariance assumes.
    spread = np.sqrt(np.mean(np.sum((centers - centers.mean(axis=0)) ** 2, axis=1)))
    translations, predicted = [], []
    for _ in range(300):
        noisy = truth.apply_points(centers) + rng.normal(0, sigma, (5, 3))
        noisy_normals = _perturb_normals(rng, truth.apply_directions(normals), sigma / spread)
        fit = fit_rigid(centers, normals, noisy, noisy_normals)
        translations.append(fit.transform.translation)
        predicted.append(np.diag(fit.covariance)[3:])
        assert fit.covariance_source == "residuals"
    # The residual-scaled variance is right on average (its scatter from 19 dof is large per trial).
    ratio = np.std(translations, axis=0, ddof=1) / np.sqrt(np.mean(predicted, axis=0))
    assert np.all(np.abs(ratio - 1) < 0.2), ratio


def test_exact_fit_with_residual_covariance_has_none():
    rng = np.random.default_rng(3)
    centers, normals = _plate(rng, 1)
    fit = fit_rigid(centers, normals, centers + 1.0, normals)
    assert fit.dof == 0 and np.all(np.isnan(fit.covariance))


def test_a_hole_with_a_big_sigma_pulls_less():
    rng = np.random.default_rng(5)
    centers, normals = _plate(rng, 5)
    truth = _random_transform(rng)
    measured = truth.apply_points(centers)
    measured[0] += truth.apply_directions([0.3, 0.0, 0.0])
    args = (centers, normals, measured, truth.apply_directions(normals))
    equal = fit_rigid(*args, center_sigma_inplane=0.01)
    loose = fit_rigid(*args, center_sigma_inplane=[1.0, 0.01, 0.01, 0.01, 0.01])
    error_equal = np.abs(equal.transform.apply_points(centers[1:]) - measured[1:]).max()
    error_loose = np.abs(loose.transform.apply_points(centers[1:]) - measured[1:]).max()
    assert error_loose < 0.01 * error_equal
    assert loose.residuals.magnitude[0] == pytest.approx(0.3, abs=1e-3)


def test_the_along_normal_sigma_is_used():
    # Every hole measured 0.1 too high along its normal, but that direction is weighted 1e4 times less:
    # the fit follows the in-plane positions and reports the offset along the normals.
    rng = np.random.default_rng(8)
    centers, normals = _plate(rng, 4)
    truth = _random_transform(rng)
    measured_normals = truth.apply_directions(normals)
    measured = truth.apply_points(centers)
    measured[1] += 0.1 * measured_normals[1]
    fit = fit_rigid(centers, normals, measured, measured_normals, center_sigma_inplane=0.001, center_sigma_normal=0.1)
    assert fit.residuals.along_normal[1] > 0.05
    assert np.max(fit.residuals.in_plane) < 0.01


def test_one_hole_leaves_the_rotation_about_its_normal_free(rng):
    for _ in range(10):
        centers, normals = _plate(rng, 1)
        truth = _random_transform(rng)
        measured, measured_normals = truth.apply_points(centers), truth.apply_directions(normals)
        fit = fit_rigid(centers, normals, measured, measured_normals, center_sigma_inplane=0.01, normal_sigma_deg=0.1)
        assert fit.free_dofs == (ROTATION_ABOUT_NORMAL,)
        np.testing.assert_allclose(fit.transform.apply_points(centers), measured, atol=1e-9)
        np.testing.assert_allclose(fit.transform.apply_directions(normals), measured_normals, atol=1e-9)
        # The shortest rotation taking the nominal normal onto the measured one.
        angle = np.arccos(np.clip(normals[0] @ measured_normals[0], -1, 1))
        assert np.linalg.norm(fit.transform.rotation_vector) == pytest.approx(angle, abs=1e-9)
        # The free direction is a rotation about the measured normal, through the measured center.
        free = fit.free_directions[0]
        assert abs(abs(_unit(free[:3]) @ measured_normals[0]) - 1) < 1e-9
        assert np.all(np.isinf(np.diag(fit.covariance)[:3][np.abs(free[:3]) > 1e-6]))
        # The hole itself and its axis stay determined.
        assert np.all(np.isfinite(fit.point_covariance(centers[0])))
        assert np.isfinite(fit.direction_uncertainty_deg(normals[0]))


def test_two_holes_are_fixed_by_their_normals(rng):
    centers, normals = _plate(rng, 2)
    truth = _random_transform(rng)
    fit = fit_rigid(centers, normals, truth.apply_points(centers), truth.apply_directions(normals))
    assert fit.free_dofs == ()
    np.testing.assert_allclose(fit.transform.matrix, truth.matrix, atol=1e-9)


@pytest.mark.parametrize("count", [2, 3, 5])
def test_collinear_holes_with_normals_along_their_line(rng, count):
    direction = _unit(rng.normal(size=3))
    centers = np.outer(np.linspace(-50, 50, count), direction) + rng.normal(size=3)
    normals = np.tile(direction, (count, 1))
    truth = _random_transform(rng)
    measured = truth.apply_points(centers)
    fit = fit_rigid(centers, normals, measured, truth.apply_directions(normals))
    assert fit.free_dofs == (ROTATION_ABOUT_LINE,)
    np.testing.assert_allclose(fit.transform.apply_points(centers), measured, atol=1e-9)
    assert np.linalg.norm(fit.transform.rotation_vector) == pytest.approx(
        np.arccos(np.clip(direction @ truth.apply_directions(direction), -1, 1)), abs=1e-9
    )
    # A point off the line is undetermined, the holes themselves are not.
    off = fit.point_covariance(centers[0] + np.cross(direction, [1.0, 0.0, 0.0]) * 10)
    assert np.any(np.isinf(off))
    assert fit.dof == 5 * count - 5


def test_collinear_holes_with_sideways_normals_are_determined(rng):
    centers = np.column_stack([np.linspace(-50, 50, 3), np.zeros(3), np.zeros(3)])
    normals = np.tile([0, 0, 1.0], (3, 1))
    truth = _random_transform(rng)
    fit = fit_rigid(centers, normals, truth.apply_points(centers), truth.apply_directions(normals))
    assert fit.free_dofs == ()
    np.testing.assert_allclose(fit.transform.matrix, truth.matrix, atol=1e-9)


def test_far_from_origin_is_well_conditioned(rng):
    centers, normals = _plate(rng, 4)
    centers = centers + 1e5
    truth = RigidTransform(Rotation.random(random_state=rng).as_matrix(), [2e5, -1e5, 3e5])
    fit = fit_rigid(centers, normals, truth.apply_points(centers), truth.apply_directions(normals))
    np.testing.assert_allclose(fit.transform.apply_points(centers), truth.apply_points(centers), atol=1e-7)


def _valid(count=3):
    rng = np.random.default_rng(0)
    centers, normals = _plate(rng, count)
    return [centers, normals, centers.copy(), normals.copy()]


@pytest.mark.parametrize(
    "change, match",
    [
        (lambda a: a.__setitem__(2, a[2][:2]), "measured_centers must hold 3 rows"),
        (lambda a: a.__setitem__(1, a[1][:, :2]), r"\(n, 3\)"),
        (lambda a: a.__setitem__(3, np.zeros((3, 3))), "zero vectors"),
        (lambda a: a.__setitem__(0, np.full((3, 3), np.nan)), "finite"),
        (lambda a: a.__setitem__(0, np.zeros((0, 3))), "at least one hole"),
    ],
)
def test_bad_inputs_raise(change, match):
    args = _valid()
    change(args)
    with pytest.raises(RegistrationError, match=match):
        fit_rigid(*args)


@pytest.mark.parametrize(
    "options, match",
    [
        ({"center_sigma_inplane": -1.0}, "> 0"),
        ({"center_sigma_inplane": [0.1, 0.1]}, r"\(3,\)"),
        ({"normal_sigma_deg": 0.1}, "needs center_sigma_inplane"),
    ],
)
def test_bad_sigmas_raise(options, match):
    with pytest.raises(ValueError, match=match):
        fit_rigid(*_valid(), **options)
