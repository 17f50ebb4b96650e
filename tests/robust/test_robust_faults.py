"""Faults that used to give confidently wrong diameters on valid scenes (issue 8, item 3).

* One stray point far away (1e3 to 1e12 file units) must not change what is measured: the plane's
  noise floor comes from the surface's own points, never from the extent of the whole cloud.
* The visible flat floor of a blind hole is not a countersink cone (check ``"flat_floor"`` of
  :mod:`holecli.robust.estimators.cone`): the diameter is the bore's.

Each fault has a known-answer test on one scene, then a test over consecutive seeds of randomly
drawn scenes (hole size, pattern, noise, pose, fault) with a bound on the failures. More seeds than
the tests run::

    .venv/bin/python tests/robust/test_robust_faults.py --stray 400 --blind 400
"""

import argparse
import math
from dataclasses import replace

import numpy as np
import pytest

from holecli.geometry.plane import fit_plane_robust
from holecli.pipeline import detect
from holecli.robust.estimators.cone import Cone, NotACone, fit_cone_edge
from holecli.settings import DEFAULT_SETTINGS
from holecli.simulation.synth import BORE, COUNTERSINK, HoleSpec, SceneSpec, make_scan

pytestmark = pytest.mark.slow  # the quick loop: pytest -m "not slow"

H = 0.1
FAR = (769.0, -83.6, 218.8)
# Failures: a stray point moves the diameter by more than this (units of h) or changes the hole
# count; a blind hole is measured more than LOOSE h off (or not found).
STRAY_CHANGE = 0.05
LOOSE = 1.0


def countersunk(**changes):
    """The issue's scene: a 3 mm bore with a 4.5 mm, 100-degree countersink, 10 % h noise."""
    hole = HoleSpec(center=(0.37, -0.21), diameter=3.0, countersink_diameter=4.5, bore_depth=2.0)
    return SceneSpec(holes=(hole,), extent=(-4.5, 4.5, -4.5, 4.5), spacing=H, noise_world_z=0.1 * H,
                     translation=FAR, **changes)


def blind(depth, bore=True, pattern="grid", noise=0.1):
    hole = HoleSpec(center=(0.37, -0.21), diameter=3.0, bottom_depth=depth, bore_depth=depth if bore else 0.0)
    return SceneSpec(holes=(hole,), extent=(-4.5, 4.5, -4.5, 4.5), spacing=H, pattern=pattern,
                     line_pitch=3 * H if pattern == "stripes" else None, scan_angle_deg=17.0,
                     noise_world_z=noise * H)


def diameters(points):
    return [hole.diameter for hole in detect(points).holes]


# --- one stray point far away ----------------------------------------------------------------------


def stray_points(scan, kind, magnitude):
    """Where the stray point goes: the world corner (m, m, m); m along the normal from the hole's
    center, or from a point just inside its edge (where the countersink's cone is fitted); or m from
    the hole in the direction (1, 2, 3)."""
    truth = scan.truth["holes"][0]
    center, normal = np.asarray(truth["center"]), np.asarray(truth["normal"])
    if kind == "corner":
        return np.array([magnitude] * 3)
    if kind == "normal":
        return center + magnitude * normal
    if kind == "rim":
        across = np.cross(normal, [1.0, 0.0, 0.0] if abs(normal[0]) < 0.9 else [0.0, 1.0, 0.0])
        return center + 0.48 * truth["diameter"] * across / np.linalg.norm(across) + magnitude * normal
    return center + magnitude * np.array([1.0, 2.0, 3.0]) / math.sqrt(14.0)


@pytest.fixture(scope="module")
def countersunk_scan():
    scan = make_scan(countersunk(), 0)
    clean = diameters(scan.points)
    assert clean == [pytest.approx(4.5, abs=0.35 * H)]
    return scan, clean[0]


