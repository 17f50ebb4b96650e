"""holecli.robust.hole_shape: type, countersink, counterbore, bore, floor and axis of one hole.

The scenes are built point by point (a grid on the surface around the edge, the hole's own surfaces
below it, drilled along a possibly tilted axis), so that each check meets exactly the case it is for.
"""

import json

import numpy as np
import pytest

from holecli.geometry.revolution import frame_about
from holecli.robust.hole_shape import measure_hole_shape
from holecli.settings import RobustSettings
from holecli.vocabulary import NOTE_CODES, WARNING_CODES

PITCH = 0.05


def _axis(tilt_deg, toward_deg=30.0):
    t, p = np.radians(tilt_deg), np.radians(toward_deg)
    return np.array([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)])


def _surface(edge_radius, extent=2.0):
    g = np.arange(-extent * edge_radius, extent * edge_radius, PITCH)
    x, y = np.meshgrid(g, g)
    keep = np.hypot(x, y) > edge_radius
    return np.column_stack([x[keep], y[keep], np.zeros(keep.sum())])


def _polar(r_low, r_high, angles=(0.0, 2 * np.pi)):
    """Points about PITCH apart over the annulus [r_low, r_high] between ``angles``."""
    out = []
    for r in np.arange(max(r_low, 1e-9), r_high, PITCH):
        count = max(int((angles[1] - angles[0]) * r / PITCH), 1)
        theta = angles[0] + (np.arange(count) + 0.5) * (angles[1] - angles[0]) / count
        out.append(np.column_stack([r * np.cos(theta), r * np.sin(theta)]))
    return np.vstack(out)


def _in_axis_frame(local, axis):
    """Local (x, y, z along the axis) points to the world, the axis through the origin."""
    return local @ frame_about(axis)


def _wall(radius, top, bottom, axis, angles=(0.0, 2 * np.pi)):
    theta = np.arange(angles[0], angles[1], PITCH / radius)
    depth = np.arange(top, bottom, PITCH)
    t, d = np.meshgrid(theta, depth)
    local = np.column_stack([radius * np.cos(t.ravel()), radius * np.sin(t.ravel()), -d.ravel()])
    return _in_axis_frame(local, axis)


def _countersunk(bore=2.0, outer=3.5, angle=100.0, tilt=0.0, wall_angles=None, thickness=3.0):
    axis = _axis(tilt)
    half = np.radians(angle / 2.0)
    annulus = _polar(bore, outer)
    rho = np.hypot(*annulus.T)
    cone = _in_axis_frame(np.column_stack([annulus, -(outer - rho) / np.tan(half)]), axis)
    parts = [_surface(outer), cone]
    depth = (outer - bore) / np.tan(half)
    if wall_angles is not None:
        parts.append(_wall(bore, depth + PITCH, thickness, axis, wall_angles))
    return np.vstack(parts), axis, depth, np.tan(half) ** -1


def _measure(points, edge_radius, **options):
    options.setdefault("noise", 0.0)
    return measure_hole_shape(points, np.zeros(3), np.array([0.0, 0.0, 1.0]), edge_radius, spacing=PITCH, **options)


def _codes(shape):
    return [warning.code for warning in shape.warnings]


def _notes(shape):
    return [note.code for note in shape.notes]


@pytest.mark.parametrize("angle", [82.0, 90.0, 100.0, 110.0])
@pytest.mark.parametrize("tilt", [0.0, 5.0])
def test_a_countersink_gives_its_diameter_angle_depth_and_axis(angle, tilt):
    points, axis, depth, slope = _countersunk(angle=angle, tilt=tilt, wall_angles=(0.0, 2 * np.pi))
    shape = _measure(points, 3.5, cone_slope=slope)
    assert shape.type == "countersunk"
    cs = shape.countersink
    assert abs(cs.angle_deg - angle) < 0.01
    assert abs(cs.diameter - 7.0) < 1e-3
    assert cs.depth_from == "bore" and abs(cs.depth - depth) < 1e-3
    assert abs(shape.bore.diameter - 4.0) < 1e-3
    assert abs(shape.perpendicularity_deg - tilt) < 0.01
    assert np.degrees(np.arccos(min(1.0, np.dot(shape.axis, axis)))) < 0.01


def test_without_the_bore_wall_the_depth_comes_from_the_cone_inner_edge():
    points, _, depth, slope = _countersunk(angle=100.0)
    shape = _measure(points, 3.5, cone_slope=slope)
    assert shape.countersink.depth_from == "cone_inner_edge"
    assert abs(shape.countersink.depth - depth) < 0.01
    assert shape.bore.diameter is None and "bore_not_seen" in _notes(shape)


