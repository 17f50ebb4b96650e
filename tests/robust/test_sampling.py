"""Tests of holecli.robust.sampling: spacing, gap scale and scan-line structure of the sampling."""

import numpy as np
import pytest

from holecli.errors import PointsError
from holecli.robust.sampling import estimate_sampling

H = 0.1


def lattice(step, pitch, angle_deg, along=60, across=None, offset=(0.013, 0.007)):
    """Points every ``step`` along lines ``pitch`` apart, the lines at ``angle_deg`` from x."""
    u, v = np.meshgrid(np.arange(along) * step, np.arange(across or along) * pitch)
    angle = np.radians(angle_deg)
    c, s = np.cos(angle), np.sin(angle)
    return np.column_stack([c * u.ravel() - s * v.ravel(), s * u.ravel() + c * v.ravel()]) + offset


def axis_angle_deg(direction, angle_deg, period=180.0):
    """Angle between a unit direction and the line at ``angle_deg``, modulo ``period`` degrees."""
    difference = (np.degrees(np.arctan2(direction[1], direction[0])) - angle_deg) % period
    return min(difference, period - difference)


@pytest.mark.parametrize("angle", [0.0, 23.0, 45.0, 80.0])
def test_square_grid(angle):
    sampling = estimate_sampling(lattice(H, H, angle))
    assert sampling.spacing == pytest.approx(H, rel=1e-9)
    # The empty circle of a grid cell: half its diagonal, 0.71 h.
    assert sampling.gap == pytest.approx(H / np.sqrt(2), rel=1e-6)
    assert sampling.lattice
    assert sampling.line_direction is None and sampling.line_pitch is None
    assert len(sampling.lattice_axes) == 2
    first, second = sampling.lattice_axes
    assert abs(first @ second) < 1e-9
    assert np.linalg.norm(first) == pytest.approx(1.0) and np.linalg.norm(second) == pytest.approx(1.0)
    assert axis_angle_deg(first, angle, period=90.0) < 0.01
    assert sampling.period == sampling.spacing


@pytest.mark.parametrize("pitch", [2 * H, 3 * H, 4 * H])
@pytest.mark.parametrize("angle", [17.0, 100.0])
def test_stripes(pitch, angle):
    sampling = estimate_sampling(lattice(H, pitch, angle, along=90, across=int(9.0 / pitch)))
    assert sampling.spacing == pytest.approx(H, rel=1e-9)
    assert sampling.line_pitch == pytest.approx(pitch, rel=1e-6)
    assert not sampling.lattice
    assert axis_angle_deg(sampling.line_direction, angle) < 0.01
    assert np.linalg.norm(sampling.line_direction) == pytest.approx(1.0)
    assert len(sampling.lattice_axes) == 1
    np.testing.assert_allclose(sampling.lattice_axes[0], sampling.line_direction)
    assert sampling.period == sampling.line_pitch
    # The empty circle between two lines: through two points on each, sqrt((p/2)^2 + (h/2)^2).
    assert sampling.gap == pytest.approx(np.hypot(pitch / 2, H / 2), rel=1e-6)


def test_random_sampling_has_no_lattice():
    for seed in range(10):  # 40 draws were within 6 % of the spacing below
        xy = np.random.default_rng(seed).uniform(0.0, 6.0, (3600, 2))  # density 1 / h^2
        sampling = estimate_sampling(xy)
        assert not sampling.lattice
        assert sampling.line_direction is None and sampling.line_pitch is None
        assert sampling.lattice_axes == ()
        assert sampling.period is None
        # Median nearest-neighbour distance of a Poisson process: sqrt(ln 2 / (pi density)) = 0.47 h.
        assert sampling.spacing == pytest.approx(np.sqrt(np.log(2) / np.pi) * H, rel=0.1), seed
        assert sampling.gap > sampling.spacing


def test_jittered_grid_keeps_its_axes_but_no_lines(rng):
    xy = lattice(H, H, 23.0) + rng.uniform(-0.25 * H, 0.25 * H, (3600, 2))
    sampling = estimate_sampling(xy)
    assert sampling.line_direction is None
    assert sampling.spacing < H


@pytest.mark.parametrize("factor", [0.001, 25.4])
def test_scale_free(factor):
    for xy in (lattice(H, H, 23.0), lattice(H, 3 * H, 17.0, along=90, across=30)):
        reference = estimate_sampling(xy)
        scaled = estimate_sampling(xy * factor)
        assert scaled.spacing == pytest.approx(reference.spacing * factor, rel=1e-9)
        assert scaled.gap == pytest.approx(reference.gap * factor, rel=1e-6)
        assert scaled.lattice == reference.lattice
        assert (scaled.line_pitch is None) == (reference.line_pitch is None)


def test_does_not_depend_on_the_point_order(rng):
    xy = rng.uniform(0.0, 6.0, (3000, 2))
    reference = estimate_sampling(xy)
    shuffled = estimate_sampling(xy[rng.permutation(len(xy))])
    assert shuffled.spacing == reference.spacing
    assert shuffled.gap == pytest.approx(reference.gap, rel=1e-12)


def test_a_hole_in_the_middle_does_not_change_the_spacing():
    xy = lattice(H, H, 23.0)
    center = xy.mean(axis=0)
    holed = xy[np.hypot(*(xy - center).T) > 1.5]
    sampling = estimate_sampling(holed)
    assert sampling.spacing == pytest.approx(H, rel=1e-9)
    assert sampling.lattice


@pytest.mark.parametrize("xy, match", [
    (np.zeros((5, 2)), "too few"),
    (np.zeros((50, 2)), "degenerate"),
])
def test_unusable_points(xy, match):
    with pytest.raises(PointsError, match=match):
        estimate_sampling(xy)
