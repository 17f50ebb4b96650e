"""The acceptance checks (holecli.robust.acceptance) one at a time, on a small scene and hand-made
candidates: a candidate every check passes, and for each check a change that makes it refuse, with
its code, value, limit and place (the counter-example scenes of test_acceptance.py and
test_rejections.py hold the same checks through the whole method)."""

from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pytest

from holecli.geometry.circle import CircleFit
from holecli.robust import acceptance
from holecli.robust.candidate import Candidate, FirstCircle, Measured, Refusal
from holecli.robust.candidates import Void, find_voids
from holecli.robust.scene import build_scene
from holecli.settings import DEFAULT_SETTINGS
from holecli.vocabulary import REJECTION_REASONS

SPACING = 0.1
MATERIAL = np.array([-2.5, -2.5])  # a point of plain material, 2.5 mm from the hole's axis on both axes


@pytest.fixture(scope="module")
def scene():
    """A flat 8 x 8 mm plate on a 0.1 mm grid, a 2 mm hole at the origin with a 1.2 mm pin standing 1 mm
    high in it; seen from +z. The minimum diameter is 0.5 mm."""
    ticks = np.arange(-4.0, 4.0 + 1e-9, SPACING)
    x, y = (axis.ravel() for axis in np.meshgrid(ticks, ticks))
    plate = np.column_stack([x, y, np.zeros_like(x)])
    plate = plate[np.hypot(x, y) >= 1.0]
    pin = np.column_stack([x, y, np.ones_like(x)])[np.hypot(x, y) < 0.6]
    return build_scene(np.vstack([plate, pin]), view_dir=(0.0, 0.0, -1.0), min_diameter=0.5)


def _circle(center, radius, count=60, arc_deg=360.0):
    angles = np.radians(np.linspace(0.0, arc_deg, count, endpoint=False))
    return np.asarray(center) + radius * np.column_stack([np.cos(angles), np.sin(angles)])


def _fit(center=(0.0, 0.0), radius=1.0, residuals=None, count=60):
    residuals = np.zeros(count) if residuals is None else residuals
    return CircleFit(center=np.asarray(center, dtype=float), radius=radius, residuals=residuals,
                     kept=np.ones(count, dtype=bool))


# The hole at the origin: a void of its cells, a round rim of 60 points, a circle through them, full.
_VOID_XY = np.array([[i, j] for i in np.arange(-0.85, 0.9, 0.1) for j in np.arange(-0.85, 0.9, 0.1)
                     if np.hypot(i, j) < 0.9])
GOOD = Candidate(void=Void(cells=np.zeros((1, 2), dtype=np.int64), enclosed=True), void_xy=_VOID_XY,
                 void_center=np.zeros(2), void_radius=0.95, fewest=DEFAULT_SETTINGS.min_rim_points,
                 rim_xy=_circle((0.0, 0.0), 1.0), fit=_fit(), used=np.ones(60, dtype=bool), partial=False,
                 arc_deg=360.0)
WAVY = 0.2 * np.where(np.arange(60) % 2 == 0, 1.0, -1.0)