def test_the_gauge_depth_reads_the_cone_and_is_refused_below_it():
    points, _, depth, slope = _countersunk(angle=90.0, wall_angles=(0.0, 2 * np.pi))
    shape = _measure(points, 3.5, cone_slope=slope, gauge_depth=0.5)
    assert abs(shape.countersink.diameter_at_depth - (7.0 - 2 * 0.5 * np.tan(np.radians(45.0)))) < 1e-3
    deep = _measure(points, 3.5, cone_slope=slope, gauge_depth=depth + 0.1)
    assert deep.countersink.diameter_at_depth is None
    assert "gauge_depth_outside_cone" in _notes(deep)


def test_the_normal_s_sign_does_not_matter():
    points, _, _, slope = _countersunk(tilt=3.0, wall_angles=(0.0, 2 * np.pi))
    up = _measure(points, 3.5, cone_slope=slope)
    down = measure_hole_shape(points, np.zeros(3), np.array([0.0, 0.0, -1.0]), 3.5, noise=0.0, spacing=PITCH,
                              cone_slope=slope)
    assert down.countersink == up.countersink and down.axis == pytest.approx(up.axis)


def test_a_cone_seen_over_too_short_an_arc_gives_no_countersink_values():
    """shape_min_arc_deg: a cone seen over a sixth of a turn would say little of its axis."""
    axis, half = _axis(0.0), np.radians(50.0)
    annulus = _polar(2.0, 3.5, angles=(0.0, np.pi / 3))
    cone = np.column_stack([annulus, -(3.5 - np.hypot(*annulus.T)) / np.tan(half)])
    shape = _measure(np.vstack([_surface(3.5), cone]), 3.5, cone_slope=1 / np.tan(half))
    assert shape.type == "countersunk"
    assert shape.countersink.angle_deg is None and "cone_short_arc" in _notes(shape)
    wide = _polar(2.0, 3.5, angles=(0.0, 2 * np.pi / 3))
    cone = np.column_stack([wide, -(3.5 - np.hypot(*wide.T)) / np.tan(half)])
    assert _measure(np.vstack([_surface(3.5), cone]), 3.5, cone_slope=1 / np.tan(half)).countersink.angle_deg \
        == pytest.approx(100.0, abs=0.01)


def test_a_cone_of_implausible_angle_is_not_reported():
    """shape_max_angle_deg: a 170-degree 'cone' is a chamfer's edge or a dent, not a countersink."""
    half = np.radians(85.0)
    annulus = _polar(2.0, 3.5)
    cone = np.column_stack([annulus, -(3.5 - np.hypot(*annulus.T)) / np.tan(half)])
    shape = _measure(np.vstack([_surface(3.5), cone]), 3.5, cone_slope=1 / np.tan(half))
    assert shape.countersink.angle_deg is None and "cone_angle_implausible" in _codes(shape)


def test_too_few_cone_points_give_no_countersink_values():
    """shape_min_points."""
    annulus = _polar(3.3, 3.5, angles=(0.0, 2 * np.pi))[::80]
    cone = np.column_stack([annulus, -(3.5 - np.hypot(*annulus.T))])
    shape = _measure(np.vstack([_surface(3.5), cone]), 3.5, cone_slope=1.0)
    assert shape.countersink.diameter is None and "cone_few_points" in _notes(shape)


@pytest.mark.parametrize("tilt", [0.0, 2.0, 5.0])
def test_a_blind_hole_gives_its_floor_depth_and_axis_from_the_floor(tilt):
    axis = _axis(tilt)
    floor = _in_axis_frame(np.column_stack([_polar(0.0, 2.0), np.full(len(_polar(0.0, 2.0)), -1.5)]), axis)
    shape = _measure(np.vstack([_surface(2.0), floor]), 2.0)
    assert shape.type == "blind"
    assert abs(shape.bore.floor_depth - 1.5) < 1e-6
    assert shape.bore.floor_rms < 1e-9
    assert abs(shape.perpendicularity_deg - tilt) < 1e-3


def test_a_step_around_the_bore_is_a_counterbore():
    """shape_floor_center_radii: a floor that does not reach the axis rings a bore."""
    step = _polar(2.0, 3.5)
    floor = np.column_stack([step, np.full(len(step), -1.0)])
    wall = _wall(2.0, 1.0 + PITCH, 3.0, _axis(0.0), (0.0, np.pi))
    shape = _measure(np.vstack([_surface(3.5), floor, wall]), 3.5)
    assert shape.type == "counterbored"
    assert abs(shape.counterbore.depth - 1.0) < 1e-6 and shape.counterbore.diameter == 7.0
    assert abs(shape.bore.diameter - 4.0) < 1e-3
    # the same floor across the axis is a blind hole's
    full = np.column_stack([_polar(0.0, 3.5), np.full(len(_polar(0.0, 3.5)), -1.0)])
    assert _measure(np.vstack([_surface(3.5), full]), 3.5).type == "blind"


