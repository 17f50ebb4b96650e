"""Acceptance: the named checks that make a candidate void a hole, each a function of the scene, the
candidate (:class:`holecli.robust.candidate.Candidate`) and the settings that returns a
:class:`holecli.robust.candidate.Refusal` (the check's code, a key of
:data:`holecli.vocabulary.REJECTION_REASONS`, its value and limit, where the void is) or None.

The measurement (:func:`holecli.robust.measure.measure_candidate`) runs them in stages, each stage's
checks in the order of its tuple (:func:`first_refusal`):

* :data:`VOID_CHECKS`, before any triangulation: an empty disk of the smallest reported size fits in
  the void;
* :data:`RIM_CHECKS`, on the rim extracted around it (again after the points deep inside a first circle
  are dropped);
* :data:`FIT_CHECKS`, on the circle fitted to that rim (again after the refit);
* :data:`EDGE_CHECKS`, on the circle kept: empty inside, round, not a cut-out's sides, enough of a
  partial hole's rim, no boss;
* and :func:`edge_below_min_diameter` once more on the edge the estimator corrected.

Then the method (:func:`holecli.robust.method.detect_robust`) selects among the holes measured, by the
selection checks: :func:`duplicate` (two candidates of one hole), :func:`partial_left_out`
(``full_only``), :func:`pocket` (a floor too shallow for a drilled hole) and :func:`beyond_max_holes`
(``max_holes``).

Every check is held by a counter-example scene (``tests/robust/test_acceptance.py``,
``tests/robust/test_rejections.py``) and by a table of small inputs
(``tests/robust/test_acceptance_checks.py``).
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from holecli.geometry.kernels import largest_angular_gap, robust_sigma
from holecli.robust.candidate import Refusal

__all__ = ["EDGE_CHECKS", "FIT_CHECKS", "RIM_CHECKS", "VOID_CHECKS", "below_min_diameter", "beyond_max_holes", "boss",
           "duplicate", "edge_below_min_diameter", "first_refusal", "material_in_first_circle", "material_inside",
           "no_circle_fit", "no_rim", "not_round", "partial_left_out", "partial_rim_arc", "pocket",
           "too_few_fitted_points", "too_few_partial_rim_points", "too_few_rim_points", "void_below_min_diameter"]


def _refusal(check, value, limit, place, shape=None):
    center, radius = place
    return Refusal(check=check, value=value, limit=limit, center=center, radius=float(radius), shape=shape)


def void_below_min_diameter(scene, candidate, settings):
    """``below_min_diameter`` before any triangulation: no disk empty of material that is centred in
    the void may reach the smallest reported radius (the natural gaps of random sampling, which grow
    with the points). Placed at that largest empty disk."""
    largest, where = _largest_empty_radius(scene, candidate.void_xy, scene.void_reach, candidate.void.cells)
    if largest < scene.min_radius:
        return _refusal("below_min_diameter", 2.0 * largest, 2.0 * scene.min_radius, (where, largest))
    return None


def no_rim(scene, candidate, settings):
    """``no_rim``: no hole boundary around the void (a gap of the sampling)."""
    if candidate.rim_xy is None:
        return _refusal("no_rim", None, None, candidate.place)
    return None


def too_few_rim_points(scene, candidate, settings):
    """``too_few_rim_points``: fewer rim points than a circle fit needs (``candidate.fewest``)."""
    if len(candidate.rim_xy) < candidate.fewest:
        return _refusal("too_few_rim_points", len(candidate.rim_xy), candidate.fewest, candidate.place)
    return None


def no_circle_fit(scene, candidate, settings):
    """``no_circle_fit``: the rim points do not give a circle (placed at the void)."""
    if candidate.fit is None:
        return _refusal("no_circle_fit", None, None, (candidate.void_center, candidate.void_radius))
    return None


def too_few_fitted_points(scene, candidate, settings):
    """``too_few_rim_points``: the clipped fit kept fewer rim points than a circle fit needs."""
    kept = int(candidate.used.sum())
    if kept < candidate.fewest:
        return _refusal("too_few_rim_points", kept, candidate.fewest, candidate.place)
    return None


def below_min_diameter(scene, candidate, settings):
    """``below_min_diameter``: the fitted circle is smaller than the minimum diameter."""
    radius = candidate.fit.radius
    if radius < scene.min_radius:
        return _refusal("below_min_diameter", 2.0 * radius, 2.0 * scene.min_radius, candidate.place)
    return None


def material_inside(scene, candidate, settings):
    """``material_inside``: surface material fills the inner half of the circle (the island of a
    groove, not a hole; :func:`_material_inside`)."""
    inside, allowed = _material_inside(scene, candidate.fit.center, candidate.fit.radius, settings)
    if inside > allowed:
        return _refusal("material_inside", inside, allowed, candidate.place)
    return None


def not_round(scene, candidate, settings):
    """``not_round``: the robust scatter of the rim's radial residuals exceeds ``max_relative_scatter``
    of the radius plus the scatter the sampling alone gives; with the outline's shape (a slot)."""
    scatter = robust_sigma(candidate.fit.residuals)
    allowed = settings.max_relative_scatter * candidate.fit.radius + scene.gap_scatter
    if scatter > allowed:
        return _refusal("not_round", scatter, float(allowed), candidate.place, shape=_outline_shape(candidate.rim_xy))
    return None