@pytest.mark.parametrize("check, change, code, value, limit, center, radius", [
    # no empty disk of the minimum radius fits in a void of material (the natural gaps of sampling)
    (acceptance.void_below_min_diameter, dict(void_xy=MATERIAL[None, :]), "below_min_diameter",
     None, 0.5, MATERIAL, None),
    (acceptance.no_rim, dict(rim_xy=None, fit=None), "no_rim", None, None, (0.0, 0.0), 0.95),
    (acceptance.too_few_rim_points, dict(rim_xy=_circle((0.0, 0.0), 1.0, count=5)), "too_few_rim_points",
     5, DEFAULT_SETTINGS.min_rim_points, (0.0, 0.0), 1.0),
    (acceptance.no_circle_fit, dict(fit=None), "no_circle_fit", None, None, (0.0, 0.0), 0.95),
    (acceptance.too_few_fitted_points, dict(used=np.arange(60) < 4), "too_few_rim_points",
     4, DEFAULT_SETTINGS.min_rim_points, (0.0, 0.0), 1.0),
    (acceptance.below_min_diameter, dict(fit=_fit(radius=0.2)), "below_min_diameter", 0.4, 0.5, (0.0, 0.0), 0.2),
    (acceptance.material_inside, dict(fit=_fit(center=MATERIAL)), "material_inside", None, None, MATERIAL, 1.0),
    (acceptance.not_round, dict(fit=_fit(residuals=WAVY)), "not_round", None, None, (0.0, 0.0), 1.0),
    (acceptance.material_in_first_circle,
     dict(first=FirstCircle(inside=40, allowed=3.5, center=np.array([0.1, 0.0]), radius=1.2,
                            rim_xy=_circle((0.1, 0.0), 1.2))),
     "material_in_first_circle", 40, 3.5, (0.1, 0.0), 1.2),
    (acceptance.partial_rim_arc, dict(partial=True, arc_deg=200.0, rim_xy=_circle((0.0, 0.0), 1.0, arc_deg=90.0)),
     "partial_rim_arc", None, DEFAULT_SETTINGS.min_partial_arc_deg, (0.0, 0.0), 1.0),
    (acceptance.too_few_partial_rim_points, dict(partial=True, arc_deg=200.0, used=np.arange(60) < 10),
     "too_few_rim_points", 10, DEFAULT_SETTINGS.min_partial_rim_points, (0.0, 0.0), 1.0),
    (acceptance.boss, {}, "boss", None, None, (0.0, 0.0), 1.0),
])
def test_each_check_refuses_its_counter_example_and_passes_a_hole(scene, check, change, code, value, limit, center,
                                                                   radius):
    if check is acceptance.boss:
        # the pin stands in the hole; the same circle in plain material has no pin (and no boss)
        passing, refusing = replace(GOOD, fit=_fit(center=MATERIAL)), GOOD
    else:
        passing, refusing = GOOD, replace(GOOD, **change)
    assert check(scene, passing, DEFAULT_SETTINGS) is None
    refused = check(scene, refusing, DEFAULT_SETTINGS)
    assert isinstance(refused, Refusal) and refused.check == code and code in REJECTION_REASONS
    if value is not None:
        assert refused.value == pytest.approx(value)
    if limit is not None:
        assert refused.limit == pytest.approx(limit)
    if refused.value is not None and refused.limit is not None:
        # every check with numbers refuses beyond its limit: above it for a count of what must not be
        # there, below it for one of what must
        above = code in ("material_inside", "not_round", "material_in_first_circle", "boss")
        assert refused.value > refused.limit if above else refused.value < refused.limit
    np.testing.assert_allclose(refused.center, center, atol=1e-12)
    if radius is not None:
        assert refused.radius == pytest.approx(radius)


def test_a_hole_passes_every_check_but_the_boss_of_its_pin(scene):
    for checks in (acceptance.VOID_CHECKS, acceptance.RIM_CHECKS, acceptance.FIT_CHECKS, acceptance.EDGE_CHECKS[:-1]):
        assert acceptance.first_refusal(checks, scene, GOOD, DEFAULT_SETTINGS) is None
    assert acceptance.EDGE_CHECKS[-1] is acceptance.boss
    assert acceptance.first_refusal(acceptance.EDGE_CHECKS, scene, GOOD, DEFAULT_SETTINGS).check == "boss"


def test_the_order_is_the_tuple(scene):
    # material inside and a rim that is not round: the first check of the tuple speaks
    both = replace(GOOD, fit=_fit(center=MATERIAL, residuals=WAVY))
    assert acceptance.first_refusal(acceptance.EDGE_CHECKS, scene, both, DEFAULT_SETTINGS).check == "material_inside"
    assert acceptance.EDGE_CHECKS.index(acceptance.material_inside) < acceptance.EDGE_CHECKS.index(acceptance.not_round)
    swapped = (acceptance.not_round, acceptance.material_inside)
    assert acceptance.first_refusal(swapped, scene, both, DEFAULT_SETTINGS).check == "not_round"


def test_a_refusal_of_the_corrected_edge(scene):
    assert acceptance.edge_below_min_diameter(scene, np.zeros(2), 0.3) is None
    refused = acceptance.edge_below_min_diameter(scene, np.zeros(2), 0.2)
    assert (refused.check, refused.value, refused.limit, refused.radius) == ("below_min_diameter", 0.4, 0.5, 0.2)


# The selection checks: among the holes measured, which are reported.

def _measured(center=(0.0, 0.0), radius=1.0, kept=60, partial=False, arc_deg=360.0):
    return Measured(center=np.asarray(center, dtype=float), radius=radius, bias=0.0,
                    fit=_fit(center, radius, count=kept), rim_xy=_circle(center, radius, count=kept),
                    partial=partial, arc_deg=arc_deg)


def _blind(diameter, floor_depth):
    return SimpleNamespace(type="blind", diameter=diameter, bore=SimpleNamespace(floor_depth=floor_depth))


PLACE = ((3.0, -1.0), 0.5)


