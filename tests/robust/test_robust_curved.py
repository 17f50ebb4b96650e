"""Holes in curved panels (cylindrical, R 500-2000 mm, convex and concave): the surface at a hole
follows a quadric when its curvature shows, so the center sits on the surface, not on the chord of
the ring around it (issue 9, item 2.4). On a flat surface the check ``curvature_sigmas`` keeps the
plane, which is less noisy there."""

import numpy as np
import pytest

from holecli.geometry.plane import fit_plane_scatter
from holecli.pipeline import detect
from holecli.robust.surface import tangent_of_quadric

pytestmark = pytest.mark.slow  # the quick loop: pytest -m "not slow"


def curved_panel(radius, hole_radius, center_x, convex, spacing=0.05, half=8.0, noise=0.0, seed=0, tilt_deg=25.0):
    """Grid points on a cylinder (axis along y) with a hole drilled along the local normal at
    (center_x, 0); then tilted about x. Returns points, the true center and normal."""
    rng = np.random.default_rng(seed)
    sign = -1.0 if convex else 1.0
    u, v = np.meshgrid(np.arange(center_x - half, center_x + half, spacing), np.arange(-half, half, spacing))
    x, y = u.ravel(), v.ravel()
    points = np.column_stack([x, y, sign * (radius - np.sqrt(radius ** 2 - x ** 2))])
    center = np.array([center_x, 0.0, sign * (radius - np.sqrt(radius ** 2 - center_x ** 2))])
    normal = np.array([-sign * center_x / np.sqrt(radius ** 2 - center_x ** 2), 0.0, 1.0])
    normal /= np.linalg.norm(normal)
    offset = points - center
    radial = offset - np.outer(offset @ normal, normal)
    points = points[np.linalg.norm(radial, axis=1) > hole_radius]
    points = points + noise * rng.normal(size=(len(points), 1)) * normal
    t = np.radians(tilt_deg)
    rotation = np.array([[1.0, 0.0, 0.0], [0.0, np.cos(t), -np.sin(t)], [0.0, np.sin(t), np.cos(t)]])
    return points @ rotation.T, rotation @ center, rotation @ normal


def _errors(points, center, normal, diameter):
    (hole,) = detect(points).holes
    error = np.array(hole.center) - center
    along = float(error @ normal)
    in_plane = float(np.linalg.norm(error - along * normal))
    return in_plane, along, hole.diameter - diameter


@pytest.mark.parametrize("radius", [500.0, 800.0, 2000.0])
@pytest.mark.parametrize("convex", [True, False], ids=["convex", "concave"])
@pytest.mark.parametrize("center_x", [0.0, 30.0])
def test_center_on_the_curved_surface(radius, convex, center_x):
    points, center, normal = curved_panel(radius, 2.5, center_x, convex)
    in_plane, along, diameter = _errors(points, center, normal, 5.0)
    # a plane through the ring [r, 3r] lies 10 um (R 800) to 16 um (R 500) off the surface at the center
    assert abs(along) < 0.5e-3
    assert in_plane < 2e-3 and abs(diameter) < 3e-3


def test_random_curved_panels_bound_the_failure_rate():
    rng = np.random.default_rng(2026)
    failures = []
    for seed in range(12):
        radius, hole_radius = rng.uniform(500.0, 2000.0), rng.uniform(1.5, 3.0)
        convex, center_x = bool(rng.integers(2)), rng.uniform(-40.0, 40.0)
        points, center, normal = curved_panel(radius, hole_radius, center_x, convex, spacing=rng.uniform(0.03, 0.08),
                                              half=4.0 * hole_radius, noise=0.002, seed=seed,
                                              tilt_deg=rng.uniform(0.0, 40.0))
        in_plane, along, diameter = _errors(points, center, normal, 2.0 * hole_radius)
        if abs(along) > 2e-3 or in_plane > 3e-3 or abs(diameter) > 5e-3:
            failures.append((seed, along, in_plane, diameter))
    assert len(failures) <= 1, failures


def test_the_curvature_check_keeps_the_plane_on_a_flat_noisy_ring():
    rng = np.random.default_rng(7)
    kept, heights_quadric, heights_plane = 0, [], []
    for _ in range(40):
        angle, distance = rng.uniform(0, 2 * np.pi, 1500), np.sqrt(rng.uniform(1.0, 9.0, 1500))
        ring = np.column_stack([distance * np.cos(angle), distance * np.sin(angle), 0.01 * rng.normal(size=1500)])
        plane = fit_plane_scatter(ring)
        near = np.zeros(3)
        kept += tangent_of_quadric(ring, plane, near, 3.0) is plane
        heights_quadric.append(tangent_of_quadric(ring, plane, near, 0.0).point[2])
        heights_plane.append(plane.point[2])
    assert kept >= 38  # a 3-sigma check passes noise about once in 370
    # and the check is worth having: the quadric's height at the center is noisier than the plane's
    assert np.std(heights_quadric) > 1.3 * np.std(heights_plane)


def _curved_countersink_scan(seed, reach=5.0):
    """A countersunk hole in a random curved panel, scanned by the profiler over ``reach`` x ``reach``
    diameters."""
    import math

    from holecli.simulation.panel import FeatureSpec, PanelSpec, build_panel, panel_truth
    from holecli.simulation.profiler import ProfilerSpec
    from holecli.simulation.scan_part import scan_part

    rng = np.random.default_rng([90, seed])
    diameter, angle = rng.uniform(3.0, 5.0), rng.choice([90.0, 100.0])
    feature = FeatureSpec(kind="countersunk", center=(0.0, 0.0), diameter=diameter, countersink_angle_deg=angle,
                          countersink_diameter=diameter + 1.4 * math.tan(math.radians(angle) / 2.0))
    panel = build_panel(PanelSpec(width=(reach + 3) * diameter, height=(reach + 3) * diameter, thickness=3.0,
                                  curvature=str(rng.choice(["convex", "concave"])), radius=rng.uniform(500, 1200),
                                  features=(feature,)))
    pitch = rng.uniform(0.04, 0.08)
    spec = ProfilerSpec(line_length=reach * diameter, scan_length=reach * diameter, point_pitch=pitch, line_pitch=pitch,
                        range_noise=0.005, range_quantum=0.001)
    scanned = scan_part(panel.vertices, panel.triangles, panel_truth(panel)["features"], spec, rng=seed)
    return scanned.scan.points, scanned.truth["holes"][0]