def material_in_first_circle(scene, candidate, settings):
    """``material_in_first_circle``: the points dropped from deep inside the first circle were
    material, not reflections.

    The refit is only as good as the points it dropped: a long cut-out (a slot, a rectangular window)
    first fits a circle across its own long sides, and without them its ends give a round rim. A
    hole's first circle holds reflections only (<= 1 % of the disk on the validation scans). Placed at
    the first circle, with the outline of its rim.
    """
    first = candidate.first
    if first is not None and first.inside > first.allowed:
        return _refusal("material_in_first_circle", first.inside, first.allowed, (first.center, first.radius),
                        shape=_outline_shape(first.rim_xy))
    return None


def partial_rim_arc(scene, candidate, settings):
    """``partial_rim_arc``: a partial hole (``candidate.partial``) whose fitted rim points cover less
    than ``min_partial_arc_deg`` of its circle (:func:`_rim_arc`)."""
    if not candidate.partial:
        return None
    rim_arc = _rim_arc(candidate.rim_xy[candidate.used], candidate.fit.center)
    if rim_arc < settings.min_partial_arc_deg:
        return _refusal("partial_rim_arc", float(rim_arc), settings.min_partial_arc_deg, candidate.place)
    return None


def too_few_partial_rim_points(scene, candidate, settings):
    """``too_few_rim_points``: a partial hole whose fit kept fewer than ``min_partial_rim_points``."""
    if not candidate.partial:
        return None
    kept = int(candidate.used.sum())
    if kept < settings.min_partial_rim_points:
        return _refusal("too_few_rim_points", kept, settings.min_partial_rim_points, candidate.place)
    return None


def boss(scene, candidate, settings):
    """``boss``: material stands above the surface inside the circle (:func:`_boss_points`)."""
    above, allowed = _boss_points(scene, candidate.fit.center, candidate.fit.radius, settings)
    if above > allowed:
        return _refusal("boss", above, allowed, candidate.place)
    return None


def edge_below_min_diameter(scene, center, radius):
    """``below_min_diameter`` of the edge an estimator measured (``radius``, corrected at ``center``)."""
    if radius < scene.min_radius:
        return _refusal("below_min_diameter", 2.0 * radius, 2.0 * scene.min_radius, (center, radius))
    return None


#: The checks of each stage, in the order they run.
VOID_CHECKS = (void_below_min_diameter,)
RIM_CHECKS = (no_rim, too_few_rim_points)
FIT_CHECKS = (no_circle_fit, too_few_fitted_points, below_min_diameter)
EDGE_CHECKS = (material_inside, not_round, material_in_first_circle, partial_rim_arc, too_few_partial_rim_points,
               boss)


