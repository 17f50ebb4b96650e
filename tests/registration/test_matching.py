"""Tests of holecli.registration.matching: pairing by name, by mutual distances and by nearness; the leave-one-out outlier check."""

import time

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from holecli.registration.matching import MIN_HOLES_FOR_OUTLIERS, find_outliers, match_holes
from holecli.registration.rigid import fit_rigid
from holecli.registration.transform import RegistrationError, RigidTransform

NOISE = 0.005  # 5 um, in mm
NORMAL_NOISE_DEG = 0.1


def _unit(vectors):
    return vectors / np.linalg.norm(vectors, axis=-1, keepdims=True)


def _scene(rng, count):
    """A plate of ``count`` holes, a random pose, and its measurement with 5 um center noise."""
    centers = np.column_stack([rng.uniform(-60, 60, (count, 2)), rng.uniform(-5, 5, count)])
    normals = _unit(np.array([0, 0, 1.0]) + rng.normal(0, 0.05, (count, 3)))
    truth = RigidTransform(Rotation.random(random_state=rng).as_matrix(), rng.uniform(-200, 200, 3))
    measured = truth.apply_points(centers) + rng.normal(0, NOISE, (count, 3))
    measured_normals = _unit(truth.apply_directions(normals) + rng.normal(0, np.radians(NORMAL_NOISE_DEG), (count, 3)))
    return centers, normals, measured, measured_normals, truth


def _names(count):
    return [f"H{i}" for i in range(count)]


def test_match_by_names(rng):
    centers, _, measured, _, _ = _scene(rng, 5)
    order = rng.permutation(5)
    names = [f"H{i}" for i in order]
    names[2] = "not-a-hole"
    match = match_holes(_names(5), centers, measured[order], measured_names=names)
    assert match.method == "names"
    assert match.pairs == [(m, int(order[m])) for m in range(5) if m != 2]
    assert match.unmatched_measured == [2] and match.unmatched_nominal == [int(order[2])]


@pytest.mark.parametrize("seed", range(30))
def test_permuted_measured_order_is_matched_from_distances(seed):
    rng = np.random.default_rng(seed)
    count = 3 + seed % 6
    centers, _, measured, _, _ = _scene(rng, count)
    order = rng.permutation(count)
    match = match_holes(_names(count), centers, measured[order])
    assert match.method == "distances"
    assert match.pairs == [(m, int(order[m])) for m in range(count)]
    assert not match.ambiguous and match.rms < 5 * NOISE


def test_extra_and_missing_holes(rng):
    centers, _, measured, _, truth = _scene(rng, 7)
    # Measured: holes 0..4 and a spurious one; nominal holes 5 and 6 not measured.
    spurious = truth.apply_points([200.0, 200.0, 0.0])
    match = match_holes(_names(7), centers, np.vstack([measured[:5], spurious]))
    assert match.pairs == [(i, i) for i in range(5)]
    assert match.unmatched_measured == [5] and match.unmatched_nominal == [5, 6]


def test_nearest_after_an_initial_transform_for_one_or_two_holes(rng):
    centers, _, measured, _, truth = _scene(rng, 6)
    rough = RigidTransform(truth.rotation, truth.translation + 0.5)
    match = match_holes(_names(6), centers, measured[[4, 1]], initial_transform=rough)
    assert match.method == "nearest" and match.pairs == [(0, 4), (1, 1)]


def test_one_or_two_unnamed_holes_without_a_transform_raise(rng):
    centers, _, measured, _, _ = _scene(rng, 6)
    with pytest.raises(RegistrationError, match="give measured names or an initial transform"):
        match_holes(_names(6), centers, measured[:2])


def test_square_layout_is_reported_ambiguous():
    # Four holes on a square: the four turns in the plane and the four turned-over poses all fit.
    square = np.array([[0, 0, 0], [50, 0, 0], [50, 50, 0], [0, 50, 0]], dtype=float)
    match = match_holes(_names(4), square, square + [1.0, 2.0, 3.0])
    assert match.ambiguous and match.alternatives == 8
    assert len(match.pairs) == 4
    # the eight pairings are given (the best first) for register to choose among by the normals
    assert len(match.tied) == 8 and len(set(match.tied)) == 8 and list(match.tied[0]) == match.pairs


