"""Known-answer and physical tests of the laser line profiler simulator (holecli.simulation.profiler)."""

import math
from dataclasses import replace

import numpy as np
import pytest

from holecli.errors import LoadError, SpecError
from holecli.simulation.profiler import ProfilerSpec, load_mesh, scan_mesh, transform_to_frame
from holecli.simulation.synth import rotation_matrix

# A small parallel-ray scan without camera occlusion: the base of most tests.
BASE = ProfilerSpec(standoff=100.0, line_length=4.0, scan_length=3.0, point_pitch=0.1,
                    line_pitch=0.1, fan=False, triangulation_deg=0.0)


# -------------------------------------------------------------------------------------------------
# meshes


def plate(half=10.0, z=0.0):
    """A square plate |x|, |y| <= half at height z: 2 triangles."""
    v = np.array([[-half, -half, z], [half, -half, z], [half, half, z], [-half, half, z]])
    return v, np.array([[0, 1, 2], [0, 2, 3]])


def box(lo, hi):
    """A closed axis-aligned box: 12 triangles."""
    (x0, y0, z0), (x1, y1, z1) = lo, hi
    v = np.array([[x0, y0, z0], [x1, y0, z0], [x1, y1, z0], [x0, y1, z0],
                  [x0, y0, z1], [x1, y0, z1], [x1, y1, z1], [x0, y1, z1]], dtype=np.float64)
    quads = [(0, 1, 2, 3), (4, 5, 6, 7), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7)]
    t = [(a, b, c) for a, b, c, d in quads] + [(a, c, d) for a, b, c, d in quads]
    return v, np.array(t)


def merge(*meshes):
    verts, tris, offset = [], [], 0
    for v, t in meshes:
        verts.append(v)
        tris.append(t + offset)
        offset += len(v)
    return np.concatenate(verts), np.concatenate(tris)


def holed_plate(radius=2.0, half=5.0, sides=64, depth=3.0):
    """A square plate with a regular `sides`-gon hole at the origin and its bore wall below.

    The plate is a ring fan between the polygon and the square (same angles, projected radially
    onto the square, so that its corners are vertices); the wall is a quad strip down to -depth.
    Returns vertices, triangles and the number of plate triangles (the wall's come after).
    """
    theta = 2 * np.pi * np.arange(sides) / sides
    c, s = np.cos(theta), np.sin(theta)
    inner = np.column_stack([radius * c, radius * s, np.zeros(sides)])
    outer = np.column_stack([half * c, half * s, np.zeros(sides)]) / np.maximum(
        np.abs(c), np.abs(s))[:, None]
    outer[:, 2] = 0.0
    bottom = inner - [0.0, 0.0, depth]
    verts = np.concatenate([inner, outer, bottom])
    k = np.arange(sides)
    k1 = (k + 1) % sides
    ring = np.concatenate([np.column_stack([k, k1, sides + k1]), np.column_stack([k, sides + k1, sides + k])])
    wall = np.concatenate([np.column_stack([k, k1, 2 * sides + k1]),
                           np.column_stack([k, 2 * sides + k1, 2 * sides + k])])
    return verts, np.concatenate([ring, wall]), len(ring)


def expected_lattice(spec):
    nc = int(round(spec.line_length / spec.point_pitch)) + 1
    npf = int(round(spec.scan_length / spec.line_pitch)) + 1
    u = (np.arange(nc) - (nc - 1) / 2) * spec.point_pitch
    s = (np.arange(npf) - (npf - 1) / 2) * spec.line_pitch
    return u, s


# -------------------------------------------------------------------------------------------------
# geometry of the lattice


def test_parallel_rays_on_a_plate_give_the_exact_lattice():
    spec = replace(BASE, target=(0.3, -0.2, 0.0))
    scan = scan_mesh(*plate(), spec)
    u, s = expected_lattice(spec)
    grid = np.array([[0.3 + ui, -0.2 + sj, 0.0] for sj in s for ui in u])
    np.testing.assert_allclose(scan.points, grid, rtol=0, atol=1e-12)
    assert scan.info["rays"] == scan.info["points"] == len(u) * len(s) == 41 * 31
    np.testing.assert_array_equal(scan.profile_index, np.repeat(np.arange(len(s)), len(u)))
    np.testing.assert_array_equal(scan.column_index, np.tile(np.arange(len(u)), len(s)))
    np.testing.assert_allclose(scan.ranges, 100.0, rtol=0, atol=1e-12)
    assert set(scan.triangle_id.tolist()) <= {0, 1}


