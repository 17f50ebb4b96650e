"""Noise-free and quantised range data (issue 24, cases 1 and 2): a face whose heights sit on a few
discrete levels (a range computed in float32 or rounded to a quantum, float32 storage) keeps every
level in its band, a faceted CAD countersink is found on exact data, and no uncertainty collapses
below the data's resolution.

The scans come from holecli's own profiler (:mod:`noise_free_scans`): parallel or fan rays, zero
noise, float32 ranges, a range quantum of 1e-7 x standoff, float32 output in a far frame, tilts
0-25 deg, pitches 0.05-0.25 mm, countersinks of 82-100 deg and plain holes, polygons of 24-48
segments. Measured on seeds 0-199 (used while writing the fix): 2 of 200 wrong (a 24-gon plain hole
at a 0.37 mm line pitch, -138 um against 121; a 24-gon countersink -43.4 um against 42.6), against 99
of 200 before it; on the fresh seeds 1000-1149 of the slow test, 1 of 150.
"""

import math

import numpy as np
import pytest

from holecli.geometry.plane import LEVEL_LIMIT, fit_plane_robust, level_step
from holecli.pipeline import detect
from holecli.robust.estimators import CONE
from holecli.robust.uncertainty import edge_uncertainty, plane_uncertainty, resolution_uncertainty

from noise_free_scans import judge, noise_free_scan

STEP = float(np.spacing(np.float32(100.0)))  # a float32 range's ulp at 100 mm: 7.63e-6 mm


def _levels(count, shares, step, rng):
    """``count`` heights on the levels ``-k..k`` steps with the given shares (center first)."""
    k = len(shares) // 2
    return rng.choice(np.arange(-k, k + 1) * step, size=count, p=shares)


def test_level_step_of_quantised_heights():
    rng = np.random.default_rng(0)
    heights = _levels(5000, [0.26, 0.48, 0.26], STEP, rng)  # the noise-free parallel-ray plate: 48 % on one
    assert level_step(heights, 3e-7, 0.03) == pytest.approx(STEP)
    # blurred by a plane tilted a fraction of a step over the face: still levels
    blurred = heights + rng.uniform(-0.15, 0.15, len(heights)) * STEP
    assert level_step(blurred, 3e-7, 0.03) == pytest.approx(STEP, rel=0.1)


@pytest.mark.parametrize("case", ["one_level", "gaussian", "uniform", "too_coarse", "few"])
def test_level_step_is_zero_off_levels(case):
    rng = np.random.default_rng(1)
    heights = {"one_level": np.zeros(5000),
               "gaussian": rng.normal(0.0, 1e-5, 5000),       # noise: one run
               "uniform": rng.uniform(-2e-5, 2e-5, 300),     # sparse: many small runs
               "too_coarse": _levels(5000, [0.3, 0.4, 0.3], 0.05, rng),  # a step of the part, not a quantum
               "few": _levels(30, [0.3, 0.4, 0.3], STEP, rng)}[case]
    assert level_step(heights, 3e-7, 0.03) == 0.0


def _quantised_face(rng, count=20000, extent=30.0, height=12.7):
    xy = rng.uniform(-extent / 2, extent / 2, (count, 2))
    z = height + _levels(count, [0.26, 0.48, 0.26], STEP, rng)
    return np.column_stack([xy, z])


def test_quantised_face_keeps_every_level():
    """Without the level floor the band held one level: 48 % of the face."""
    face = _quantised_face(np.random.default_rng(2))
    plane = fit_plane_robust(face)
    assert plane.inliers.mean() == 1.0
    assert plane.resolution == pytest.approx(STEP)


def test_exact_face_keeps_the_round_off_floor():
    rng = np.random.default_rng(3)
    face = np.column_stack([rng.uniform(-15, 15, (5000, 2)), np.full(5000, 12.7)])
    plane = fit_plane_robust(face)
    assert plane.inliers.all()
    assert 0.0 < plane.resolution < 1e-6  # the round-off floor, no level step


def test_a_step_of_the_part_is_no_quantum():
    """A face 0.05 mm below the main one (beyond LEVEL_LIMIT of the 30 mm field) stays out of the band."""
    rng = np.random.default_rng(4)
    face = _quantised_face(rng)
    lower = face[:6000].copy()
    lower[:, 2] -= 0.05
    assert 0.05 > LEVEL_LIMIT * 30.0
    plane = fit_plane_robust(np.vstack([face[6000:], lower]))
    assert plane.inliers[:14000].all() and not plane.inliers[14000:].any()


def test_uncertainties_not_below_the_resolution():
    """On exact data every covariance is 0 (the height at the center came out 1.6e-17 mm)."""
    rng = np.random.default_rng(5)
    face = np.column_stack([rng.uniform(-5, 5, (400, 2)), np.zeros(400)])
    plane = fit_plane_robust(face)
    least = resolution_uncertainty(STEP)
    assert least == pytest.approx(STEP / math.sqrt(12.0))
    height, normal = plane_uncertainty(face, plane, np.zeros(3))
    assert height < 1e-12 and normal < 1e-12  # the covariance alone
    height, normal = plane_uncertainty(face, plane, np.zeros(3), resolution=STEP)
    assert height == pytest.approx(least)
    assert normal >= least / 5.0
    angles = np.linspace(0, 2 * np.pi, 60, endpoint=False)
    rim = 2.0 * np.column_stack([np.cos(angles), np.sin(angles)])
    u_center, u_diameter = edge_uncertainty(CONE, None, rim, np.zeros(2), 2.0, 0.0, 0.0,
                                            cone_covariance=np.zeros((3, 3)), resolution=STEP)
    assert u_center == pytest.approx(least) and u_diameter == pytest.approx(2 * least)


def _failures(seeds):
    failures = []
    for seed in seeds:
        points, truth, pitch, params = noise_free_scan(seed)
        problems = judge(detect(points), truth, pitch, points)
        if problems:
            failures.append((seed, params, problems))
    return failures


def test_noise_free_scans_quick():
    failures = _failures(range(8))
    assert not failures, failures


@pytest.mark.slow
def test_noise_free_scans_fresh_instances():
    """150 fresh instances: measured 1 wrong (seed 1095: a tilted view whose float32 heights are dithered
    over a few levels; its height u 5e-8 is below a level step's 1.1e-6)."""
    failures = _failures(range(1000, 1150))
    assert len(failures) <= 4, failures