@pytest.mark.parametrize("refuse, passing, refusing, code, value, limit, center, radius", [
    # of two candidates of one hole, the one whose fit kept fewer rim points (a tie: the one asked about)
    (lambda m, twin: acceptance.duplicate(m, twin), (_measured(kept=60), _measured(kept=40)),
     (_measured((0.1, 0.0), kept=40), _measured(kept=60)), "duplicate", 40, 60, (0.1, 0.0), 1.0),
    (lambda m, twin: acceptance.duplicate(m, twin), None,
     (_measured(kept=50), _measured(kept=50)), "duplicate", 50, 50, (0.0, 0.0), 1.0),
    # a partial hole, only when full holes only are asked for
    (lambda m, full_only: acceptance.partial_left_out(m, full_only, DEFAULT_SETTINGS),
     (_measured(partial=True, arc_deg=200.0), False), (_measured(partial=True, arc_deg=200.0), True),
     "partial_left_out", 200.0, DEFAULT_SETTINGS.full_arc_deg, (0.0, 0.0), 1.0),
    # a blind hole's floor shallower than a drilled hole's, in diameters
    (lambda m, hole: acceptance.pocket(m, hole, DEFAULT_SETTINGS),
     (_measured(), _blind(2.0, 2.0 * (DEFAULT_SETTINGS.pocket_max_depth_ratio + 0.01))),
     (_measured(), _blind(2.0, 2.0 * 0.5 * DEFAULT_SETTINGS.pocket_max_depth_ratio)),
     "pocket", 0.5 * DEFAULT_SETTINGS.pocket_max_depth_ratio, DEFAULT_SETTINGS.pocket_max_depth_ratio,
     (0.0, 0.0), 1.0),
])
def test_each_selection_check_refuses_its_counter_example(refuse, passing, refusing, code, value, limit, center,
                                                          radius):
    if passing is not None:
        assert refuse(*passing) is None
    refused = refuse(*refusing)
    assert isinstance(refused, Refusal) and refused.check == code and code in REJECTION_REASONS
    assert refused.value == pytest.approx(value) and refused.limit == pytest.approx(limit)
    np.testing.assert_allclose(refused.center, center, atol=1e-12)
    assert refused.radius == pytest.approx(radius)


def test_a_pocket_needs_a_blind_hole_with_a_floor():
    shallow = 0.1 * DEFAULT_SETTINGS.pocket_max_depth_ratio
    for hole in (SimpleNamespace(type="through", diameter=2.0, bore=None),
                 SimpleNamespace(type="blind", diameter=2.0, bore=None), _blind(2.0, None)):
        assert acceptance.pocket(_measured(), hole, DEFAULT_SETTINGS) is None
    assert acceptance.pocket(_measured(), _blind(2.0, shallow), DEFAULT_SETTINGS).check == "pocket"


@pytest.mark.parametrize("diameters, max_holes, kept, refused", [
    ([1.0, 3.0, 2.0], None, [0, 1, 2], []),            # no limit
    ([1.0, 3.0, 2.0], 3, [0, 1, 2], []),               # within it: all, in their order
    ([1.0, 3.0, 2.0], 2, [1, 2], [(1.0, 2.0)]),        # beyond it: the largest, largest first
    ([1.0, 3.0, 2.0, 0.5], 1, [1], [(2.0, 3.0), (1.0, 3.0), (0.5, 3.0)]),
])
def test_beyond_max_holes_keeps_the_largest(diameters, max_holes, kept, refused):
    places = lambda i: ((float(i), 0.0), 0.5 * diameters[i])  # noqa: E731
    indices, refusals = acceptance.beyond_max_holes(diameters, places, max_holes)
    assert indices == kept
    assert [(r.value, r.limit) for r in refusals] == refused
    assert all(r.check == "beyond_max_holes" and r.radius == 0.5 * r.value for r in refusals)
    assert all(r.value < r.limit for r in refusals)


def test_the_void_check_reads_the_same_distances_from_the_cell_indices():
    """With the cell indices (many candidates), the void check reads its distances from the scene's
    clearance of the empty cells: every void of a randomly sampled plate (its natural gaps) is refused
    or passed as a box query of its own material points refuses or passes it, at the same place."""
    rng = np.random.default_rng(3)
    xy = rng.uniform(-5.0, 5.0, (20_000, 2))
    xy = xy[np.hypot(*xy.T) >= 1.0]
    plain = build_scene(np.column_stack([xy, 0.001 * rng.standard_normal(len(xy))]), view_dir=(0.0, 0.0, -1.0))
    indexed = plain.with_cell_indices()
    candidates = [Candidate.of(void, plain.grid, DEFAULT_SETTINGS) for void in find_voids(plain.grid)]
    refused = 0
    for candidate in candidates:
        expected = acceptance.void_below_min_diameter(plain, candidate, DEFAULT_SETTINGS)
        got = acceptance.void_below_min_diameter(indexed, candidate, DEFAULT_SETTINGS)
        assert (got is None) == (expected is None)
        if expected is not None:
            assert (got.check, got.value, got.limit, got.radius) == (expected.check, expected.value,
                                                                      expected.limit, expected.radius)
            np.testing.assert_array_equal(got.center, expected.center)
            refused += 1
    assert 10 < refused < len(candidates)  # the gaps refused, the hole passed