def duplicate(measured, twin):
    """``duplicate``: ``measured`` (a :class:`holecli.robust.candidate.Measured`) overlaps ``twin``, whose
    circle fit kept at least as many rim points; None when ``measured`` kept more (``twin`` is then the
    duplicate: ``duplicate(twin, measured)``)."""
    kept, twin_kept = int(measured.fit.kept.sum()), int(twin.fit.kept.sum())
    if kept > twin_kept:
        return None
    return _refusal("duplicate", kept, twin_kept, (measured.center, measured.radius))


def partial_left_out(measured, full_only, settings):
    """``partial_left_out``: a partial hole when only full holes are asked for (``full_only``)."""
    if full_only and measured.partial:
        return _refusal("partial_left_out", measured.arc_deg, settings.full_arc_deg,
                        (measured.center, measured.radius))
    return None


def pocket(measured, hole, settings):
    """``pocket``: the blind ``hole`` (the :class:`holecli.results.Hole` of ``measured``) has a floor
    shallower than ``pocket_max_depth_ratio`` diameters (a pocket or spot face, not a drilled hole);
    the value is that depth in diameters."""
    if hole.type != "blind" or hole.bore is None or hole.bore.floor_depth is None:
        return None
    ratio = float(hole.bore.floor_depth) / hole.diameter
    if ratio < settings.pocket_max_depth_ratio:
        return _refusal("pocket", ratio, settings.pocket_max_depth_ratio, (measured.center, measured.radius))
    return None


def beyond_max_holes(diameters, places, max_holes):
    """``beyond_max_holes``: the holes of ``diameters`` smaller than the ``max_holes`` largest (None: no
    limit); the value is the hole's diameter, the limit the smallest kept.

    Parameters
    ----------
    diameters : sequence of float
    places : callable
        ``places(i) -> (center, radius)``: where hole ``i`` is (plane frame).
    max_holes : int or None

    Returns
    -------
    kept : list of int
        The indices of the holes kept: all, in their order, within the limit; else the largest first.
    refusals : list of Refusal
        Of the holes left out, largest first.
    """
    if max_holes is None or len(diameters) <= max_holes:
        return list(range(len(diameters))), []
    ranked = sorted(range(len(diameters)), key=lambda i: -diameters[i])
    kept = ranked[:max_holes]
    limit = diameters[kept[-1]]
    return kept, [_refusal("beyond_max_holes", diameters[i], limit, places(i)) for i in ranked[max_holes:]]


def first_refusal(checks, scene, candidate, settings):
    """The :class:`holecli.robust.candidate.Refusal` of the first of ``checks`` that refuses the
    candidate, else None."""
    for check in checks:
        refused = check(scene, candidate, settings)
        if refused is not None:
            return refused
    return None


def _rim_arc(rim_xy, center):
    """Degrees of the circle not in the largest angular gap between rim points."""
    return float(np.degrees(2 * np.pi - largest_angular_gap(rim_xy, center)))


def _material_inside(scene, center, radius, settings):
    """Surface material points within half the radius of a fitted circle, and how many it may hold.

    A groove around a standing island (an O-ring groove, a C-shaped slot) is a void whose outer rim is
    a good circle: the fit takes it and the island stands inside. A hole's inner half holds at most a
    few reflections (specks, not material); an island fills it.

    Parameters
    ----------
    scene : holecli.robust.scene.Scene
    center : (2,) float
        The fitted circle's center, plane frame.
    radius : float
        Its radius.
    settings : RobustSettings

    Returns
    -------
    inside : int
        Material points of the surface within ``radius / 2`` of ``center``.
    allowed : float
        ``max_material_inside`` (setting) times the surface points that area would hold.
    """
    inside = scene.count_in_disk(scene.material_xy, center, 0.5 * radius)
    return inside, scene.disk_allowance(0.5 * radius, settings.max_material_inside)