@pytest.mark.parametrize("kind", ["corner", "normal", "rim", "oblique"])
@pytest.mark.parametrize("magnitude", [1e3, 1e8, 1e12 / 2])
def test_one_stray_point_changes_nothing(countersunk_scan, kind, magnitude):
    """4.50 mm countersunk hole: 2.93 mm with a point at (1e8, 1e8, 1e8) before the fix."""
    scan, clean = countersunk_scan
    point = stray_points(scan, kind, magnitude)
    assert diameters(np.vstack([scan.points, point])) == [pytest.approx(clean, abs=STRAY_CHANGE * H)]
    # First in the cloud, too (the plane's working origin used to be the first point).
    assert diameters(np.vstack([point, scan.points])) == [pytest.approx(clean, abs=STRAY_CHANGE * H)]


def test_stray_point_leaves_the_plane_band_alone():
    scan = make_scan(countersunk(), 0)
    clean = fit_plane_robust(scan.points)
    fit = fit_plane_robust(np.vstack([scan.points, [1e8, 1e8, 1e8]]))
    assert fit.rms == pytest.approx(clean.rms, rel=1e-6)
    np.testing.assert_array_equal(fit.inliers[:-1], clean.inliers)
    assert not fit.inliers[-1]
    # Cone points near the edge are within the band, bore-wall points never.
    assert fit.inliers[:-1][scan.labels == BORE].mean() < 0.01
    assert fit.inliers[:-1][scan.labels == COUNTERSINK].mean() < 0.3


def test_exact_data_keeps_its_band_far_from_the_origin():
    """The round-off floor follows the surface's coordinates: exact data 1e6 away keeps all points."""
    scan = make_scan(SceneSpec(holes=(), spacing=0.2, translation=(1e6, -2e6, 5e5)), 0)
    fit = fit_plane_robust(np.vstack([scan.points, [1e11, 1e11, 1e11]]))
    assert fit.inliers[:-1].all() and not fit.inliers[-1]


# --- the floor of a blind hole ---------------------------------------------------------------------


@pytest.mark.parametrize("depth", [0.3, 0.6, 1.0])
@pytest.mark.parametrize("bore", [False, True], ids=["floor", "floor-and-wall"])
@pytest.mark.parametrize("pattern", ["grid", "stripes"])
def test_blind_hole_floor_is_not_a_countersink(depth, bore, pattern):
    """3.0 mm blind hole: 3.6-3.7 mm (a 'countersink' edge outside the hole) before the fix. A floor 0.3 mm
    down (0.1 diameters) is a pocket's (check 'pocket'): measured here with that check off, since the
    floor's being no cone is what is tested."""
    scan = make_scan(blind(depth, bore, pattern), 0)
    settings = replace(DEFAULT_SETTINGS, pocket_max_depth_ratio=1e-9)
    assert [hole.diameter for hole in detect(scan.points, settings=settings).holes] == [pytest.approx(3.0, abs=0.35 * H)]
    if depth / 3.0 < DEFAULT_SETTINGS.pocket_max_depth_ratio:
        detection = detect(scan.points)
        assert detection.holes == () and "pocket" in [r.check for r in detection.rejected]


def cone_inputs(depth_of, noise=0.0, rng=None):
    """Points on a disc of radius 2.5 mm (spacing ~0.05 mm) with ``depth_of(rho)`` below the surface."""
    rng = np.random.default_rng(0) if rng is None else rng
    rho = 2.5 * np.sqrt(rng.uniform(0.0, 1.0, 8000))
    depth = depth_of(rho)
    if noise:
        depth = depth + rng.normal(0.0, noise, len(rho))
    return rho, depth


@pytest.mark.parametrize("noise", [0.0, 0.01])
def test_flat_floor_check(noise):
    """A floor 0.5 mm down inside a 1.5 mm radius: refused by name, value and limit."""
    rho, depth = cone_inputs(lambda rho: np.where(rho < 1.5, 0.5, 0.0), noise=noise)
    result = fit_cone_edge(rho, depth, 1.5, 0.35, noise)
    assert isinstance(result, NotACone)
    assert result.check == "flat_floor"
    assert result.value < 0.1 and result.limit == 0.3