def test_default_motion_is_line_cross_view():
    # line +x, view -z: profiles advance along +y, the sensor frame (line, motion, -view) is right-handed.
    scan = scan_mesh(*plate(), BASE)
    assert np.all(np.diff(scan.points[scan.column_index == 0, 1]) > 0)
    flipped = scan_mesh(*plate(), replace(BASE, motion=(0.0, -3.0, 0.0)))
    assert np.all(np.diff(flipped.points[flipped.column_index == 0, 1]) < 0)


@pytest.mark.parametrize("depth", [0.0, 7.0])
def test_fan_rays_have_the_pitch_at_the_standoff_and_spread_beyond(depth):
    spec = replace(BASE, fan=True, scan_length=0.0)
    scan = scan_mesh(*plate(z=-depth), spec)
    u, _ = expected_lattice(spec)
    np.testing.assert_allclose(scan.points[:, 0], u * (100.0 + depth) / 100.0, rtol=0, atol=1e-11)
    np.testing.assert_allclose(scan.points[:, 2], -depth, rtol=0, atol=1e-11)
    np.testing.assert_allclose(scan.ranges, np.hypot(100.0 + depth, scan.points[:, 0]), rtol=1e-13)


# -------------------------------------------------------------------------------------------------
# range defects


def test_range_noise_is_gaussian_along_the_ray():
    sigma = 0.01
    spec = replace(BASE, fan=True, line_length=20.0, scan_length=5.0, point_pitch=0.2,
                   line_pitch=0.05, range_noise=sigma)
    scan = scan_mesh(*plate(), spec, rng=1)
    u, s = expected_lattice(spec)
    origin = np.column_stack([np.zeros(len(scan.points)), s[scan.profile_index],
                              np.full(len(scan.points), 100.0)])
    aim = np.column_stack([u[scan.column_index], np.zeros(len(origin)), np.full(len(origin), -100.0)])
    aim /= np.linalg.norm(aim, axis=1, keepdims=True)
    # Every point stays on its ray ...
    np.testing.assert_allclose(scan.points, origin + scan.ranges[:, None] * aim, rtol=0, atol=1e-11)
    # ... displaced along it by N(0, sigma).
    residual = scan.ranges - np.hypot(100.0, u[scan.column_index])
    n = len(residual)
    assert n == 101 * 101
    assert abs(residual.mean()) < 5 * sigma / math.sqrt(n)
    assert residual.std() == pytest.approx(sigma, rel=0.05)


def test_quantization_makes_ranges_multiples_of_the_quantum():
    q = 1e-3
    spec = replace(BASE, fan=True, range_noise=0.004, range_quantum=q)
    scan = scan_mesh(*plate(), spec, rng=2)
    steps = scan.ranges / q
    np.testing.assert_allclose(steps, np.round(steps), rtol=0, atol=1e-6)
    assert len(np.unique(np.round(steps))) > 5


def test_dropout_fraction_is_binomial():
    p = 0.2
    spec = replace(BASE, line_length=10.0, scan_length=9.9, dropout=p)
    scan = scan_mesh(*plate(), spec, rng=3)
    n = scan.info["hits"]
    assert n == 101 * 100
    bound = 5 * math.sqrt(n * p * (1 - p))
    assert abs(scan.info["dropped"] - n * p) < bound
    assert scan.info["points"] == len(scan.points) == n - scan.info["dropped"]


def test_jitter_moves_whole_profiles():
    sigma = 0.05
    spec = replace(BASE, line_length=2.0, scan_length=10.0, jitter=sigma)
    u, s = expected_lattice(spec)
    scan = scan_mesh(*plate(), spec, rng=4)
    # On a flat plate only the height error shows (sliding a plane along itself changes nothing):
    # one offset per profile, constant within it, N(0, sigma) across profiles.
    z = scan.points[:, 2].reshape(len(s), len(u))
    assert np.ptp(z, axis=1).max() < 1e-9
    assert 0.65 * sigma < z[:, 0].std() < 1.35 * sigma
    np.testing.assert_allclose(scan.points[:, 0], u[scan.column_index], rtol=0, atol=1e-12)
    # On the slope z = x the lateral error shows too: the profile is offset by dx - dz.
    v, t = plate()
    v[:, 2] = v[:, 0]
    sloped = scan_mesh(v, t, spec, rng=4)
    offset = (sloped.points[:, 2] - sloped.points[:, 0]).reshape(len(s), len(u))
    assert np.ptp(offset, axis=1).max() < 1e-9
    assert 0.65 * math.sqrt(2) * sigma < offset[:, 0].std() < 1.35 * math.sqrt(2) * sigma
    again = scan_mesh(*plate(), spec, rng=4)
    np.testing.assert_array_equal(again.points, scan.points)


