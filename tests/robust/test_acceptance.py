"""Counter-examples that pin the robust method's acceptance checks (issue 10).

Every named check of :func:`holecli.robust.measure.measure_candidate` (the ``check`` of a rejection,
``holecli detect --explain``) and the start of the robust circle fit is held here by a constructed
scene that it, and nothing else, gets right: removing or loosening the check makes a test below fail.
The scenes are plain grids with a cut-out of known shape (hand-made points), so that the reason each
check exists is in the scene itself.
"""

import math

import numpy as np
import pytest

from holecli.geometry.circle import fit_circle_robust
from holecli.pipeline import detect
from holecli.simulation.synth import HoleSpec, SceneSpec, make_scan

H = 0.08  # grid step, mm


def grid_without(removed, extent=(-6.0, 6.0, -6.0, 6.0), h=H):
    """A flat square grid scan (z = 0) of step ``h`` without the points where ``removed(u, v)``.

    Parameters
    ----------
    removed : callable
        ``removed(u, v) -> (n,) bool`` on the grid's coordinates: True where there is no material.
    extent : (4,) tuple of float
        ``(xmin, xmax, ymin, ymax)`` of the grid.
    h : float
        Grid step.

    Returns
    -------
    (m, 3) float
        The points kept.
    """
    u, v = np.meshgrid(np.arange(extent[0], extent[1] + 1e-9, h), np.arange(extent[2], extent[3] + 1e-9, h))
    u, v = u.ravel(), v.ravel()
    keep = ~removed(u, v)
    return np.column_stack([u[keep], v[keep], np.zeros(int(keep.sum()))])


def _checks(detection):
    return [rejection.check for rejection in detection.rejected]


# --- material_inside: a groove around a standing island is not a hole ----------------------------


def groove(inner, outer, bridge_deg=0.0):
    """The cut-out of a groove between radii ``inner`` and ``outer`` around the origin, except for a
    bridge of material ``bridge_deg`` wide at angle 0 (0: a closed ring, an O-ring groove seen from
    above; else a C-shaped slot around an island joined to the plate)."""
    def removed(u, v):
        rho = np.hypot(u, v)
        angle = np.degrees(np.abs(np.arctan2(v, u)))
        return (rho > inner) & (rho < outer) & (angle > 0.5 * bridge_deg)
    return removed


@pytest.mark.parametrize("inner, bridge_deg", [
    pytest.param(1.5, 0.0, id="o-ring-groove"),
    pytest.param(1.5, 90.0, id="c-slot"),
    # The island fills 0.64 of the inner half of the 4 mm circle (0.69 of its surface points with
    # the bridge): a limit of 0.7 or more lets this through.
    pytest.param(0.8, 60.0, id="c-slot-small-island"),
])
def test_a_groove_around_an_island_is_no_hole(inner, bridge_deg):
    """The outer rim of a groove is a good 4 mm circle and material surrounds it: before the check the
    groove was reported as a full 4 mm hole, its island standing inside."""
    detection = detect(grid_without(groove(inner, 2.0, bridge_deg)))
    assert detection.holes == (), [(hole.diameter, hole.partial) for hole in detection.holes]
    (rejection,) = [r for r in detection.rejected if r.check == "material_inside"]
    assert rejection.value > rejection.limit
    assert rejection.diameter == pytest.approx(4.0, abs=0.1)


def test_a_hole_of_the_same_size_passes_the_check():
    detection = detect(grid_without(lambda u, v: np.hypot(u, v) < 2.0))
    assert len(detection.holes) == 1 and detection.rejected == ()
    assert detection.holes[0].diameter == pytest.approx(4.0, abs=0.25 * H)


# --- not_round: an oval cut-out is not a hole ------------------------------------------------------


def ellipse(ratio, minor=1.5):
    """The cut-out of an ellipse with semi-axes ``ratio * minor`` (along x) and ``minor``."""
    return lambda u, v: (u / (ratio * minor)) ** 2 + (v / minor) ** 2 < 1.0


def test_an_oval_cut_out_is_not_round():
    """A 4.5 x 3 mm ellipse (axis ratio 1.5): its rim's robust radial scatter is about 1.5 times the
    limit (6 % of the radius plus half a gap), so a limit half as large again lets it pass as a
    hole of its mean diameter."""
    detection = detect(grid_without(ellipse(1.5)))
    assert detection.holes == (), [hole.diameter for hole in detection.holes]
    (rejection,) = [r for r in detection.rejected if r.check == "not_round"]
    assert 1.3 * rejection.limit < rejection.value < 2.0 * rejection.limit
    assert abs(rejection.shape["direction"][0]) == pytest.approx(1.0, abs=1e-3)


def test_a_slightly_oval_hole_is_still_a_hole():
    """Axis ratio 1.05 (a worn or drifted drill): round within the limit, reported with its roundness."""
    detection = detect(grid_without(ellipse(1.05)))
    (hole,) = detection.holes
    assert hole.diameter == pytest.approx(1.5 * 2.05, abs=2 * H)
    assert hole.roundness > 0.05  # the ovality shows in the fit's roundness


