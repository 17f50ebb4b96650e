"""Tests of holecli.robust.edge.fit_edge: outer envelope of the rim points, then a clipped circle fit."""

import functools

import numpy as np
import pytest

from holecli.robust.boundary import hole_rim
from holecli.robust.edge import fit_edge
from holecli.robust.sampling import estimate_sampling
from holecli.simulation.synth import MATERIAL, HoleSpec, SceneSpec, make_scan

CENTER = np.array([3.21, -1.7])
RADIUS = 1.5
DEPTH = 0.18  # alpha of a 0.1 mm grid
FLOOR = 0.005  # 0.05 h
CLIP = 3.0


def circle_points(count, radius=RADIUS, center=CENTER, phase=0.1):
    angles = phase + np.linspace(0.0, 2 * np.pi, count, endpoint=False)
    return center + radius * np.column_stack([np.cos(angles), np.sin(angles)])


def test_exact_rim():
    fit, used = fit_edge(circle_points(40), DEPTH, FLOOR, CLIP)
    np.testing.assert_allclose(fit.center, CENTER, atol=1e-9)
    assert fit.radius == pytest.approx(RADIUS, abs=1e-9)
    assert used.all() and used.dtype == bool
    assert fit.rms < 1e-9


def test_points_deeper_in_the_hole_are_dropped():
    edge = circle_points(60)
    deep = circle_points(8, radius=RADIUS - 0.4, phase=0.3)
    fit, used = fit_edge(np.concatenate([edge, deep]), DEPTH, FLOOR, CLIP)
    assert fit.radius == pytest.approx(RADIUS, abs=1e-9)
    np.testing.assert_allclose(fit.center, CENTER, atol=1e-9)
    assert used[:60].all() and not used[60:].any()


def test_noisy_rim_with_gross_outliers():
    # Over 100 draws: the circle within 0.005 and the outliers dropped every time; the outliers'
    # sector loses a few edge points to the envelope, more than 5 % of them in under one draw in ten.
    few_kept = []
    for seed in range(100):
        rng = np.random.default_rng(seed)
        edge = circle_points(120) + rng.normal(0.0, 0.01, (120, 2))
        outliers = CENTER + rng.uniform(1.3, 1.6, (6, 1)) * np.array([[2.0, 0.0]])
        fit, used = fit_edge(np.concatenate([edge, outliers]), DEPTH, FLOOR, CLIP)
        assert fit.radius == pytest.approx(RADIUS, abs=0.005), seed
        assert np.linalg.norm(fit.center - CENTER) < 0.005, seed
        assert not used[120:].any(), seed
        assert used[:120].mean() > 0.9, seed
        if used[:120].mean() <= 0.95:
            few_kept.append(seed)
    assert len(few_kept) < 10, few_kept


def test_start_gives_the_same_circle():
    rim = circle_points(40) + 0.001 * np.sin(np.arange(40))[:, None]
    free, _ = fit_edge(rim, DEPTH, FLOOR, CLIP)
    started, _ = fit_edge(rim, DEPTH, FLOOR, CLIP, start=(CENTER + 0.05, RADIUS + 0.05))
    np.testing.assert_allclose(started.center, free.center, atol=1e-9)
    assert started.radius == pytest.approx(free.radius, abs=1e-9)


@pytest.mark.parametrize("rim", [
    pytest.param(circle_points(4), id="too-few"),
    pytest.param(np.column_stack([np.linspace(0, 1, 20), np.linspace(0, 2, 20)]), id="collinear"),
])
def test_degenerate_rims_give_no_fit(rim):
    fit, used = fit_edge(rim, DEPTH, FLOOR, CLIP)
    assert fit is None
    assert used.shape == (len(rim),)


STRIPES_PITCH = 0.3


@functools.cache
def stripes_rim(seed):
    """Rim points of a 3 mm hole in a striped scan (h = 0.1, pitch 0.3 mm), as the robust pipeline
    extracts them (the alpha-shape rim of the surface points around the hole), after a rigid motion in
    the plane: a round rim with runs of points along the scan lines that are collinear up to round-off.

    Returns the rim, the hole's center after the motion and the sampling's gap.
    """
    rng = np.random.default_rng(seed)
    center = rng.uniform(-0.5, 0.5, 2)
    scene = SceneSpec(holes=(HoleSpec(center=tuple(center), diameter=2.0 * RADIUS),), extent=(-2.5, 2.5, -2.5, 2.5),
                      spacing=0.1, pattern="stripes", line_pitch=STRIPES_PITCH,
                      scan_angle_deg=float(rng.uniform(0.0, 180.0)), rotation_deg=(0.0, 0.0, 0.0),
                      translation=(0.0, 0.0, 0.0))
    scan = make_scan(scene, seed)
    xy = scan.points[scan.labels == MATERIAL][:, :2]
    gap = estimate_sampling(xy).gap
    rim = hole_rim(xy, lambda positions: np.hypot(*(positions - center).T) < RADIUS, 2.5 * gap)
    angle = rng.uniform(0.0, 2.0 * np.pi)
    turn = np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
    shift = rng.uniform(-500.0, 500.0, 2)
    return xy[rim.index] @ turn.T + shift, turn @ center + shift, gap


@pytest.mark.parametrize("depth_gaps", [1.0, 2.5], ids=["envelope", "alpha"])
def test_a_rim_with_collinear_runs_gives_the_hole_in_any_order(depth_gaps):
    # Over 12 scans (hole position, scan angle, motion) and 6 orders of the rim points each: a fit
    # every time, the same circle in every order, and the hole's edge: the rim lies outside the
    # edge by less than half a line pitch, its center on the hole's within h / 2.
    for seed in range(12):
        rim, center, gap = stripes_rim(seed)
        radii = []
        for order_seed in range(-1, 5):
            order = np.arange(len(rim)) if order_seed < 0 else np.random.default_rng(order_seed).permutation(len(rim))
            fit, _ = fit_edge(rim[order], depth_gaps * gap, 0.005, CLIP)
            assert fit is not None, (seed, order_seed)
            assert np.hypot(*(fit.center - center)) < 0.05, (seed, order_seed, fit.center, center)
            radii.append(fit.radius)
        assert np.ptp(radii) < 1e-9, (seed, radii)
        assert RADIUS < radii[0] < RADIUS + 0.5 * STRIPES_PITCH, (seed, radii[0])