def test_planar_layout_matches_its_mirror_image():
    # The mirror image of a planar layout is the layout turned over (a proper rotation): the distances
    # cannot tell them apart, so a mirrored part is matched, not rejected (documented).
    rng = np.random.default_rng(4)
    plate = np.column_stack([rng.uniform(-60, 60, (5, 2)), np.zeros(5)])
    mirrored = plate * [-1.0, 1.0, 1.0]
    match = match_holes(_names(5), plate, mirrored)
    assert match.pairs == [(i, i) for i in range(5)] and match.rms < 1e-9
    # no tie: the turn-over is the only pairing (register's check normals_reversed refuses the fit)
    assert not match.ambiguous and match.tied == (tuple(match.pairs),)


def test_a_3d_layout_does_not_match_its_mirror_image():
    rng = np.random.default_rng(4)
    part = rng.uniform(-60, 60, (5, 3))
    match = match_holes(_names(5), part, part * [-1.0, 1.0, 1.0])
    assert len(match.pairs) < 5 or match.rms > 1.0


def test_twenty_holes_match_quickly(rng):
    centers, _, measured, _, _ = _scene(rng, 20)
    order = rng.permutation(20)
    start = time.perf_counter()
    match = match_holes(_names(20), centers, measured[order])
    assert time.perf_counter() - start < 10.0
    assert match.pairs == [(m, int(order[m])) for m in range(20)]


@pytest.mark.parametrize(
    "args, match",
    [
        ((["a"], np.zeros((2, 3)), np.zeros((3, 3))), "1 nominal names for 2"),
        ((["a", "a"], np.eye(3)[:2], np.zeros((3, 3))), "unique"),
        ((["a", "b"], np.zeros((2, 2)), np.zeros((3, 3))), r"\(n, 3\)"),
    ],
)
def test_match_bad_inputs(args, match):
    with pytest.raises(RegistrationError, match=match):
        match_holes(*args)


SIGMAS = {"center_sigma_inplane": NOISE, "normal_sigma_deg": NORMAL_NOISE_DEG}
SEEDS = 200


def test_a_displaced_hole_is_named():
    failures = 0
    for seed in range(SEEDS):
        rng = np.random.default_rng(1000 + seed)
        count = 4 + seed % 2
        centers, normals, measured, measured_normals, _ = _scene(rng, count)
        bad = int(rng.integers(count))
        measured[bad] += 0.2 * _unit(rng.normal(size=3))
        check = find_outliers(fit_rigid, centers, normals, measured, measured_normals, names=_names(count),
                              floor=0.02, **SIGMAS)
        failures += check.outliers != [f"H{bad}"]
    # Measured: 0 failures in 200 (the smallest standardized residual of the displaced hole was 6.2).
    assert failures <= SEEDS // 100


def test_no_false_outlier_with_noise_only():
    flagged = 0
    for seed in range(SEEDS):
        rng = np.random.default_rng(2000 + seed)
        count = 4 + seed % 3
        centers, normals, measured, measured_normals, _ = _scene(rng, count)
        check = find_outliers(fit_rigid, centers, normals, measured, measured_normals, floor=0.02, **SIGMAS)
        assert check.checked
        flagged += bool(check.outliers)
    assert flagged <= SEEDS // 100


def test_two_displaced_holes_among_six_are_both_named(rng):
    centers, normals, measured, measured_normals, _ = _scene(rng, 6)
    measured[1] += [0.3, 0.0, 0.0]
    measured[4] += [0.0, -0.25, 0.1]
    check = find_outliers(fit_rigid, centers, normals, measured, measured_normals, floor=0.02, **SIGMAS)
    assert sorted(check.outliers) == [1, 4]
    assert "standard uncertainties" in check.reason