# --- full_arc_deg: a hole whose surroundings miss a wedge of scan is partial -----------------------


def hole_with_dropout(wedge_deg, center=(0.37, -0.21), radius=1.5, reach=0.7):
    """A 3 mm hole and a wedge of missing scan (a shadow, a dropout) ``wedge_deg`` wide at 30 degrees,
    from the hole's edge to ``reach`` beyond it."""
    def removed(u, v):
        du, dv = u - center[0], v - center[1]
        rho = np.hypot(du, dv)
        angle = np.degrees(np.arctan2(dv, du))
        return (rho < radius) | ((rho < radius + reach) & (np.abs(angle - 30.0) < 0.5 * wedge_deg))
    return removed


def test_a_hole_missing_a_wedge_of_its_surroundings_is_partial():
    """An 18 degree dropout next to the hole leaves scanned material around about 344 degrees of the
    circle: a partial hole (full_arc_deg 350). At 340 it was reported full, arc 360, with 18 degrees
    of its edge never seen."""
    detection = detect(grid_without(hole_with_dropout(18.0)))
    (hole,) = detection.holes
    assert hole.partial
    assert 340.0 < hole.arc_deg < 350.0
    assert hole.diameter == pytest.approx(3.0, abs=0.35 * H)


def test_a_hole_missing_a_narrow_wedge_is_full():
    """A 6 degree dropout leaves the occupancy grid's ring around the hole closed: a full hole."""
    detection = detect(grid_without(hole_with_dropout(6.0)))
    (hole,) = detection.holes
    assert not hole.partial and hole.arc_deg == 360.0


# --- the start of the robust circle fit -------------------------------------------------------------


def rim_with_cluster(seed, rim=48, cluster=16, at=(0.3, 0.0), spread=0.05, noise=0.005):
    """``rim`` points on the unit circle (radial noise ``noise``) and a cluster of ``cluster`` points
    about ``at`` inside it (reflections that joined the rim): a quarter of the points are outliers."""
    rng = np.random.default_rng(seed)
    t = rng.uniform(0.0, 2.0 * math.pi, rim)
    points = np.column_stack([np.cos(t), np.sin(t)]) + rng.normal(0.0, noise, (rim, 2))
    return np.concatenate([points, np.asarray(at) + rng.normal(0.0, spread, (cluster, 2))])


def test_the_robust_fit_starts_from_the_least_quantile_circle():
    """14 reflections about (0.5, 0) inside a rim of 48: the algebraic fit of all the points leans toward
    the cluster and clipping from it keeps the cluster (center about 0.18 off, 47 of 50 seeds); the
    least-quantile circle through three rim points halves the 75th percentile of the residuals and
    starts the fit on the rim. (That it must halve it, not merely lower it, is held by the
    stripes-pitch-4h scene of test_robust_scenes.py: taking any better triple puts it 1.02 h small.)"""
    failures = {}
    for seed in range(20):
        fit = fit_circle_robust(rim_with_cluster(seed, cluster=14, at=(0.5, 0.0), spread=0.1))
        error = float(np.hypot(*fit.center))
        if error > 0.01 or abs(fit.radius - 1.0) > 0.01:
            failures[seed] = (round(error, 3), round(fit.radius, 3))
    assert not failures, failures


# --- surveyed failures (issue 10), not fixed ---------------------------------------------------------


@pytest.mark.xfail(strict=True, reason=(
    "tilt 70 deg, stripes, 10 % noise: 2 of seeds 0-29 break the contract, seed 13 (center 0.302 h, in "
    "test_robust_scenes) and seed 15 (diameter -0.392 h against 0.35 h; center 0.058 h); cause not found"))
def test_tilt_70_stripes_noise_seed_15():
    """The survey's failing tilt-70 scene (``panel("stripes", rotation_deg=(70, 0, 0), noise=0.1)`` of
    ``test_robust_scenes``), measured and not fixed: the contract is center within 0.25 h, diameter
    within 0.35 h."""
    h = 0.1
    hole = HoleSpec(center=(0.37, -0.21), diameter=3.0)
    scene = SceneSpec(holes=(hole,), extent=(-4.5, 4.5, -4.5, 4.5), spacing=h, pattern="stripes", line_pitch=3 * h,
                      scan_angle_deg=17.0, rotation_deg=(70.0, 0.0, 0.0), translation=(3.0, 4.0, 5.0),
                      noise_world_z=0.1 * h)
    scan = make_scan(scene, 15)
    (true,) = scan.truth["holes"]
    (found,) = detect(scan.points[np.all(np.isfinite(scan.points), axis=1)]).holes
    assert np.linalg.norm(np.subtract(found.center, true["center"])) < 0.25 * h
    assert abs(found.diameter - true["diameter"]) < 0.35 * h