@pytest.mark.parametrize("noise", [0.0, 0.01])
def test_cone_passes_the_flat_floor_check(noise):
    """A 100-degree countersink meeting the surface at 2.25 mm, seen around a rim fit at 2.2 mm."""
    slope = 1.0 / math.tan(math.radians(50.0))
    rho, depth = cone_inputs(lambda rho: slope * np.clip(2.25 - rho, 0.0, 0.75), noise=noise)
    result = fit_cone_edge(rho, depth, 2.2, 0.35, max(noise, 1e-3))
    assert isinstance(result, Cone)
    assert result.radius == pytest.approx(2.25, abs=0.01)
    assert result.slope == pytest.approx(slope, rel=0.05)


def test_flat_floor_ratio_is_a_setting():
    """At a limit above the cone's own ratio (about 1), a real cone is refused too; with no limit the
    floor is taken for a cone again, as before the check (the RobustSettings field reaches it)."""
    slope = 1.0 / math.tan(math.radians(50.0))
    rho, depth = cone_inputs(lambda rho: slope * np.clip(2.25 - rho, 0.0, 0.75))
    result = fit_cone_edge(rho, depth, 2.2, 0.35, 1e-3, depth_slope_ratio=1.5)
    assert isinstance(result, NotACone) and result.check == "flat_floor" and result.limit == 1.5
    # without the argument, the limit is the settings' (no module copy of their default)
    rho, depth = cone_inputs(lambda rho: np.where(rho < 1.5, 0.5, 0.0))
    result = fit_cone_edge(rho, depth, 1.5, 0.35, 1e-3, settings=replace(DEFAULT_SETTINGS, cone_depth_slope_ratio=0.2))
    assert isinstance(result, NotACone) and result.check == "flat_floor" and result.limit == 0.2
    points = make_scan(blind(0.5), 0).points
    unchecked = replace(DEFAULT_SETTINGS, cone_depth_slope_ratio=-np.inf)
    (hole,) = detect(points, settings=unchecked).holes
    assert hole.diameter > 3.2  # the floor's "cone" puts the edge well outside the 3.0 mm hole


# --- random scenes: consecutive seeds, failure rate bounded ----------------------------------------


def random_panel(rng, hole):
    """A panel 6 surface radii wide around ``hole`` (built by the caller from the same ``rng``)."""
    spacing = hole.diameter / rng.uniform(20.0, 50.0)
    pattern = str(rng.choice(["grid", "stripes", "jittered", "random"]))
    half = 3.0 * hole.surface_radius
    # Facing the sensor within about 60 degrees (a scanner sees no steeper surface well), any heading.
    angles = (*rng.uniform(-45.0, 45.0, 2), rng.uniform(-180.0, 180.0))
    return SceneSpec(holes=(hole,), extent=(-half, half, -half, half), spacing=spacing, pattern=pattern,
                     line_pitch=3.0 * spacing if pattern == "stripes" else None,
                     scan_angle_deg=float(rng.uniform(0.0, 90.0)), rotation_deg=tuple(float(a) for a in angles),
                     translation=tuple(rng.uniform(-1000.0, 1000.0, 3)),
                     noise_normal=float(rng.choice([0.0, 0.05, 0.1, 0.2]) * spacing))


def random_hole(rng, blind_hole):
    diameter = float(rng.uniform(2.0, 8.0))
    center = tuple(rng.uniform(-0.2, 0.2, 2) * diameter)
    if blind_hole:
        depth = float(rng.uniform(0.2, 1.5))
        return HoleSpec(center=center, diameter=diameter, bottom_depth=depth,
                        bore_depth=depth if rng.uniform() < 0.5 else 0.0)
    kind = rng.choice(["plain", "bore", "countersink"])
    if kind == "countersink":
        return HoleSpec(center=center, diameter=diameter, countersink_diameter=diameter * float(rng.uniform(1.2, 1.6)),
                        countersink_angle_deg=float(rng.choice([82.0, 90.0, 100.0, 120.0])))
    return HoleSpec(center=center, diameter=diameter, bore_depth=float(rng.uniform(1.0, 3.0)) if kind == "bore" else 0.0)