# -------------------------------------------------------------------------------------------------
# what the sensor cannot see


@pytest.mark.parametrize("tilt, kept", [(60.0, True), (74.0, True), (76.0, False), (85.0, False)])
def test_max_incidence_drops_steep_faces(tilt, kept):
    v, t = plate(half=3.0)
    rot = rotation_matrix((tilt, 0.0, 0.0))
    scan = scan_mesh(v @ rot.T, t, replace(BASE, line_length=2.0, scan_length=0.5,
                                          max_incidence_deg=75.0))
    assert scan.info["hits"] == scan.info["rays"]
    assert scan.info["points"] == (scan.info["rays"] if kept else 0)
    assert scan.info["beyond_incidence"] == (0 if kept else scan.info["rays"])


@pytest.mark.parametrize("side", [1, -1])
def test_camera_shadow_behind_a_step_has_width_height_tan_angle(side):
    height, angle = 2.0, 25.0
    mesh = merge(plate(half=12.0), box((-10.0, 0.0, 0.0), (10.0, 5.0, height)))
    # Profiles at y = 0.025 + 0.1 k: never on the box's walls at y = 0 and y = 5.
    spec = replace(BASE, target=(0.0, 2.525, 0.0), line_length=2.0, scan_length=16.0,
                   triangulation_deg=angle, camera_side=side)
    scan = scan_mesh(*mesh, spec)
    u, s = expected_lattice(spec)
    y = 2.525 + s
    shadow = height * math.tan(math.radians(angle))
    hidden = (y > -shadow) & (y < 0) if side == 1 else (y > 5.0) & (y < 5.0 + shadow)
    seen = np.unique(scan.profile_index)
    np.testing.assert_array_equal(np.isin(np.arange(len(s)), seen), ~hidden)
    assert scan.info["occluded"] == hidden.sum() * len(u)
    # No camera, no shadow.
    flat = scan_mesh(*mesh, replace(spec, triangulation_deg=0.0))
    assert flat.info["occluded"] == 0 and flat.info["points"] == flat.info["rays"]


def test_camera_hides_part_of_a_bore_wall_the_laser_lights():
    radius, sides = 2.0, 64
    verts, tris, n_plate = holed_plate(radius=radius, sides=sides)
    # Laser tilted 30 deg about the line: it lights the far half of the bore wall.
    view = np.array([0.0, math.sin(math.radians(30)), -math.cos(math.radians(30))])
    spec = replace(BASE, view=tuple(view), line_length=6.0, scan_length=6.0, point_pitch=0.05,
                   line_pitch=0.05)

    def wall_scan(**kw):
        scan = scan_mesh(verts, tris, replace(spec, **kw))
        wall = scan.triangle_id >= n_plate
        return scan, wall, set(zip(scan.profile_index[wall].tolist(), scan.column_index[wall].tolist()))

    scan0, wall0, lit = wall_scan(triangulation_deg=0.0)
    _, _, near_vertical = wall_scan(triangulation_deg=25.0, camera_side=1)   # camera at 5 deg
    scan, _, oblique = wall_scan(triangulation_deg=25.0, camera_side=-1)     # camera at 55 deg
    assert scan0.info["occluded"] == 0 and len(lit) > 1000
    # A line of sight steeper than the laser's enters the (convex) opening wherever the laser did.
    assert near_vertical == lit
    assert 0 < len(oblique) < 0.9 * len(lit) and oblique <= lit
    # Known answer: a wall point is seen when its line of sight to the camera crosses the surface
    # inside the opening (between the polygon's inscribed and circumscribed circles: undecided).
    u, st = expected_lattice(spec)
    motion = np.cross([1.0, 0.0, 0.0], view)
    baseline = -100.0 * math.tan(math.radians(25.0)) * motion
    p = scan0.points[wall0]
    j, i = scan0.profile_index[wall0], scan0.column_index[wall0]
    camera = (-100.0 * view + st[j, None] * motion + u[i, None] * [1.0, 0.0, 0.0] + baseline)
    sight = camera - p
    crossing = p[:, :2] + (-p[:, 2] / sight[:, 2])[:, None] * sight[:, :2]
    rho = np.hypot(crossing[:, 0], crossing[:, 1])
    seen = np.array([key in oblique for key in zip(j.tolist(), i.tolist())])
    assert np.all(rho[seen] < radius + 1e-9)
    assert np.all(rho[~seen] > radius * math.cos(math.pi / sides) - 1e-9)
    assert scan.info["occluded"] >= len(lit) - len(oblique)


