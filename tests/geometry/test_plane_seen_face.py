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