def stray_case(seed):
    """(clean points, points with one stray point, truth diameter, spacing, description)."""
    rng = np.random.default_rng([8, 3, seed])
    scene = random_panel(rng, random_hole(rng, False))
    scan = make_scan(scene, rng)
    magnitude = 10.0 ** rng.uniform(3.0, 11.5)
    kind = str(rng.choice(["corner", "normal", "rim", "random"]))
    if kind == "random":
        direction = rng.normal(size=3)
        point = np.asarray(scan.truth["holes"][0]["center"]) + magnitude * direction / np.linalg.norm(direction)
    else:
        point = stray_points(scan, kind, magnitude) * (rng.choice([-1.0, 1.0]) if kind == "corner" else 1.0)
    at = int(rng.integers(0, len(scan.points) + 1))
    stray = np.insert(scan.points, at, point, axis=0)
    return scan.points, stray, scan.truth["holes"][0]["diameter"], scene.spacing, f"{kind} {magnitude:.1e}"


def blind_case(seed):
    """(points, truth diameter, spacing, description, whether the floor is a pocket's)."""
    rng = np.random.default_rng([8, 4, seed])
    scene = random_panel(rng, random_hole(rng, True))
    hole = scene.holes[0]
    scan = make_scan(scene, rng)
    pocket = hole.bottom_depth < DEFAULT_SETTINGS.pocket_max_depth_ratio * hole.diameter
    return (scan.points, scan.truth["holes"][0]["diameter"], scene.spacing,
            f"d {hole.diameter:.2f} floor {hole.bottom_depth:.2f} wall {hole.bore_depth > 0} {scene.pattern}", pocket)


def stray_failure(seed):
    """None, or why seed ``seed`` of the stray-point scenes fails."""
    clean, stray, _, spacing, what = stray_case(seed)
    before, after = diameters(clean), diameters(stray)

    def changed(other):
        return len(before) != len(other) or any(abs(a - b) > STRAY_CHANGE * spacing for a, b in zip(before, other))

    if changed(after):
        # Tell apart a scene whose result the order of its rows already changes (no stray point).
        shuffled = diameters(clean[np.random.default_rng(seed).permutation(len(clean))])
        unstable = f"; without it, rows permuted: {shuffled}" if changed(shuffled) else ""
        return f"seed {seed} ({what}): {before} -> {after}{unstable}"
    return None


def blind_failure(seed):
    """None, or why seed ``seed`` of the blind-hole scenes fails: a floor shallower than
    ``pocket_max_depth_ratio`` diameters is a pocket's (no hole, a 'pocket' rejection), any other a
    blind hole measured within LOOSE spacings."""
    points, truth, spacing, what, pocket = blind_case(seed)
    detection = detect(points)
    found = [hole.diameter for hole in detection.holes]
    if pocket:
        if found or "pocket" not in [r.check for r in detection.rejected]:
            return f"seed {seed} ({what}, a pocket): {found}, {[r.check for r in detection.rejected]}"
        return None
    if len(found) != 1 or abs(found[0] - truth) > LOOSE * spacing:
        return f"seed {seed} ({what}): {found}, truth {truth:.3f}, h {spacing:.3f}"
    return None


def test_stray_point_over_a_sparse_countersink():
    """Surveyed: an 8.26 mm countersink on sparse stripes (h 0.27 mm), whose cone window reaches the
    center, and a point 5.1e3 above it: the cone's least squares took the point (8.00 mm)."""
    assert stray_failure(924) is None


def test_stray_point_over_random_scenes():
    failures = [f for f in map(stray_failure, range(8)) if f]
    assert not failures, failures


def test_blind_holes_over_random_scenes():
    failures = [f for f in map(blind_failure, range(12)) if f]
    assert len(failures) <= 1, failures


def _survey(name, failure, count):
    failures = [f for f in map(failure, range(count)) if f]
    print(f"{name}: {len(failures)} of {count} seeds fail ({100.0 * len(failures) / max(count, 1):.1f} %)")
    for line in failures:
        print("   ", line)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description="Survey the fault scenes over more seeds than the tests run.")
    parser.add_argument("--stray", type=int, default=200, help="seeds of stray-point scenes")
    parser.add_argument("--blind", type=int, default=200, help="seeds of blind-hole scenes")
    options = parser.parse_args()
    _survey("stray point", stray_failure, options.stray)
    _survey("blind hole", blind_failure, options.blind)