def test_no_points_inside_the_hole_at_the_surface():
    radius, sides = 2.0, 64
    verts, tris, n_plate = holed_plate(radius=radius, sides=sides)
    spec = replace(BASE, fan=True, triangulation_deg=25.0, line_length=8.0, scan_length=8.0,
                   point_pitch=0.05, line_pitch=0.05, standoff=30.0, max_incidence_deg=89.0)
    scan = scan_mesh(verts, tris, spec)
    rho = np.hypot(scan.points[:, 0], scan.points[:, 1])
    top = np.abs(scan.points[:, 2]) < 1e-9
    on_plate = scan.triangle_id < n_plate
    np.testing.assert_array_equal(top, on_plate)
    assert rho[top].min() >= radius * math.cos(math.pi / sides) - 1e-9
    wall = ~on_plate
    assert wall.sum() > 0 and np.all(scan.points[wall, 2] < 0)
    np.testing.assert_allclose(rho[wall].max(), radius, atol=1e-9)
    assert scan.info["occluded"] > 0


@pytest.mark.parametrize("triangulation", [0.0, 25.0])
def test_a_wide_line_changes_nothing_on_a_flat_face(triangulation):
    spec = replace(BASE, fan=True, triangulation_deg=triangulation, line_length=6.0, scan_length=6.0)
    thin = scan_mesh(*plate(), spec)
    wide = scan_mesh(*plate(), replace(spec, line_width=0.06))
    np.testing.assert_allclose(wide.points, thin.points, atol=1e-9)
    assert wide.info == thin.info


@pytest.mark.parametrize("side", [1, -1])
def test_a_wide_line_makes_mixed_pixels_at_a_hole_edge(side):
    """Where the footprint straddles the rim only part of it returns light: the centroid moves by up
    to w/2 along the motion and the point by up to w/2/tan(triangulation) in height, above the surface
    on one side of the hole (along the motion) and below it on the other, as the camera side says;
    nothing farther than w/2 inside the edge, and the ideal line's points are unchanged elsewhere."""
    radius, sides, width, angle = 2.0, 256, 0.04, 25.0
    verts, tris, n_plate = holed_plate(radius=radius, sides=sides)
    spec = replace(BASE, fan=False, triangulation_deg=angle, camera_side=side, line_length=6.0, scan_length=6.0,
                   point_pitch=0.05, line_pitch=0.05, max_incidence_deg=89.0)
    scan = scan_mesh(verts, tris, replace(spec, line_width=width))
    x, y, z = scan.points.T
    rho = np.hypot(x, y)
    top = scan.triangle_id < n_plate
    bound = width / 2.0 / math.tan(math.radians(angle))
    mixed = top & (np.abs(z) > 1e-9)
    assert mixed.sum() > 20
    assert np.all(np.abs(z[top]) <= bound * (1 + 1e-6))
    assert np.abs(z[top]).max() > 0.6 * bound
    assert np.all(rho[mixed] > radius - width / 2.0 - 1e-9) and np.all(rho[mixed] < radius + width / 2.0)
    # above on one side, below on the other: the sign of height * y is the camera's side
    assert np.all(np.sign(z[mixed]) * np.sign(y[mixed]) == -side)
    far = rho > radius + width
    thin = scan_mesh(verts, tris, spec)
    keep = np.hypot(*thin.points[:, :2].T) > radius + width
    np.testing.assert_allclose(np.sort(z[far]), np.sort(thin.points[keep, 2]), atol=1e-9)