def _boss_points(scene, center, radius, settings):
    """Points standing above the surface inside the void, and how many a hole may have: more is
    material (a pin or boss), not a hole.

    Counted over the part of the disk inside the scan (:meth:`holecli.robust.scene.Scene.scanned_fraction`):
    a boss cut by the scan's border stands over that part only, and against the whole disk its points
    were too few (a boss a quarter inside the scan was a partial Ø4.2 hole, ``benchmarks/cutouts.py``).
    """
    above = scene.count_in_disk(scene.above_xy, center, 0.9 * radius)
    allowed = scene.disk_allowance(0.9 * radius, settings.boss_fraction)
    if above:
        allowed *= scene.scanned_fraction(center, 0.9 * radius)
    return above, allowed


def _largest_empty_radius(scene, void_xy, reach, cells=None):
    """An upper bound of the radius of any disk empty of material points whose center lies in the void
    (its cells' centers ``void_xy``).

    The distance to the nearest material point is 1-Lipschitz, and every point of the void lies within
    half a cell's diagonal of a cell center: the bound is the largest nearest-point distance at the
    centers plus that half diagonal. Only the material within ``reach`` of the void's cells is looked
    at (a farther point would give a larger distance: the bound stays an upper bound), and a bound
    beyond ``reach`` is not refined. Returns the bound and the cell center it was found at.

    A scene with cell indices (many candidates) reads the distances of the void's grid ``cells``
    (their centers ``void_xy``) from :attr:`holecli.robust.scene.Scene.empty_cell_clearance`: the same
    distances, from one query of every empty cell.
    """
    if (cells is not None and getattr(scene, "material_cells", None) is not None and reach == scene.void_reach
            and np.array_equal(void_xy, scene.grid.center_of(cells))):
        distance = scene.empty_cell_clearance[cells[:, 0], cells[:, 1]]
    else:
        low, high = void_xy.min(axis=0) - reach, void_xy.max(axis=0) + reach
        near = scene.material_xy[scene.box(scene.material_xy, low, high)]
        if len(near) == 0:
            return np.inf, void_xy.mean(axis=0)
        distance, _ = cKDTree(near).query(void_xy, distance_upper_bound=reach)
    best = int(np.argmax(distance))
    return float(distance[best]) + scene.cell / np.sqrt(2.0), void_xy[best]


def _outline_shape(rim_xy):
    """Length, width and direction (plane frame) of a cut-out from its rim: its extent along its
    principal axes (a slot's overall length and width).

    The rim holds the material points within an alpha of the edge, a few rows deep: the width is
    taken between the innermost rows of the two long sides (the 10th percentile of each side's
    distance from the axis, over the middle half of the length), the length between the innermost
    points of the two rounded ends, each corrected for where it sits on its end's semicircle.
    """
    centred = rim_xy - rim_xy.mean(axis=0)
    _, vectors = np.linalg.eigh(centred.T @ centred)
    major = vectors[:, 1]
    along, across = centred @ major, centred @ vectors[:, 0]
    middle = np.abs(along) < 0.25 * np.ptp(along)  # the long sides, away from the ends
    left, right = -across[middle & (across < 0)], across[middle & (across > 0)]
    if len(left) < 3 or len(right) < 3:
        return float(np.ptp(along)), float(np.ptp(across)), major
    width = float(np.percentile(left, 10) + np.percentile(right, 10))
    # On a rounded end a rim point at distance a from the axis lies sqrt(w^2/4 - a^2) short of the
    # end's tip: each end point gives the half length it implies; the innermost one counts.
    near_axis = np.abs(across) < 0.4 * width
    half = np.abs(along[near_axis]) + 0.5 * width - np.sqrt(np.maximum(0.25 * width ** 2 - across[near_axis] ** 2, 0.0))
    ends = np.sign(along[near_axis])
    if not (np.any(ends < 0) and np.any(ends > 0)):
        return float(np.ptp(along)), width, major
    length = float(half[ends < 0].min() + half[ends > 0].min())
    return length, width, major
