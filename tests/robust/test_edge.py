"""Tests of holecli.robust.edge.fit_edge: outer envelope of the rim points, then a clipped circle fit."""

import numpy as np
import pytest

from holecli.robust.edge import fit_edge

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


def test_noisy_rim_with_gross_outliers(rng):
    edge = circle_points(120) + rng.normal(0.0, 0.01, (120, 2))
    outliers = CENTER + rng.uniform(1.3, 1.6, (6, 1)) * np.array([[2.0, 0.0]])
    fit, used = fit_edge(np.concatenate([edge, outliers]), DEPTH, FLOOR, CLIP)
    assert fit.radius == pytest.approx(RADIUS, abs=0.005)
    assert np.linalg.norm(fit.center - CENTER) < 0.005
    assert not used[120:].any()
    assert used[:120].mean() > 0.95


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


# Rim points of a 3 mm hole in a striped scan (h = 0.1, pitch 0.3 mm) after a rigid motion of the
# cloud, as the robust pipeline extracted them (test_robust_properties, stripes, motion 3):
# a round rim (algebraic fit: radius 1.543, residuals within 0.062) with runs of points along the
# scan lines that are collinear up to round-off.
STRIPES_RIM = np.array([
    [0.038029904422945494, 1.182707930892903], [-1.1058127991663849, -0.89373707667302],
    [0.8378536040438277, 1.1659136007555118], [0.5749189411234175, -1.8292266902884624],
    [0.6748969035760259, -1.8313259815556364], [0.13800786687555622, 1.1806086396257252],
    [-0.06194805802966306, 1.1848072221600767], [1.587294313252543, -1.2503518282445334],
    [1.718761644712794, 0.24721831727743676], [-0.7184966969590092, -1.5020020164573662],
    [0.6378976791386087, 1.1701121832898567], [-1.1994928878174875, -0.5917038980480057],
    [-1.0121327105153326, -1.1957702552980098], [1.6935701495067095, -0.9525172321538885],
    [0.8748528284812491, -1.8355245640899887], [0.23798582932816656, 1.1785093483585543],
    [1.7998459857608302, -0.6546826360632265], [-0.16192602048227556, 1.1869065134272516],
    [0.3379637917807791, 1.1764100570913794], [-0.32488272095007725, -1.8103330688838966],
    [0.4379417542333855, 1.1743107658242091], [1.812441733363848, -0.05481486134755023],
    [-1.0806213039603003, 0.30599847275830516], [-0.024948833592243695, -1.8166309426854201],
    [-0.5681357440942276, 0.8953697911381093], [-0.1249267960448541, -1.8145316514182492],
    [0.5379197166860001, 1.1722114745570307], [-1.1931950140159773, -0.29177001069017267],
    [-0.22490475849746872, -1.8124323601510706], [1.5251035936090829, 0.551350787169625],
    [0.7378756415912191, 1.1680128920226858], [1.281062552093199, -1.5439878418008428],
    [1.906121822014951, -0.3568480399725646], [1.2314675800527595, 0.8575825483289815],
    [0.7748748660286364, -1.8334252728228075], [-1.186897140214465, 0.008163876667663173],
    [-0.8743675052535693, 0.601733777581796],
])


def test_a_rim_with_collinear_runs_gives_the_hole_in_any_order():
    depth, floor = 0.3953, 0.005
    radii = []
    for seed in range(-1, 40):
        order = np.arange(len(STRIPES_RIM)) if seed < 0 else np.random.default_rng(seed).permutation(len(STRIPES_RIM))
        fit, _ = fit_edge(STRIPES_RIM[order], depth, floor, CLIP)
        radii.append(np.inf if fit is None else fit.radius)
    assert np.all(np.abs(np.array(radii) - 1.543) < 0.01), radii