def test_a_wide_line_without_triangulation_mixes_ranges():
    """With the camera on the laser the sensor reads the mean range of the lit sub-rays: at the rim
    of a blind hole, points between the surface and the floor, never above the surface."""
    radius, depth, width = 2.0, 0.1, 0.05
    verts, tris, _ = holed_plate(radius=radius, sides=256, depth=depth)
    floor = np.array([[-3.0, -3.0, -depth], [3.0, -3.0, -depth], [3.0, 3.0, -depth], [-3.0, 3.0, -depth]])
    verts, tris = merge((verts, tris), (floor, np.array([[0, 1, 2], [0, 2, 3]])))
    spec = replace(BASE, line_length=6.0, scan_length=6.0, point_pitch=0.05, line_pitch=0.05, line_width=width)
    z = scan_mesh(verts, tris, spec).points[:, 2]
    between = (z < -1e-9) & (z > -depth + 1e-9)
    assert between.sum() > 20 and np.all(z < 1e-9)


def test_keep_nan_writes_one_row_per_ray():
    spec = replace(BASE, line_length=30.0, scan_length=1.0, point_pitch=0.5, keep_nan=True,
                   dropout=0.1)
    scan = scan_mesh(*plate(half=5.0), spec, rng=5)
    info = scan.info
    assert len(scan.points) == info["rows"] == info["rays"] == 61 * 11
    missing = np.isnan(scan.points).any(axis=1)
    assert missing.sum() == info["missed"] + info["dropped"]
    np.testing.assert_array_equal(missing, scan.triangle_id < 0)
    np.testing.assert_array_equal(missing, np.isnan(scan.ranges))
    np.testing.assert_array_equal(scan.column_index, np.tile(np.arange(61), 11))
    assert info["missed"] == 11 * 40   # |x| > 5 misses the plate


# -------------------------------------------------------------------------------------------------
# output frame and precision


FRAME = np.eye(4)
FRAME[:3, :3] = rotation_matrix((32.0, -10.0, 20.0))
FRAME[:3, 3] = (1500.0, -800.0, 1200.0)


def test_robot_frame_is_a_rigid_move_then_scale():
    spec = replace(BASE, fan=True, triangulation_deg=25.0)
    part = scan_mesh(*plate(), spec)
    robot = scan_mesh(*plate(), replace(spec, frame=FRAME.tolist(), unit_scale=1e-3))
    expected = (part.points @ FRAME[:3, :3].T + FRAME[:3, 3]) * 1e-3
    np.testing.assert_allclose(robot.points, expected, rtol=0, atol=1e-12)
    np.testing.assert_allclose(transform_to_frame(part.points, FRAME, 1e-3), expected, rtol=0, atol=1e-15)
    np.testing.assert_allclose(robot.ranges, part.ranges * 1e-3, rtol=1e-15)
    d_part = np.linalg.norm(part.points[1:] - part.points[:-1], axis=1)
    d_robot = np.linalg.norm(robot.points[1:] - robot.points[:-1], axis=1)
    np.testing.assert_allclose(d_robot, 1e-3 * d_part, rtol=1e-9)


def test_float32_rounds_after_the_frame():
    spec = replace(BASE, range_noise=0.003, frame=FRAME, unit_scale=1e-3)
    exact = scan_mesh(*plate(), spec, rng=6)
    rounded = scan_mesh(*plate(), replace(spec, float32=True), rng=6)
    assert rounded.points.dtype == np.float64
    np.testing.assert_array_equal(rounded.points, rounded.points.astype(np.float32))
    np.testing.assert_array_equal(rounded.points, exact.points.astype(np.float32))
    assert not np.array_equal(rounded.points, exact.points)
    np.testing.assert_allclose(rounded.points, exact.points, rtol=1e-7, atol=0)


# -------------------------------------------------------------------------------------------------
# files


def test_load_mesh_reads_ply_and_stl(tmp_path):
    import open3d as o3d

    verts, tris, _ = holed_plate(sides=16)
    mesh = o3d.geometry.TriangleMesh(o3d.utility.Vector3dVector(verts),
                                     o3d.utility.Vector3iVector(tris.astype(np.int32)))
    mesh.compute_triangle_normals()
    for name in ("part.ply", "part.STL"):
        path = tmp_path / name
        assert o3d.io.write_triangle_mesh(str(path), mesh)
        v, t = load_mesh(path)
        assert t.shape == tris.shape and t.dtype == np.int64
        np.testing.assert_allclose(v[t], verts[tris], atol=1e-6)   # STL stores float32 corners
    assert scan_mesh(v, t, BASE).info["points"] > 0