def test_a_bore_wall_is_not_taken_for_a_floor():
    """shape_floor_fraction: the points of a wall seen from a tilted view spread over its depth; no
    depth holds enough of them to be a floor."""
    wall = _wall(2.0, 0.1, 3.0, _axis(0.0), (0.0, np.pi))
    shape = _measure(np.vstack([_surface(2.0), wall]), 2.0)
    assert shape.type == "through"
    assert abs(shape.bore.diameter - 4.0) < 1e-3
    assert shape.perpendicularity_deg == pytest.approx(0.0, abs=1e-3)


@pytest.mark.parametrize("tilt", [2.0, 5.0])
def test_a_tilted_bore_gives_its_axis(tilt):
    axis = _axis(tilt, 200.0)
    wall = _wall(2.0, 0.1, 3.0, axis, (0.0, 1.2 * np.pi))
    shape = _measure(np.vstack([_surface(2.0), wall]), 2.0)
    assert abs(shape.perpendicularity_deg - tilt) < 0.01
    assert np.degrees(np.arccos(min(1.0, np.dot(shape.axis, axis)))) < 0.01


def test_a_wall_seen_over_less_than_a_quarter_turn_gives_no_diameter():
    """shape_min_arc_deg: over a short arc the radius trades off against the axis's position."""
    wall = _wall(2.0, 0.1, 3.0, _axis(0.0), (0.0, np.radians(60.0)))
    shape = _measure(np.vstack([_surface(2.0), wall]), 2.0)
    assert shape.bore.diameter is None and shape.bore.arc_deg < 90.0
    assert "bore_short_arc" in _notes(shape) and "axis_not_measured" in _notes(shape)
    assert shape.axis is None and shape.perpendicularity_deg is None


def test_a_short_wall_is_fitted_along_the_known_axis():
    """shape_axis_min_span: a band of wall a fraction of the radius deep says its radius, not its
    direction: the bore gives no axis."""
    wall = _wall(2.0, 0.1, 0.5, _axis(0.0), (0.0, 2 * np.pi))
    shape = _measure(np.vstack([_surface(2.0), wall]), 2.0)
    assert abs(shape.bore.diameter - 4.0) < 1e-3
    assert shape.axis is None and "axis_not_measured" in _notes(shape)
    deeper = _measure(np.vstack([_surface(2.0), _wall(2.0, 0.1, 1.5, _axis(0.0), (0.0, 2 * np.pi))]), 2.0)
    assert deeper.axis is not None


def test_nothing_below_the_edge_is_a_through_hole_with_its_reasons():
    shape = _measure(_surface(2.0), 2.0)
    assert shape.type == "through" and shape.bore.diameter is None and shape.bore.points == 0
    # why the bore and the axis are null: notes, no warning (nothing given is doubtful)
    assert _codes(shape) == [] and _notes(shape) == ["bore_not_seen", "axis_not_measured"]
    assert all(note.message.startswith(NOTE_CODES[note.code]) for note in shape.notes)


def test_notes_and_warnings_are_apart():
    # a note says why a value is null; a warning that the points contradict the hole's shape
    assert not set(NOTE_CODES) & set(WARNING_CODES)


def test_surface_noise_is_not_taken_for_points_below():
    """shape_below_sigmas: with noise, surface points dip below the plane; they are no wall."""
    rng = np.random.default_rng(0)
    surface = _surface(2.0)
    surface[:, 2] += rng.normal(0.0, 0.01, len(surface))
    shape = _measure(surface, 2.0, noise=0.01)
    assert shape.bore.points == 0 and shape.type == "through"


def test_a_ring_of_wall_points_at_one_depth_is_not_a_floor():
    """shape_floor_min_width: one scan row across a bore wall is planar, but has no width."""
    ring = _wall(2.0, 0.6, 0.6 + PITCH / 2, _axis(0.0), (0.0, 2 * np.pi))
    # just inside the edge, with a scan row's in-plane scatter
    ring[:, :2] *= 0.997 + 0.002 * np.random.default_rng(0).random((len(ring), 1))
    shape = _measure(np.vstack([_surface(2.0), ring]), 2.0)
    assert shape.type == "through"