def test_the_floor_keeps_small_offsets(rng):
    centers, normals, measured, measured_normals, _ = _scene(rng, 5)
    measured[2] += [0.2, 0.0, 0.0]
    check = find_outliers(fit_rigid, centers, normals, measured, measured_normals, floor=1.0, **SIGMAS)
    assert check.outliers == [] and check.predicted_residuals[2] > 0.1


def test_without_sigmas_the_residuals_set_the_scale(rng):
    named = 0
    for _ in range(20):
        centers, normals, measured, measured_normals, _ = _scene(rng, 5)
        measured[0] += [0.2, 0.0, 0.0]
        named += find_outliers(fit_rigid, centers, normals, measured, measured_normals, floor=0.02).outliers == [0]
    assert named >= 18


def test_three_holes_are_not_checked(rng):
    centers, normals, measured, measured_normals, _ = _scene(rng, MIN_HOLES_FOR_OUTLIERS - 1)
    check = find_outliers(fit_rigid, centers, normals, measured, measured_normals, floor=0.02)
    assert not check.checked and check.outliers == [] and "at least 4" in check.reason


def test_outliers_bad_inputs(rng):
    centers, normals, measured, measured_normals, _ = _scene(rng, 5)
    with pytest.raises(RegistrationError, match="one row per hole"):
        find_outliers(fit_rigid, centers, normals, measured[:4], measured_normals)
    with pytest.raises(RegistrationError, match="floor"):
        find_outliers(fit_rigid, centers, normals, measured, measured_normals, floor=-1.0)


def test_without_sigmas_noise_alone_is_rarely_flagged():
    # Measured: 2 of 200 flagged (4 to 5 holes); the scale from three holes' residuals is itself noisy.
    flagged = 0
    for seed in range(100):
        rng = np.random.default_rng(3000 + seed)
        centers, normals, measured, measured_normals, _ = _scene(rng, 4 + seed % 2)
        flagged += bool(find_outliers(fit_rigid, centers, normals, measured, measured_normals, floor=0.02).outliers)
    assert flagged <= 4


def test_a_displaced_hole_is_named_when_the_scans_are_far_more_precise_than_the_move():
    # A cell's scans measure a center to 0.25 um in the plane: a refit to three holes that still
    # hold the moved one is bent, its covariance does not know it, and it places a good hole further
    # off (0.29 mm) than the moved hole's own 0.2 mm. The candidate is the hole whose removal leaves
    # the others consistent (the refit's chi-square), not the largest standardized residual.
    in_plane, along, normal_deg = 0.25e-3, 0.03e-3, 3e-4
    failures = []
    for seed in range(100):
        rng = np.random.default_rng(3000 + seed)
        count = 4 + seed % 2
        centers = np.column_stack([rng.uniform(-150, 150, count), rng.uniform(-100, 100, count), np.zeros(count)])
        normals = np.tile([0.0, 0.0, 1.0], (count, 1))
        truth = RigidTransform(Rotation.from_euler("xyz", rng.uniform(-5, 5, 3), degrees=True).as_matrix(),
                               rng.uniform(-500, 500, 3))
        drilled = centers.copy()
        bad = int(rng.integers(count))
        angle = rng.uniform(0, 2 * np.pi)
        drilled[bad, :2] += 0.2 * np.array([np.cos(angle), np.sin(angle)])
        measured_normals = truth.apply_directions(normals)
        measured = truth.apply_points(drilled)
        measured += rng.normal(0, in_plane, (count, 3)) * [1, 1, 0] @ truth.rotation.T
        measured += np.outer(rng.normal(0, along, count), measured_normals[0])
        check = find_outliers(fit_rigid, centers, normals, measured, measured_normals, names=_names(count),
                              floor=0.02, center_sigma_inplane=np.full(count, in_plane),
                              center_sigma_normal=np.full(count, along), normal_sigma_deg=np.full(count, normal_deg))
        if check.outliers != [f"H{bad}"]:
            failures.append((seed, bad, check.outliers))
    assert len(failures) <= 1, failures