@pytest.mark.parametrize("name, content, match", [
    ("missing.stl", None, "no such file"),
    ("empty.ply", b"", "no triangles"),
    ("garbage.stl", b"not a mesh\n", "no triangles"),
    ("part.step", b"ISO-10303-21;", "unsupported mesh extension"),
])
def test_load_mesh_refuses_bad_files(tmp_path, capfd, name, content, match):
    path = tmp_path / name
    if content is not None:
        path.write_bytes(content)
    with pytest.raises(LoadError, match=match) as err:
        load_mesh(path)
    assert name in str(err.value)
    assert "Open3D" not in capfd.readouterr().out   # stdout carries data only


# -------------------------------------------------------------------------------------------------
# validation


@pytest.mark.parametrize("field, value, match", [
    ("target", (0.0, 1.0), "target must be 3 finite numbers"),
    ("standoff", 0.0, "standoff must be a finite number > 0, got 0.0"),
    ("standoff", float("nan"), "standoff must be a finite number > 0"),
    ("view", (0.0, 0.0, 0.0), "view must be a non-zero direction"),
    ("line", (0.0, 0.1, 1.0), "line must be perpendicular to view"),
    ("motion", (1.0, 0.0, 0.0), "motion must be None or perpendicular"),
    ("line_length", -1.0, "line_length must be a finite number >= 0"),
    ("point_pitch", 0.0, "point_pitch must be a finite number > 0"),
    ("line_pitch", float("inf"), "line_pitch must be a finite number > 0"),
    ("fan", 1, "fan must be True or False"),
    ("triangulation_deg", 90.0, r"triangulation_deg must be a finite angle in \[0, 90\)"),
    ("camera_side", 0, "camera_side must be \\+1 or -1"),
    ("max_incidence_deg", 0.0, r"max_incidence_deg must be a finite angle in \(0, 90\]"),
    ("range_noise", -0.1, "range_noise must be a finite number >= 0"),
    ("range_quantum", -1e-3, "range_quantum must be a finite number >= 0"),
    ("dropout", 1.0, r"dropout must be a probability in \[0, 1\), got 1.0"),
    ("jitter", "big", "jitter must be a finite number >= 0"),
    ("jitter", "0.1", "jitter must be a finite number >= 0, got '0.1'"),
    ("frame", np.diag([2.0, 1.0, 1.0, 1.0]), "frame must be a rigid transform"),
    ("frame", np.diag([-1.0, 1.0, 1.0, 1.0]), "frame must be a rigid transform"),
    ("unit_scale", 0.0, "unit_scale must be a finite number > 0"),
    ("float32", "yes", "float32 must be True or False"),
    ("line_width", -0.01, "line_width must be a finite number >= 0"),
    ("line_subrays", 1, "line_subrays must be an integer >= 2"),
    ("line_subrays", 3.0, "line_subrays must be an integer >= 2"),
    ("point_pitch", 1e-6, "at most 50000000 rays"),
])
def test_invalid_spec_is_refused(field, value, match):
    with pytest.raises(SpecError, match=match):
        scan_mesh(*plate(), replace(BASE, **{field: value}))


def test_directions_are_normalized():
    scan = scan_mesh(*plate(), replace(BASE, view=(0.0, 0.0, -7.0), line=(2.0, 0.0, 0.0)))
    np.testing.assert_array_equal(scan.points, scan_mesh(*plate(), BASE).points)


@pytest.mark.parametrize("vertices, triangles, match", [
    (np.zeros((4, 2)), [[0, 1, 2]], r"vertices must be an \(m, 3\) array"),
    ([[0, 0, 0], [1, 0, 0], [0, np.nan, 0]], [[0, 1, 2]], "vertices must be finite"),
    (np.eye(3), np.zeros((0, 3), dtype=int), r"triangles must be a \(k, 3\) array"),
    (np.eye(3), [[0, 1, 3]], r"triangles must be indices in \[0, 3\)"),
    (np.eye(3), [[0.0, 1.0, 2.0]], "triangles must be integer vertex indices"),
])
def test_invalid_mesh_is_refused(vertices, triangles, match):
    with pytest.raises(SpecError, match=match):
        scan_mesh(vertices, triangles, BASE)


def test_transform_to_frame_refuses_bad_arguments():
    with pytest.raises(SpecError, match=r"points must be an \(n, 3\) array"):
        transform_to_frame(np.zeros((3, 2)), FRAME)
    with pytest.raises(SpecError, match="matrix must be a 4x4 matrix"):
        transform_to_frame(np.zeros((3, 3)), np.eye(3))
    with pytest.raises(SpecError, match="unit_scale must be a finite number > 0"):
        transform_to_frame(np.zeros((3, 3)), None, -1.0)