def test_reflections_inside_a_through_hole_are_no_floor():
    """shape_floor_fraction: stray points at random depths inside the bore (reflections) put a few
    dozen at any one depth, a small share of them; a floor holds most of the points below."""
    rng = np.random.default_rng(1)
    count = 3000
    rho, theta = 1.9 * np.sqrt(rng.random(count)), rng.uniform(0.0, 2 * np.pi, count)
    stray = np.column_stack([rho * np.cos(theta), rho * np.sin(theta), -rng.uniform(0.1, 3.0, count)])
    shape = _measure(np.vstack([_surface(2.0), stray]), 2.0)
    assert shape.type == "through"


def test_a_steep_cone_is_not_reported_as_a_countersink():
    """shape_min_angle_deg: a 'cone' of 20 degrees included is a bore wall with a draft, not a countersink."""
    half = np.radians(10.0)
    annulus = _polar(3.0, 3.5)
    cone = np.column_stack([annulus, -(3.5 - np.hypot(*annulus.T)) / np.tan(half)])
    shape = _measure(np.vstack([_surface(3.5), cone]), 3.5, cone_slope=1 / np.tan(half))
    assert shape.countersink.angle_deg is None and "cone_angle_implausible" in _codes(shape)


@pytest.mark.parametrize("tilt", [2.0, 5.0])
def test_a_counterbore_step_drilled_off_the_normal_is_found(tilt):
    """shape_floor_max_tilt_deg: the step lies square to the tilted axis, so across it its depth below
    the surface varies by 2 R tan(tilt); the floor is searched among tilted planes."""
    axis = _axis(tilt)
    step = _polar(2.0, 3.5)
    floor = _in_axis_frame(np.column_stack([step, np.full(len(step), -1.0)]), axis)
    wall = _wall(2.0, 1.0 + 2 * PITCH, 3.0, axis, (0.0, np.pi))
    shape = _measure(np.vstack([_surface(3.5), floor, wall]), 3.5)
    assert shape.type == "counterbored"
    assert abs(shape.counterbore.depth - 1.0) < 1e-3
    assert abs(shape.perpendicularity_deg - tilt) < 0.01
    flat_only = _measure(np.vstack([_surface(3.5), floor, wall]), 3.5,
                         settings=RobustSettings(shape_floor_max_tilt_deg=0.5))
    assert flat_only.type != "counterbored" or abs(flat_only.perpendicularity_deg - tilt) > 0.01


def test_an_oval_wall_gives_no_bore():
    """shape_max_rms_sigmas / shape_max_rms_radii: the wall of an oval cut-out (2.2 by 1.8 mm) has a
    bore's size on average but lies on no cylinder."""
    wall = _wall(2.0, 0.1, 2.5, _axis(0.0))
    oval = wall * np.array([1.1, 0.9, 1.0])
    shape = _measure(np.vstack([_surface(2.2), oval]), 2.2)
    assert shape.bore.diameter is None and "bore_not_cylindrical" in _codes(shape)
    round_wall = _measure(np.vstack([_surface(2.0), wall]), 2.0)
    assert round_wall.bore.diameter == pytest.approx(4.0, abs=1e-3)


def test_a_free_axis_far_off_the_known_one_is_not_trusted():
    """shape_max_axis_change_deg: a bore 'drilled' 30 degrees off the normal is no bore of this
    hole; its wall is fitted along the known axis and gives no axis of its own."""
    wall = _wall(2.0, 0.1, 3.0, _axis(30.0), (0.0, 1.5 * np.pi))
    shape = _measure(np.vstack([_surface(2.0), wall]), 2.0)
    assert shape.axis is None or shape.perpendicularity_deg < 15.0
    loose = _measure(np.vstack([_surface(2.0), wall]), 2.0, settings=RobustSettings(shape_max_axis_change_deg=60.0))
    assert loose.perpendicularity_deg == pytest.approx(30.0, abs=0.01)


def test_a_rounded_bowl_is_no_countersink():
    """shape_max_rms_sigmas / shape_max_rms_radii for the cone: a bowl (depth growing with the square
    of the distance from the edge) has a cone's slope on average but lies on no cone."""
    annulus = _polar(2.0, 3.5)
    depth = ((3.5 - np.hypot(*annulus.T)) / 1.5) ** 2 * 1.5
    bowl = np.column_stack([annulus, -depth])
    shape = _measure(np.vstack([_surface(3.5), bowl]), 3.5, cone_slope=1.0)
    assert shape.countersink.angle_deg is None and "cone_not_conical" in _codes(shape)