def test_countersinks_on_curved_panels_are_measured_from_the_surface_not_the_plane():
    # The plane of a scan 5 diameters wide lies tens of um off a curved surface at the hole: a
    # countersink's depth measured from it put the edge 50 um off (a convex R 873 panel).
    errors = []
    for seed in range(4):
        points, truth = _curved_countersink_scan(seed)
        (hole,) = detect(points).holes
        errors.append(hole.diameter - truth["diameter"])
    assert sum(abs(error) > 15e-3 for error in errors) <= 1, errors
    assert np.median(np.abs(errors)) < 8e-3, errors


def test_countersinks_in_wide_scans_of_curved_panels():
    # A scan 7 diameters wide of a curved panel has a surface band of tens of um about its plane: the
    # top of the cone counts as surface and the rim lies inside the edge by more than the window in
    # which the cone's edge is searched (a 7 mm countersink at R 800 convex was 32 um small).
    errors = []
    for seed in range(10, 14):
        points, truth = _curved_countersink_scan(seed, reach=7.0)
        (hole,) = detect(points).holes
        errors.append(hole.diameter - truth["diameter"])
    assert sum(abs(error) > 15e-3 for error in errors) <= 1, errors
    assert np.median(np.abs(errors)) < 8e-3, errors


def test_holes_away_from_the_middle_of_a_wide_scan_of_a_curved_panel():
    # Across a 50 mm scan at R 800 the plane lies 0.4 mm off the surface at its ends: the band of
    # surface points is wide and the top of a countersink counts as surface on one side of the hole
    # more than on the other (a countersink 15 mm from the middle was 55 um off in center, 53 um in
    # diameter). Each such hole is measured again on its flattened neighbourhood.
    import math

    from holecli.simulation.panel import FeatureSpec, PanelSpec, build_panel, panel_truth
    from holecli.simulation.profiler import ProfilerSpec
    from holecli.simulation.scan_part import scan_part

    failures = []
    for seed in range(3):
        rng = np.random.default_rng([91, seed])
        offset = rng.uniform(12.0, 18.0) * rng.choice([-1.0, 1.0])
        panel = build_panel(PanelSpec(width=60.0, height=24.0, thickness=2.5, curvature=str(rng.choice(["convex", "concave"])),
                                      radius=rng.uniform(600.0, 1200.0), features=(
                                          FeatureSpec(kind="countersunk", center=(offset, 0.0), diameter=4.1,
                                                      countersink_diameter=7.0),
                                          FeatureSpec(kind="through", center=(-offset, 0.0), diameter=4.1))))
        tilt = math.radians(rng.uniform(0.0, 25.0))
        spec = ProfilerSpec(view=(0.0, math.sin(tilt), -math.cos(tilt)), line_length=50.0, scan_length=14.0,
                            point_pitch=0.1, line_pitch=0.1, range_noise=0.003, range_quantum=0.001)
        scanned = scan_part(panel.vertices, panel.triangles, panel_truth(panel)["features"], spec, rng=seed)
        holes = detect(scanned.scan.points).holes
        for truth in scanned.truth["holes"]:
            hole = min(holes, key=lambda h: np.linalg.norm(np.subtract(h.center, truth["center"])))
            center_error = np.linalg.norm(np.subtract(hole.center, truth["center"]))
            diameter_error = hole.diameter - truth["diameter"]
            if center_error > 15e-3 or abs(diameter_error) > 10e-3:
                failures.append((seed, truth["kind"], center_error, diameter_error))
    assert len(failures) <= 1, failures


def test_a_curved_panel_hole_is_measured_on_its_flattened_crop_without_a_second_detection(monkeypatch):
    """The hole is measured again on its flattened neighbourhood (a scene of the crop, the void at its
    center measured as every candidate is), not by running the whole method on the crop, and the hole
    reported is that measurement's."""
    import holecli.robust.curved as curved
    import holecli.robust.method as method

    points, center, normal = curved_panel(800.0, 2.5, 30.0, convex=True)
    detections, flattened, again = [], [], []
    real_detect, real_build, real_curved = method.detect_robust, method.build_scene, method.on_curved_surface

    def counting_detect(*args, **kwargs):
        detections.append(1)
        return real_detect(*args, **kwargs)

    def counting_build(*args, **kwargs):
        flattened.append(kwargs.get("flattened", False))
        return real_build(*args, **kwargs)

    def recording_curved(*args):
        again.append(real_curved(*args))
        return again[-1]

    monkeypatch.setattr(method, "detect_robust", counting_detect)
    monkeypatch.setattr(method, "build_scene", counting_build)
    monkeypatch.setattr(curved, "build_scene", counting_build)  # the flattened crop's scene
    monkeypatch.setattr(method, "on_curved_surface", recording_curved)
    (hole,) = detect(points).holes
    assert len(detections) == 1 and flattened == [False, True]
    assert len(again) == 1 and again[0] is not None and hole.center == again[0].center
    error = np.array(hole.center) - center
    assert abs(float(error @ normal)) < 0.5e-3 and np.linalg.norm(error) < 2e-3
