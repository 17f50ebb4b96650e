"""fit_plane_robust's view: the face a sensor sees, not the one holding the most points (issue 24, CAD-made
clouds: a sampled mesh holds its bottom, sides and bore walls as well as its top)."""

import numpy as np

from holecli.geometry.plane import _dominant_face, _seen_face, fit_plane_robust

DOWN = np.array([0.0, 0.0, -1.0])
TOP = (900, np.array([0.0, 0.0, 1.0]), 0.0, 1e-3)
BOTTOM = (950, np.array([0.0, 0.0, -1.0]), 3.0, 1e-3)  # the plane z = -3 (n . x = offset with n = -z)
SIDE = (1000, np.array([1.0, 0.0, 0.02]) / np.hypot(1.0, 0.02), 5.0, 1e-3)  # a side wall, 1.1 deg off the view


def test_a_side_face_is_not_seen_face_on():
    """SEEN_FACE_MAX_DEG: a side wall holding the most points of the sample runs along the view (where the
    view's line meets it is meaningless: here 250 mm before the top) and is not the surface."""
    assert _seen_face([SIDE, TOP, BOTTOM], DOWN) is TOP


def test_the_nearest_of_two_sheet_faces():
    """The top and the bottom of a sampled sheet hold about as many points: the nearer is the surface,
    whichever way its normal is written."""
    assert _seen_face([BOTTOM, TOP], DOWN) is TOP
    assert _seen_face([BOTTOM, TOP], -DOWN) is BOTTOM
    flipped = (TOP[0], -TOP[1], -TOP[2], TOP[3])
    assert _seen_face([BOTTOM, flipped], DOWN) is flipped


def test_two_sided_sheet():
    """Both faces of a 3 mm sheet sampled evenly (the bottom with 10 % more points): the view picks the top."""
    rng = np.random.default_rng(0)
    top = np.column_stack([rng.uniform(-20, 20, (4000, 2)), np.zeros(4000)])
    bottom = np.column_stack([rng.uniform(-20, 20, (4400, 2)), np.full(4400, -3.0)])
    points = np.vstack([top, bottom])
    # without a view, faces holding alike many points: the one a sensor above +z sees (_dominant_face)
    assert abs(float(fit_plane_robust(points).point[2])) < 1e-9
    assert abs(float(fit_plane_robust(points, view=DOWN).point[2])) < 1e-9
    assert abs(float(fit_plane_robust(points, view=-DOWN).point[2]) + 3.0) < 1e-9


def test_without_a_view_the_largest_face_unless_another_holds_nearly_as_many():
    """_dominant_face: a scan's own surface holds far more points than any other face it shows, and stays
    the surface whichever way it faces (a robot's frame may put it across +z); of two faces holding alike
    many points (a sheet sampled on both sides) the one toward +z is taken."""
    floor = (300, np.array([0.0, 0.0, 1.0]), 8.0, 1e-3)  # a small face nearer +z: a boss's top
    assert _dominant_face([SIDE, floor]) is SIDE
    assert _dominant_face([BOTTOM, TOP]) is TOP
    assert _dominant_face([BOTTOM, (500, TOP[1], TOP[2], TOP[3])]) is BOTTOM
    # SHEET_SIDES_MAX_DEG: a face across the largest (an angle's other flange) is another surface
    across = (900, np.array([0.0, 1.0, 0.0]), 0.0, 1e-3)
    assert _dominant_face([BOTTOM, across]) is BOTTOM


def _sheet_with_large_holes(rng, holes=((-8.0, 0.0), (8.0, 0.0)), radius=6.0):
    """A 3 mm sheet sampled on both sides, its top with two large holes (the top holds under 80 % of the
    bottom's points), the bottom whole, as a cloud sampled from every face of a mesh holds them."""
    top = rng.uniform(-20, 20, (4800, 2))  # sampled at 0.8 of the bottom's density
    for center in holes:
        top = top[np.hypot(*(top - center).T) > radius]
    bottom = rng.uniform(-20, 20, (6000, 2))
    return np.column_stack([top, np.zeros(len(top))]), np.column_stack([bottom, np.full(len(bottom), -3.0)])


def test_a_face_hidden_behind_the_surface_is_not_seen():
    """_hidden / HIDDEN_SHARE: the bottom of a sampled sheet lies under its top along the view; whatever
    its share of the points (here it holds under 0.7 of the bottom's), the sensor sees
    the top, and the bottom's points are the ones a sensor cannot have recorded (hidden_points)."""
    from holecli.geometry.plane import hidden_points

    top, bottom = _sheet_with_large_holes(np.random.default_rng(1))
    assert len(top) < 0.7 * len(bottom)
    points = np.vstack([top, bottom])
    plane = fit_plane_robust(points, view=DOWN)
    assert abs(float(plane.point[2])) < 1e-9
    hidden = hidden_points(points, plane, DOWN)
    assert hidden[len(top):].all() and not hidden[:len(top)].any()
    # from below, the bottom is seen and the top is hidden behind it
    plane = fit_plane_robust(points, view=-DOWN)
    assert abs(float(plane.point[2]) + 3.0) < 1e-9
    assert hidden_points(points, plane, -DOWN)[:len(top)].all()


def test_a_floor_seen_around_a_part_is_not_hidden():
    """A scan's fixture floor, seen around the part and through its holes, lies mostly clear of the part
    along the view: nothing is dropped (a sensor recorded it, so it was seen)."""
    rng = np.random.default_rng(2)
    top, _ = _sheet_with_large_holes(rng, holes=((0.0, 0.0),), radius=3.0)
    top = top[(np.abs(top[:, 0]) < 10) & (np.abs(top[:, 1]) < 10)]
    floor = rng.uniform(-30, 30, (3000, 2))
    floor = floor[(np.abs(floor[:, 0]) > 10) | (np.abs(floor[:, 1]) > 10) | (np.hypot(*floor.T) < 3.0)]
    points = np.vstack([top, np.column_stack([floor, np.full(len(floor), -5.0)])])
    plane = fit_plane_robust(points, view=DOWN)
    assert plane.hidden == ()


def test_without_a_view_only_a_sheet_sampled_on_both_sides_has_a_hidden_face():
    """_sheet_sides: without a view, the bottom of a sheet sampled on both sides (faces holding alike many
    points) lies hidden behind the top a sensor above +z sees; a scan's own surface over a floor holding
    far fewer points hides nothing (the floor is seen through the holes, the side's cue)."""
    from holecli.geometry.plane import hidden_points

    rng = np.random.default_rng(3)
    top = np.column_stack([rng.uniform(-20, 20, (5000, 2)), np.zeros(5000)])
    bottom = np.column_stack([rng.uniform(-20, 20, (5000, 2)), np.full(5000, -3.0)])
    points = np.vstack([top, bottom])
    plane = fit_plane_robust(points)
    assert abs(float(plane.point[2])) < 1e-9 and len(plane.hidden) == 1
    assert hidden_points(points, plane, (0.0, 0.0, -1.0)).sum() == len(bottom)
    floor = bottom[:1500]
    assert fit_plane_robust(np.vstack([top, floor])).hidden == ()