def test_a_blind_floor_seen_only_on_one_side_is_still_blind():
    """_floor_is_blind: from a tilted view the wall hides all of a deep blind floor but a lune on one
    side, which does not reach the axis; its side toward the axis is the shadow's arc, and the floor
    lies inside that arc's circle. A counterbore's step seen over half a turn lies outside its arc."""
    disc = _polar(0.0, 2.0)
    shadow = np.hypot(disc[:, 0] - 2.6, disc[:, 1]) < 2.0  # the opening's shadow, shifted 2.6 mm
    lune = disc[shadow]
    assert np.min(np.hypot(*lune.T)) > 0.3 * 2.0
    floor = np.column_stack([lune, np.full(len(lune), -2.5)])
    assert _measure(np.vstack([_surface(2.0), floor]), 2.0).type == "blind"
    step = _polar(2.0, 3.5, angles=(-np.radians(80), np.radians(80)))
    floor = np.column_stack([step, np.full(len(step), -1.0)])
    assert _measure(np.vstack([_surface(3.5), floor]), 3.5).type == "counterbored"


def test_the_countersunk_sample_with_outliers_gives_its_cone_and_bore(repo_root):
    """The first cone fit starts from the hinge with the points far from it left out (see
    holecli.geometry.revolution): the bore-wall points within the hinge's band pulled a plain first
    fit to 79 degrees, and trimming after it no longer got out (rms 0.06 mm, no countersink)."""
    from holecli import detect_file

    truth = json.loads((repo_root / "sample_clouds" / "countersunk_outliers.truth.json").read_text())["holes"][0]
    hole = detect_file(repo_root / "sample_clouds" / "countersunk_outliers.xyz").holes[0]
    assert hole.type == "countersunk"
    assert abs(hole.countersink.angle_deg - 100.0) < 0.5
    assert abs(hole.countersink.diameter - truth["diameter"]) < 0.005
    assert abs(hole.bore.diameter - truth["bore_diameter"]) < 0.005
    assert hole.countersink.depth_from == "bore"
    assert abs(hole.countersink.depth - (truth["diameter"] - truth["bore_diameter"]) / 2 / np.tan(np.radians(50))) < 0.005


def test_float32_round_off_of_a_noise_free_scan_is_not_taken_for_points_below():
    """The noise is the surface ring's own: a noise-free scan 1 m from the origin in float32 has
    heights rounded by about 3e-5 mm, far above the scan's noise estimate of zero; with that estimate
    the surface just outside the edge would be a 'bore wall' at no depth."""
    offset = np.array([1000.0, -400.0, 700.0])
    normal = _axis(20.0, 70.0)  # a tilted part: every coordinate is rounded
    surface = (_in_axis_frame(_surface(2.0), normal) + offset).astype(np.float32).astype(np.float64)
    shape = measure_hole_shape(surface, offset, normal, 2.0, noise=0.0, spacing=PITCH)
    assert shape.type == "through" and shape.bore.points == 0


def test_stray_points_near_the_cone_are_trimmed():
    """shape_trim_sigmas: reflections under the cone's surface (within the hinge's band, all on one
    side: they would tilt its angle) are left out of its fit."""
    rng = np.random.default_rng(4)
    points, _, _, slope = _countersunk(angle=100.0)
    points = points + rng.normal(0.0, 0.003, points.shape)
    annulus = 2.0 + 1.5 * rng.random((3000, 1))
    theta = rng.uniform(0, 2 * np.pi, (3000, 1))
    depth = (3.5 - annulus) * slope + rng.uniform(0.02, 0.3, (3000, 1))
    stray = np.hstack([annulus * np.cos(theta), annulus * np.sin(theta), -depth])
    shape = _measure(np.vstack([points, stray]), 3.5, cone_slope=slope, noise=0.003)
    assert abs(shape.countersink.angle_deg - 100.0) < 0.05
    assert abs(shape.countersink.diameter - 7.0) < 2e-3


def test_on_a_curved_panel_the_noise_is_the_surface_ring_s_not_the_scan_s():
    """The scan's height noise of a curved panel holds the sheet's sag across the scan (0.05 mm here),
    which would widen every band; the ring's quadric leaves the real noise (here none), and the cone
    and the bore seen from a tilted view come out exact."""
    points, _, depth, slope = _countersunk(angle=90.0, wall_angles=(0.0, np.pi))
    surface = points[:, 2] == 0.0
    points[surface, 2] = -(points[surface, 0] ** 2 + points[surface, 1] ** 2) / (2 * 500.0)
    shape = _measure(points, 3.5, cone_slope=slope, noise=0.05)
    assert abs(shape.countersink.angle_deg - 90.0) < 0.01
    assert abs(shape.countersink.depth - depth) < 1e-3
