"""Tests of holecli.tolerance: tolerance forms, nominal specs, spec files, matching and verdicts."""

import copy
import math
from dataclasses import replace

import numpy as np
import pytest

from holecli.errors import SpecError
from holecli.simulation import synth
from holecli.tolerance import Band, check, describe, nominal_spec, parse_band, parse_spec

SPEC_TEXT = """
# two holes of a bracket
[[hole]]
name = "A1"
center = [0.0, 0.0, 0.0]
diameter = 3.0
tolerance = "+0.036/-0"
position_tolerance = 0.1
normal = [0.0, 0.0, 1.0]
max_tilt = 1.0

[[hole]]
name = "A2"
center = [10, 0, 0]
diameter = 4
tolerance = 0.05
"""


# What check() adds to every verdict under the default decision rule.
SIMPLE_VERDICT = {"undecided": 0, "decision_rule": "simple", "coverage_factor": 2.0}


def _hole(index, center, diameter, normal=(0.0, 0.0, 1.0)):
    return {"index": index, "center": list(center), "diameter": diameter, "normal": list(normal), "rim_points": 40,
            "fit_rms": 0.001, "partial": False}


def _record(*holes):
    return {"file": "part.ply", "points": 5000, "method": "robust", "holes": list(holes), "timing": {"elapsed_ms": 12.0}}


# --- tolerance forms -------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "value, lower, upper",
    [
        (0.05, -0.05, 0.05),
        (0, 0.0, 0.0),
        ("0.05", -0.05, 0.05),
        ("±0.05", -0.05, 0.05),
        ("+/-0.05", -0.05, 0.05),
        ("+-0.05", -0.05, 0.05),
        ("+0.036/-0", 0.0, 0.036),
        ("+0.036/0", 0.0, 0.036),
        ("0.036/-0.010", -0.010, 0.036),
        (" +0.036 / -0.010 ", -0.010, 0.036),
        ("-0.014/-0.035", -0.035, -0.014),  # a P7 hole: both deviations below the nominal size
        ("+0.034/+0.012", 0.012, 0.034),  # a G7 hole: both above
        ("1e-2/-1e-2", -0.01, 0.01),
    ],
)
def test_parse_band_accepts_every_form(value, lower, upper):
    band = parse_band(value)
    assert band == Band(lower=pytest.approx(lower, abs=1e-15), upper=pytest.approx(upper, abs=1e-15))
    # no negative zero leaks into the JSON
    assert math.copysign(1.0, band.lower) == 1.0 or band.lower != 0.0


@pytest.mark.parametrize(
    "value, match",
    [
        (-0.1, "symmetric tolerance must be a number >= 0"),
        ("-0.1", "symmetric tolerance must be a number >= 0"),
        ("0.05/0.05", "with its sign"),
        ("-0.010/+0.036", r"upper deviation \(first\) is below the lower one.*did you mean \+0.036/-0.010"),
        ("abc", "expected a number >= 0 or a string"),
        ("+0.036/", "expected a number"),
        ("1/2/3", "expected a number"),
        ("nan", "expected a number"),
        ("inf/-0", "expected a number"),
        (float("inf"), "symmetric tolerance must be a number >= 0"),
        (True, "expected a number"),
        ([0.1], "expected a number"),
    ],
)
def test_parse_band_refuses(value, match):
    with pytest.raises(SpecError, match=match):
        parse_band(value)


# --- nominal specs from separate values ----------------------------------------------------------


@pytest.mark.parametrize(
    "values, match",
    [
        ({"tolerance": 0.1}, "tolerance needs diameter"),
        ({"diameter": 3.0}, "diameter needs tolerance"),
        ({"center": (0, 0, 0), "diameter": 3.0}, "diameter needs tolerance"),
        ({"position_tolerance": 0.1}, "position_tolerance needs center"),
        ({"max_tilt": 1.0}, "max_tilt needs normal"),
        ({"center": (0, 0, 0)}, "give a tolerance"),
        ({"normal": (0, 0, 1)}, "give a tolerance"),
        ({"diameter": -3.0, "tolerance": 0.1}, "diameter must be a number > 0, got -3.0"),
        ({"diameter": 3.0, "tolerance": "x"}, "tolerance: expected a number"),
        ({"center": (0, 0), "position_tolerance": 0.1}, r"center must be 3 finite numbers"),
        ({"center": (0, 0, float("nan")), "position_tolerance": 0.1}, r"center must be 3 finite numbers"),
        ({"center": (0, 0, 0), "position_tolerance": -0.1}, "position_tolerance must be a number >= 0"),
        ({"normal": (0, 0, 0), "max_tilt": 1.0}, "normal must not be the zero vector"),
        ({"normal": (0, 0, 1), "max_tilt": 91.0}, "max_tilt must be an angle in degrees from 0 to 90"),
    ],
)
def test_nominal_spec_refuses(values, match):
    with pytest.raises(SpecError, match=match):
        nominal_spec(**values)


def test_nominal_spec_messages_use_the_given_names():
    with pytest.raises(SpecError, match="--tolerance needs --nominal-diameter"):
        nominal_spec(tolerance=0.1, names={"tolerance": "--tolerance", "diameter": "--nominal-diameter"})


def test_nominal_spec_values():
    spec = nominal_spec(diameter=3, tolerance="+0.036/-0", center=(1, 2, 3), position_tolerance=0.2,
                        normal=(0, 0, 2), max_tilt=1)
    (hole,) = spec.holes
    assert not spec.named
    assert hole.name is None
    assert (hole.diameter, hole.band, hole.center) == (3.0, Band(0.0, 0.036), (1.0, 2.0, 3.0))
    assert (hole.position_tolerance, hole.normal, hole.max_tilt) == (0.2, (0.0, 0.0, 2.0), 1.0)
    assert hole.match_radius == math.inf  # the command line's nominal takes the nearest hole


# --- spec files ------------------------------------------------------------------------------------


def test_parse_spec():
    spec = parse_spec(SPEC_TEXT, source="bracket.toml")
    assert spec.named and spec.source == "bracket.toml"
    first, second = spec.holes
    assert first.name == "A1" and first.band == Band(0.0, 0.036) and first.max_tilt == 1.0
    assert first.match_radius == 3.0
    assert second.name == "A2" and second.center == (10.0, 0.0, 0.0) and second.diameter == 4.0
    assert second.band == Band(-0.05, 0.05)
    assert second.position_tolerance is None and second.normal is None


def _spec_with(**changes):
    lines = ['[[hole]]', 'name = "A1"', 'center = [0, 0, 0]', 'diameter = 3.0', 'tolerance = 0.05']
    table = {line.split(" = ")[0]: line for line in lines[1:]}
    for key, value in changes.items():
        if value is None:
            table.pop(key, None)
        else:
            table[key] = f"{key} = {value}"
    return "\n".join([lines[0], *table.values()]) + "\n"


@pytest.mark.parametrize(
    "text, match",
    [
        ("[[hole]\nname = 1", "invalid TOML"),
        ("", r"expected at least one \[\[hole\]\] table"),
        ("hole = 3", r"expected at least one \[\[hole\]\] table"),
        ('part = "x"\n' + _spec_with(), "unknown top-level key 'part'"),
        (_spec_with(postion_tolerance="0.1"), "hole 1 \\('A1'\\): unknown key 'postion_tolerance'"),
        (_spec_with(tolerance=None), "hole 1 \\('A1'\\): missing key 'tolerance'"),
        (_spec_with(center=None), "missing key 'center'"),
        (_spec_with(name=None), "hole 1: missing key 'name'"),
        (_spec_with(name='""'), "'name' must be a non-empty string"),
        (_spec_with(name="7"), "'name' must be a non-empty string, got 7"),
        (_spec_with(tolerance="-0.05"), "tolerance: a symmetric tolerance must be a number >= 0, got -0.05"),
        (_spec_with(tolerance='"0.1/0.1"'), "with its sign"),
        (_spec_with(diameter="0"), "diameter must be a number > 0, got 0"),
        (_spec_with(diameter='"3"'), "diameter must be a number > 0, got '3'"),
        (_spec_with(diameter="true"), "diameter must be a number > 0, got True"),
        (_spec_with(center="[0, 0]"), r"center must be 3 finite numbers \[x, y, z\], got \[0, 0\]"),
        (_spec_with(center="[0, 0, nan]"), "center must be 3 finite numbers"),
        (_spec_with(position_tolerance="-1"), "position_tolerance must be a number >= 0"),
        (_spec_with(max_tilt="1"), "max_tilt needs normal"),
        (_spec_with(normal="[0, 0, 0]", max_tilt="1"), "normal must not be the zero vector"),
        (_spec_with() + _spec_with(), "hole 2 \\('A1'\\): the name 'A1' is used twice"),
        # strict where a shop floor needs it (issue 8, item 16)
        (_spec_with(tolerance='"1_0"'), "expected a number"),
        (_spec_with(tolerance='"٣"'), "expected a number"),
        (_spec_with(tolerance='"+0.0_36/-0"'), "expected a number"),
        (_spec_with(tolerance='"0x1p-4"'), "expected a number"),
        (_spec_with(tolerance='"infinity"'), "expected a number"),
        (_spec_with(name='"A1 "'), "must not start or end with spaces"),
        (_spec_with(name='" A1"'), "must not start or end with spaces"),
        (_spec_with(name='"A1\\n"'), "must not start or end with spaces or hold control characters"),
        (_spec_with(name='"A\\u00001"'), "control characters"),
        ("a = " + "[" * 5000 + "]" * 5000, "nested too deeply"),
    ],
)
def test_parse_spec_refuses(text, match):
    with pytest.raises(SpecError, match=match):
        parse_spec(text)


@pytest.mark.parametrize("text, expected", [
    ('"0.05"', Band(-0.05, 0.05)), ('"±0.05"', Band(-0.05, 0.05)), ('"± 0.05"', Band(-0.05, 0.05)),
    ('" +0.036 / -0 "', Band(0.0, 0.036)), ('"+3.6e-2/-0"', Band(0.0, 0.036)), ('".05"', Band(-0.05, 0.05)),
])
def test_parse_spec_takes_plain_decimals_with_spaces_around_them(text, expected):
    (hole,) = parse_spec(_spec_with(tolerance=text)).holes
    assert hole.band == expected


# --- verdicts: the diameter ----------------------------------------------------------------------


@pytest.mark.parametrize(
    "diameter, tolerance, expected",
    [
        (3.020, "+0.036/-0", True),
        (3.036, "+0.036/-0", True),  # on the upper limit: in (within round-off)
        (3.000, "+0.036/-0", True),  # on the lower limit
        (2.999, "+0.036/-0", False),
        (3.037, "+0.036/-0", False),
        (2.990, 0.01, True),
        (2.989, 0.01, False),
        (2.980, "-0.014/-0.035", True),
        (2.990, "-0.014/-0.035", False),
    ],
)
def test_diameter_verdict(diameter, tolerance, expected):
    out = check(_record(_hole(0, (0, 0, 0), diameter)), nominal_spec(diameter=3.0, tolerance=tolerance))
    hole = out["holes"][0]
    assert hole["diameter_deviation"] == pytest.approx(diameter - 3.0, abs=1e-15)
    assert hole["in_tolerance"] is expected
    assert hole["failed_checks"] == ([] if expected else ["diameter"])
    assert hole["position_deviation"] is None and hole["tilt_deg"] is None
    assert "name" not in hole
    assert out["verdict"] == {"checked": 1, "out_of_tolerance": 0 if expected else 1, "missing": [],
                              "in_tolerance": expected, **SIMPLE_VERDICT}


def test_without_a_center_every_hole_is_checked():
    record = _record(_hole(0, (0, 0, 0), 3.01), _hole(1, (9, 0, 0), 3.2), _hole(2, (-9, 0, 0), 2.99))
    out = check(record, nominal_spec(diameter=3.0, tolerance=0.02))
    assert [hole["in_tolerance"] for hole in out["holes"]] == [True, False, True]
    assert out["verdict"] == {"checked": 3, "out_of_tolerance": 1, "missing": [], "in_tolerance": False,
                              **SIMPLE_VERDICT}


def test_no_hole_at_all_means_the_nominal_is_missing():
    out = check(_record(), nominal_spec(diameter=3.0, tolerance=0.02))
    assert out["holes"] == []
    assert out["verdict"] == {"checked": 0, "out_of_tolerance": 0, "missing": [None], "in_tolerance": False,
                              **SIMPLE_VERDICT}


def test_check_keeps_the_record_and_adds_the_verdict_after_the_holes():
    record = _record(_hole(0, (0, 0, 0), 3.0))
    before = copy.deepcopy(record)
    out = check(record, nominal_spec(diameter=3.0, tolerance=0.02))
    assert record == before  # not modified
    assert list(out) == ["file", "points", "method", "holes", "verdict", "timing"]
    for key in record["holes"][0]:
        assert out["holes"][0][key] == record["holes"][0][key]
    assert list(out["holes"][0])[-12:] == ["diameter_deviation", "position_deviation", "tilt_deg",
                                           "countersink_diameter_deviation", "countersink_angle_deviation",
                                           "countersink_depth_deviation", "bore_diameter_deviation",
                                           "countersink_gauge_deviation", "in_tolerance",
                                           "failed_checks", "undecided_checks", "conformance"]


# --- verdicts: position and tilt ---------------------------------------------------------------------


def test_position_deviation_in_the_plane_and_along_the_normal():
    # Hole normal tilted about x by 30 degrees; the center 0.03 off in the plane, 0.02 along the normal.
    normal = np.array([0.0, -np.sin(np.radians(30)), np.cos(np.radians(30))])
    in_plane_direction = np.array([1.0, 0.0, 0.0])
    nominal = np.array([5.0, 6.0, 7.0])
    center = nominal + 0.03 * in_plane_direction + 0.02 * normal
    spec = nominal_spec(center=tuple(nominal), position_tolerance=0.05)
    out = check(_record(_hole(0, center, 3.0, normal)), spec)
    hole = out["holes"][0]
    assert hole["position_deviation"]["in_plane"] == pytest.approx(0.03, abs=1e-12)
    assert hole["position_deviation"]["along_normal"] == pytest.approx(0.02, abs=1e-12)
    assert hole["diameter_deviation"] is None
    assert hole["in_tolerance"] is True
    out = check(_record(_hole(0, center, 3.0, -normal)), spec)
    assert out["holes"][0]["position_deviation"]["along_normal"] == pytest.approx(-0.02, abs=1e-12)
    tight = nominal_spec(center=tuple(nominal), position_tolerance=0.029)
    hole = check(_record(_hole(0, center, 3.0, normal)), tight)["holes"][0]
    assert hole["in_tolerance"] is False and hole["failed_checks"] == ["position"]


def test_the_nominal_center_picks_the_nearest_hole_and_leaves_the_others_unchecked():
    record = _record(_hole(0, (0, 0, 0), 3.5), _hole(1, (10.02, 0, 0), 3.01), _hole(2, (20, 0, 0), 2.0))
    out = check(record, nominal_spec(diameter=3.0, tolerance=0.02, center=(10, 0, 0), position_tolerance=0.05))
    first, second, third = out["holes"]
    assert second["in_tolerance"] is True
    assert second["position_deviation"]["in_plane"] == pytest.approx(0.02)
    assert first["in_tolerance"] is None and third["in_tolerance"] is None
    assert first["diameter_deviation"] is None and first["failed_checks"] is None
    assert out["verdict"] == {"checked": 1, "out_of_tolerance": 0, "missing": [], "in_tolerance": True,
                              **SIMPLE_VERDICT}


def test_the_nominal_center_of_the_command_line_has_no_match_radius():
    out = check(_record(_hole(0, (50, 0, 0), 3.0)), nominal_spec(center=(0, 0, 0), position_tolerance=0.1))
    hole = out["holes"][0]
    assert hole["position_deviation"]["in_plane"] == pytest.approx(50.0)
    assert hole["in_tolerance"] is False and hole["failed_checks"] == ["position"]


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_tilt_is_the_angle_between_the_lines(sign):
    angle = np.radians(0.7)
    normal = sign * np.array([np.sin(angle), 0.0, np.cos(angle)])
    spec = nominal_spec(normal=(0, 0, 5), max_tilt=1.0)
    hole = check(_record(_hole(0, (0, 0, 0), 3.0, normal)), spec)["holes"][0]
    assert hole["tilt_deg"] == pytest.approx(0.7, abs=1e-12)
    assert hole["in_tolerance"] is True
    hole = check(_record(_hole(0, (0, 0, 0), 3.0, normal)), nominal_spec(normal=(0, 0, -1), max_tilt=0.5))["holes"][0]
    assert hole["in_tolerance"] is False and hole["failed_checks"] == ["tilt"]


def test_tilt_is_accurate_near_zero():
    tiny = 1e-9
    hole = check(_record(_hole(0, (0, 0, 0), 3.0, (tiny, 0.0, 1.0))), nominal_spec(normal=(0, 0, 1), max_tilt=1))
    assert hole["holes"][0]["tilt_deg"] == pytest.approx(np.degrees(tiny), rel=1e-6)


def test_a_normal_without_max_tilt_only_reports_the_tilt():
    spec = nominal_spec(diameter=3.0, tolerance=0.1, normal=(0, 1, 0))
    hole = check(_record(_hole(0, (0, 0, 0), 3.0)), spec)["holes"][0]
    assert hole["tilt_deg"] == pytest.approx(90.0)
    assert hole["in_tolerance"] is True


def test_several_failed_checks_are_all_listed():
    spec = nominal_spec(diameter=3.0, tolerance=0.01, center=(0, 0, 0), position_tolerance=0.01, normal=(1, 0, 0),
                        max_tilt=5)
    hole = check(_record(_hole(0, (0.5, 0, 0), 3.1)), spec)["holes"][0]
    assert hole["failed_checks"] == ["diameter", "position", "tilt"]


def test_verdicts_are_invariant_under_a_rigid_motion(rng):
    rotation = synth.random_rotation(rng)
    shift = rng.normal(scale=100.0, size=3)
    nominal_center, nominal_normal = np.array([1.0, 2.0, 3.0]), np.array([0.0, 0.1, 1.0])
    center, normal = nominal_center + [0.02, -0.01, 0.005], np.array([0.01, 0.08, 1.0])
    normal /= np.linalg.norm(normal)

    def verdict(transform, turn):
        spec = nominal_spec(diameter=3.0, tolerance=0.05, center=tuple(transform(nominal_center)),
                            position_tolerance=0.03, normal=tuple(turn(nominal_normal)), max_tilt=2.0)
        return check(_record(_hole(0, transform(center), 3.01, turn(normal))), spec)["holes"][0]

    plain = verdict(lambda p: p, lambda v: v)
    moved = verdict(lambda p: rotation @ p + shift, lambda v: rotation @ v)
    for key in ("in_plane", "along_normal"):
        assert moved["position_deviation"][key] == pytest.approx(plain["position_deviation"][key], abs=1e-9)
    assert moved["tilt_deg"] == pytest.approx(plain["tilt_deg"], abs=1e-7)
    assert moved["in_tolerance"] == plain["in_tolerance"] is True


# --- verdicts: spec files and matching ---------------------------------------------------------------


def test_spec_matching_names_missing_and_extra_holes():
    spec = parse_spec(SPEC_TEXT)
    record = _record(_hole(0, (0.02, 0.0, 0.0), 3.01), _hole(1, (30.0, 0.0, 0.0), 4.0))
    out = check(record, spec)
    matched, extra = out["holes"]
    assert matched["name"] == "A1" and matched["in_tolerance"] is True
    assert matched["diameter_deviation"] == pytest.approx(0.01)
    assert matched["position_deviation"]["in_plane"] == pytest.approx(0.02)
    assert matched["tilt_deg"] == pytest.approx(0.0)
    # a measured hole without a nominal one is reported, not checked, and does not fail the verdict
    assert extra["name"] is None and extra["in_tolerance"] is None
    assert extra["diameter_deviation"] is None and extra["position_deviation"] is None
    assert out["verdict"] == {"checked": 1, "out_of_tolerance": 0, "missing": ["A2"], "in_tolerance": False,
                              **SIMPLE_VERDICT}


def test_spec_all_matched_and_in_tolerance():
    record = _record(_hole(0, (10.1, 0.0, 0.0), 4.03), _hole(1, (0.0, 0.05, 0.0), 3.03))
    out = check(record, parse_spec(SPEC_TEXT))
    assert [hole["name"] for hole in out["holes"]] == ["A2", "A1"]
    assert out["verdict"] == {"checked": 2, "out_of_tolerance": 0, "missing": [], "in_tolerance": True,
                              **SIMPLE_VERDICT}


def test_spec_match_radius_is_the_nominal_diameter():
    record = _record(_hole(0, (3.01, 0.0, 0.0), 3.0))  # just beyond A1's 3 mm
    out = check(record, parse_spec(SPEC_TEXT))
    assert out["holes"][0]["name"] is None
    assert out["verdict"]["missing"] == ["A1", "A2"]


def test_spec_matching_is_one_to_one_and_greedy_by_distance():
    text = "\n".join(f'[[hole]]\nname = "{name}"\ncenter = [{x}, 0, 0]\ndiameter = 3\ntolerance = 0.1\n'
                     for name, x in (("left", 0.0), ("right", 2.0)))
    spec = parse_spec(text)
    # One measured hole between both, nearer to "right": "right" takes it and "left" is missing.
    out = check(_record(_hole(0, (1.2, 0, 0), 3.0)), spec)
    assert out["holes"][0]["name"] == "right"
    assert out["verdict"]["missing"] == ["left"]
    # Two measured holes: the closest pair first, then the next, each hole once.
    out = check(_record(_hole(0, (1.1, 0, 0), 3.0), _hole(1, (1.9, 0, 0), 3.0)), spec)
    assert [hole["name"] for hole in out["holes"]] == ["left", "right"]
    assert out["verdict"]["missing"] == []


# --- verdicts: countersink, bore and perpendicularity (issue 12) ------------------------------------


def _countersunk(index=0, center=(0, 0, 0), diameter=7.0, angle=100.0, depth=1.26, bore=4.0,
                 perpendicularity=0.02):
    hole = _hole(index, center, diameter)
    hole.update(type="countersunk", perpendicularity_deg=perpendicularity,
                countersink={"diameter": diameter, "angle_deg": angle, "depth": depth, "depth_from": "bore",
                             "diameter_at_depth": None, "gauge_depth": None, "rms": 0.001, "points": 600,
                             "arc_deg": 360.0},
                counterbore=None,
                bore={"diameter": bore, "rms": 0.001, "points": 300, "depth_range": [1.3, 3.0], "arc_deg": 360.0,
                      "floor_depth": None})
    return hole


def _through(index=0, center=(0, 0, 0), diameter=4.0):
    """A through hole whose bore wall is not seen and whose axis is not measured: only the edge."""
    hole = _hole(index, center, diameter)
    hole.update(type="through", countersink=None, counterbore=None, perpendicularity_deg=None, axis=None,
                bore={"diameter": None, "rms": None, "points": 0, "depth_range": None, "arc_deg": None,
                      "floor_depth": None})
    return hole


FEATURE_CASES = [
    # check, measured (keyword of _countersunk), nominal, tolerance, expected
    ("countersink_diameter", "diameter", 7.0, "+0.1/-0", True),
    ("countersink_diameter", "diameter", 7.1, "+0.1/-0", True),  # on the upper limit
    ("countersink_diameter", "diameter", 7.1001, "+0.1/-0", False),
    ("countersink_diameter", "diameter", 6.9999, "+0.1/-0", False),  # below the lower limit 0
    ("countersink_angle", "angle", 100.8, 1, True),  # 100 +- 1
    ("countersink_angle", "angle", 101.2, "+/-1", False),
    ("countersink_angle", "angle", 98.9, "±1", False),
    ("countersink_angle", "angle", 99.6, "+1/-0.5", True),
    ("countersink_angle", "angle", 99.4, "+1/-0.5", False),
    ("countersink_angle", "angle", 101.0, "+1/-0.5", True),  # on the upper limit
    ("countersink_depth", "depth", 1.3, 0.05, True),
    ("countersink_depth", "depth", 1.36, 0.05, False),
    ("countersink_depth", "depth", 1.24, 0.05, False),
    ("bore_diameter", "bore", 4.01, "+0.02/-0", True),
    ("bore_diameter", "bore", 4.03, "+0.02/-0", False),
    ("bore_diameter", "bore", 3.99, "+0.02/-0", False),
]


@pytest.mark.parametrize("name, measured_key, measured, tolerance, expected", FEATURE_CASES)
def test_feature_verdict(name, measured_key, measured, tolerance, expected):
    nominal = {"countersink_diameter": 7.0, "countersink_angle": 100.0, "countersink_depth": 1.3,
               "bore_diameter": 4.0}[name]
    spec = nominal_spec(**{name: nominal, f"{name}_tolerance": tolerance})
    out = check(_record(_countersunk(**{measured_key: measured})), spec)
    hole = out["holes"][0]
    assert hole[f"{name}_deviation"] == pytest.approx(measured - nominal, abs=1e-12)
    assert hole["in_tolerance"] is expected
    assert hole["failed_checks"] == ([] if expected else [name])
    others = {f"{other}_deviation" for other in ("countersink_diameter", "countersink_angle", "countersink_depth",
                                                 "bore_diameter")} - {f"{name}_deviation"}
    assert all(hole[key] is None for key in others) and hole["diameter_deviation"] is None
    assert out["verdict"]["in_tolerance"] is expected


@pytest.mark.parametrize("perpendicularity, expected", [(0.0, True), (0.5, True), (0.5000001, False), (3.0, False)])
def test_perpendicularity_verdict(perpendicularity, expected):
    out = check(_record(_countersunk(perpendicularity=perpendicularity)), nominal_spec(max_perpendicularity=0.5))
    hole = out["holes"][0]
    assert hole["in_tolerance"] is expected
    assert hole["failed_checks"] == ([] if expected else ["perpendicularity"])
    assert hole["perpendicularity_deg"] == perpendicularity  # the measured value, as it was


@pytest.mark.parametrize("values, failed", [
    ({"countersink_diameter": 7.0, "countersink_diameter_tolerance": 0.1}, "countersink_diameter_not_measured"),
    ({"countersink_angle": 100.0, "countersink_angle_tolerance": 1}, "countersink_angle_not_measured"),
    ({"countersink_depth": 1.3, "countersink_depth_tolerance": 0.1}, "countersink_depth_not_measured"),
    ({"bore_diameter": 4.0, "bore_diameter_tolerance": 0.1}, "bore_diameter_not_measured"),
    ({"max_perpendicularity": 1.0}, "perpendicularity_not_measured"),
])
@pytest.mark.parametrize("shape", ["through", "paper"])
def test_a_check_without_its_measured_value_is_not_measured_and_fails(values, failed, shape):
    # a through hole (no countersink, bore wall not seen, no axis), or a record of the paper method,
    # whose holes have neither countersink nor bore (null), or an older record without the keys at all
    hole = _through() if shape == "through" else dict(_hole(0, (0, 0, 0), 4.0), countersink=None, bore=None)
    out = check(_record(hole), nominal_spec(diameter=4.0, tolerance=0.1, **values))
    checked = out["holes"][0]
    assert checked["in_tolerance"] is False
    assert checked["failed_checks"] == [failed]  # the diameter itself is in tolerance
    assert all(checked[key] is None for key in checked if key.endswith("_deviation") and key != "diameter_deviation")
    assert out["verdict"] == {"checked": 1, "out_of_tolerance": 1, "missing": [], "in_tolerance": False,
                              **SIMPLE_VERDICT}
    bare = check(_record(_hole(0, (0, 0, 0), 4.0)), nominal_spec(diameter=4.0, tolerance=0.1, **values))
    assert bare["holes"][0]["failed_checks"] == [failed]


def test_every_check_at_once_lists_every_failure_in_order():
    spec = nominal_spec(diameter=7.0, tolerance=0.01, countersink_diameter=7.0, countersink_diameter_tolerance=0.01,
                        countersink_angle=90.0, countersink_angle_tolerance=1, countersink_depth=1.26,
                        countersink_depth_tolerance=0.01, bore_diameter=4.2, bore_diameter_tolerance=0.05,
                        max_perpendicularity=0.01)
    out = check(_record(_countersunk(diameter=7.005)), spec)
    hole = out["holes"][0]
    assert hole["failed_checks"] == ["countersink_angle", "bore_diameter", "perpendicularity"]
    assert hole["countersink_angle_deviation"] == pytest.approx(10.0)
    assert hole["bore_diameter_deviation"] == pytest.approx(-0.2)
    assert hole["countersink_diameter_deviation"] == pytest.approx(0.005)
    assert hole["countersink_depth_deviation"] == pytest.approx(0.0, abs=1e-12)


def test_feature_checks_are_json_ready():
    import json

    spec = nominal_spec(countersink_angle=100.0, countersink_angle_tolerance=1)
    out = check(_record(_countersunk(), _through(1, (10, 0, 0))), spec)
    assert json.loads(json.dumps(out, allow_nan=False)) == out


@pytest.mark.parametrize(
    "values, match",
    [
        ({"countersink_diameter": 7.0}, "countersink_diameter needs countersink_diameter_tolerance"),
        ({"countersink_angle_tolerance": 1}, "countersink_angle_tolerance needs countersink_angle"),
        ({"countersink_depth": 1.0}, "countersink_depth needs countersink_depth_tolerance"),
        ({"bore_diameter_tolerance": 0.1}, "bore_diameter_tolerance needs bore_diameter"),
        ({"countersink_diameter": 0.0, "countersink_diameter_tolerance": 0.1},
         "countersink_diameter must be a number > 0, got 0.0"),
        ({"countersink_angle": 180.0, "countersink_angle_tolerance": 1},
         "countersink_angle must be an angle in degrees between 0 and 180, got 180.0"),
        ({"countersink_angle": 0, "countersink_angle_tolerance": 1}, "countersink_angle must be an angle"),
        ({"countersink_angle": float("nan"), "countersink_angle_tolerance": 1}, "countersink_angle must be an angle"),
        ({"countersink_angle": "100 +/- 1", "countersink_angle_tolerance": 1},
         r"its tolerance goes in countersink_angle_tolerance\), got '100 \+/- 1'"),
        ({"countersink_angle": 100, "countersink_angle_tolerance": "-1"},
         "countersink_angle_tolerance: a symmetric tolerance must be a number >= 0"),
        ({"countersink_angle": 100, "countersink_angle_tolerance": "1/0.5"},
         "countersink_angle_tolerance: write the lower deviation of '1/0.5' with its sign"),
        ({"countersink_angle": 100, "countersink_angle_tolerance": "-0.5/+1"},
         r"countersink_angle_tolerance: .* did you mean \+1/-0.5"),
        ({"countersink_angle": 100, "countersink_angle_tolerance": "100 +/- 1"},
         "countersink_angle_tolerance: expected a number"),
        ({"countersink_depth": -1.0, "countersink_depth_tolerance": 0.1}, "countersink_depth must be a number > 0"),
        ({"bore_diameter": True, "bore_diameter_tolerance": 0.1}, "bore_diameter must be a number > 0, got True"),
        ({"max_perpendicularity": -0.1}, "max_perpendicularity must be an angle in degrees from 0 to 90"),
        ({"max_perpendicularity": 90.5}, "max_perpendicularity must be an angle in degrees from 0 to 90"),
        ({"center": (0, 0, 0)}, "give a tolerance: .*countersink_angle_tolerance.* or max_perpendicularity"),
    ],
)
def test_nominal_spec_refuses_bad_feature_values(values, match):
    with pytest.raises(SpecError, match=match):
        nominal_spec(**values)


def test_nominal_spec_feature_values():
    spec = nominal_spec(countersink_diameter=7, countersink_diameter_tolerance="+0.1/-0", countersink_angle=100,
                        countersink_angle_tolerance="+/- 1", countersink_depth=1.3, countersink_depth_tolerance=0.05,
                        bore_diameter=4, bore_diameter_tolerance=Band(-0.01, 0.02), max_perpendicularity=0.5)
    (hole,) = spec.holes
    assert (hole.countersink_diameter, hole.countersink_diameter_band) == (7.0, Band(0.0, 0.1))
    assert (hole.countersink_angle, hole.countersink_angle_band) == (100.0, Band(-1.0, 1.0))
    assert (hole.countersink_depth, hole.countersink_depth_band) == (1.3, Band(-0.05, 0.05))
    assert (hole.bore_diameter, hole.bore_diameter_band) == (4.0, Band(-0.01, 0.02))
    assert hole.max_perpendicularity == 0.5 and hole.diameter is None


COUNTERSUNK_SPEC = """
[[hole]]
name = "CS1"
center = [0, 0, 0]
diameter = 7.0
tolerance = "+0.1/-0"
countersink_diameter = 7.0
countersink_diameter_tolerance = "+0.1/-0"
countersink_angle = 100
countersink_angle_tolerance = "+/-1"      # 100 +- 1 degrees
countersink_depth = 1.26
countersink_depth_tolerance = 0.05
max_perpendicularity = 0.5

[[hole]]
name = "T1"
center = [10, 0, 0]
diameter = 4.0
tolerance = 0.05
bore_diameter = 4.0
bore_diameter_tolerance = "+0.02/-0"
"""


def test_parse_spec_feature_keys_and_their_verdicts():
    spec = parse_spec(COUNTERSUNK_SPEC)
    countersunk, through = spec.holes
    assert countersunk.countersink_angle == 100.0 and countersunk.countersink_angle_band == Band(-1.0, 1.0)
    assert countersunk.countersink_diameter_band == Band(0.0, 0.1) and countersunk.max_perpendicularity == 0.5
    assert countersunk.bore_diameter is None and through.bore_diameter_band == Band(0.0, 0.02)
    out = check(_record(_countersunk(angle=100.4), _through(1, (10, 0, 0))), spec)
    first, second = out["holes"]
    assert (first["name"], first["in_tolerance"], first["failed_checks"]) == ("CS1", True, [])
    assert first["countersink_angle_deviation"] == pytest.approx(0.4)
    assert (second["name"], second["in_tolerance"]) == ("T1", False)
    assert second["failed_checks"] == ["bore_diameter_not_measured"]
    assert out["verdict"] == {"checked": 2, "out_of_tolerance": 1, "missing": [], "in_tolerance": False,
                              **SIMPLE_VERDICT}


@pytest.mark.parametrize(
    "changes, match",
    [
        ({"countersink_angle": "100"}, "countersink_angle needs countersink_angle_tolerance"),
        ({"countersink_angle_tolerance": "1"}, "countersink_angle_tolerance needs countersink_angle"),
        ({"countersink_angle": '"100 +/- 1"', "countersink_angle_tolerance": "1"},
         r"hole 1 \('A1'\): countersink_angle must be an angle in degrees between 0 and 180 \(its tolerance goes in "
         r"countersink_angle_tolerance\), got '100 \+/- 1'"),
        ({"countersink_angle": "200", "countersink_angle_tolerance": "1"}, "between 0 and 180, got 200"),
        ({"countersink_angle": "100", "countersink_angle_tolerance": '"1/1"'},
         "countersink_angle_tolerance: write the lower deviation"),
        ({"countersink_diameter": "7", "countersink_diameter_tolerance": "[0.1]"},
         "countersink_diameter_tolerance: expected a number"),
        ({"bore_diameter": "0", "bore_diameter_tolerance": "0.1"}, "bore_diameter must be a number > 0"),
        ({"max_perpendicularity": "91"}, "max_perpendicularity must be an angle in degrees from 0 to 90"),
        ({"max_perpendicularity": '"0.5"'}, "max_perpendicularity must be an angle"),
        ({"countersink_angel": "100"}, "unknown key 'countersink_angel'"),
    ],
)
def test_parse_spec_refuses_bad_feature_keys(changes, match):
    with pytest.raises(SpecError, match=match):
        parse_spec(_spec_with(**changes))


# --- decision rules (ISO 14253-1) ----------------------------------------------------------------------


def _uncertain_hole(diameter, u_diameter=None, **uncertainty):
    hole = _hole(0, (0, 0, 0), diameter)
    hole["uncertainty"] = {"center_in_plane": None, "center_along_normal": None, "diameter": u_diameter,
                           "normal_deg": None, "countersink": None, "counterbore": None, "bore": None,
                           "axis_deg": None, "perpendicularity_deg": None, **uncertainty}
    return hole


def _h9(rule="guarded", coverage_factor=2.0):
    """3 +0.036/-0 (an H9 hole) under ``rule``."""
    return replace(nominal_spec(diameter=3.0, tolerance="+0.036/-0"), decision_rule=rule,
                   coverage_factor=coverage_factor)


@pytest.mark.parametrize(
    "diameter, u, decision, reason",
    [
        (3.018, 0.002, "pass", "inside_with_uncertainty"),  # 3.014 .. 3.022: inside [3, 3.036]
        (3.004, 0.002, "pass", "inside_with_uncertainty"),  # 3.000 .. 3.008: on the lower limit is inside
        (2.9969, 0.002, "undecided", "straddles_lower"),  # the README's H9 case: 2.9929 .. 3.0009
        (3.0031, 0.002, "undecided", "straddles_lower"),  # inside by value, not by value - U
        (3.0349, 0.002, "undecided", "straddles_upper"),
        (3.0371, 0.002, "undecided", "straddles_upper"),  # outside by value, not by value - U
        (2.9950, 0.002, "fail", "outside_with_uncertainty"),  # 2.991 .. 2.999: wholly below
        (3.0410, 0.002, "fail", "outside_with_uncertainty"),  # 3.037 .. 3.045: wholly above
        (3.018, 0.02, "undecided", "straddles_both"),  # U wider than the zone
    ],
)
def test_guarded_decides_by_the_value_and_its_expanded_uncertainty(diameter, u, decision, reason):
    out = check(_record(_uncertain_hole(diameter, u)), _h9())
    hole = out["holes"][0]
    entry = hole["conformance"]["diameter"]
    assert entry == {"value": pytest.approx(diameter - 3.0, abs=1e-12), "lower": 0.0, "upper": 0.036,
                     "expanded_uncertainty": pytest.approx(2 * u), "decision": decision, "reason": reason}
    assert hole["failed_checks"] == (["diameter"] if decision == "fail" else [])
    assert hole["undecided_checks"] == (["diameter"] if decision == "undecided" else [])
    assert hole["in_tolerance"] is (decision == "pass")
    verdict = out["verdict"]
    assert (verdict["out_of_tolerance"], verdict["undecided"]) == (decision == "fail", decision == "undecided")
    assert verdict["in_tolerance"] is (decision == "pass")
    assert (verdict["decision_rule"], verdict["coverage_factor"]) == ("guarded", 2.0)


@pytest.mark.parametrize("diameter, expected", [(2.9969, "fail"), (3.0031, "pass"), (3.0371, "fail"), (3.018, "pass")])
def test_simple_decides_by_the_value_alone_and_reports_u(diameter, expected):
    simple = check(_record(_uncertain_hole(diameter, 0.002)), _h9("simple"))
    hole = simple["holes"][0]
    assert hole["conformance"]["diameter"]["decision"] == expected
    assert hole["conformance"]["diameter"]["expanded_uncertainty"] == pytest.approx(0.004)
    assert hole["undecided_checks"] == [] and simple["verdict"]["undecided"] == 0
    # the same verdict as without any uncertainty (today's behaviour)
    plain = check(_record(_hole(0, (0, 0, 0), diameter)), nominal_spec(diameter=3.0, tolerance="+0.036/-0"))
    for key in ("in_tolerance", "failed_checks", "diameter_deviation"):
        assert plain["holes"][0][key] == hole[key]
    assert plain["verdict"] == simple["verdict"]
    assert plain["holes"][0]["conformance"]["diameter"]["expanded_uncertainty"] is None


@pytest.mark.parametrize("uncertainty", [None, {}, {"diameter": None}])
def test_guarded_without_u_is_undecided_even_far_inside(uncertainty):
    hole = dict(_hole(0, (0, 0, 0), 3.018), uncertainty=uncertainty)
    out = check(_record(hole), _h9())
    entry = out["holes"][0]["conformance"]["diameter"]
    assert entry["decision"] == "undecided" and entry["reason"] == "uncertainty_unknown"
    assert entry["expanded_uncertainty"] is None
    assert out["holes"][0]["undecided_checks"] == ["diameter"] and out["verdict"]["undecided"] == 1


def test_guarded_without_an_uncertainty_key_at_all_is_undecided():
    out = check(_record(_hole(0, (0, 0, 0), 3.018)), _h9())
    assert out["holes"][0]["conformance"]["diameter"]["reason"] == "uncertainty_unknown"


@pytest.mark.parametrize("rule", ["simple", "guarded"])
def test_a_check_not_measured_fails_under_either_rule(rule):
    hole = _uncertain_hole(3.018, 0.001, bore={"diameter": 0.001, "floor_depth": None})
    spec = replace(nominal_spec(bore_diameter=4.0, bore_diameter_tolerance=0.02), decision_rule=rule)
    out = check(_record(hole), spec)
    assert out["holes"][0]["failed_checks"] == ["bore_diameter_not_measured"]
    entry = out["holes"][0]["conformance"]["bore_diameter"]
    assert (entry["value"], entry["decision"], entry["reason"]) == (None, "fail", "not_measured")


@pytest.mark.parametrize("coverage_factor, decision", [(1.0, "pass"), (3.0, "undecided")])
def test_the_coverage_factor_scales_u(coverage_factor, decision):
    # 3.0025 with u = 0.001: 3.0015 .. 3.0035 at k = 1, 2.9995 .. 3.0055 at k = 3
    out = check(_record(_uncertain_hole(3.0025, 0.001)), _h9(coverage_factor=coverage_factor))
    entry = out["holes"][0]["conformance"]["diameter"]
    assert entry["expanded_uncertainty"] == pytest.approx(coverage_factor * 0.001)
    assert entry["decision"] == decision
    assert out["verdict"]["coverage_factor"] == coverage_factor


@pytest.mark.parametrize(
    "in_plane, u, decision",
    [(0.05, 0.01, "pass"), (0.09, 0.01, "undecided"), (0.11, 0.01, "undecided"), (0.13, 0.01, "fail"),
     (0.099, 0.0, "pass")],
)
def test_guarded_position_is_one_sided(in_plane, u, decision):
    hole = _uncertain_hole(3.0, center_in_plane=u)
    hole["center"] = [in_plane, 0.0, 0.0]
    out = check(_record(hole), replace(nominal_spec(center=(0, 0, 0), position_tolerance=0.1), decision_rule="guarded"))
    entry = out["holes"][0]["conformance"]["position"]
    assert entry["lower"] is None and entry["upper"] == 0.1
    assert entry["value"] == pytest.approx(in_plane) and entry["decision"] == decision
    assert entry["expanded_uncertainty"] == pytest.approx(2 * u)


@pytest.mark.parametrize(
    "nominal, hole_changes, uncertainty, check_name, value",
    [
        ({"normal": (0, 0, 1), "max_tilt": 1.0},
         {"normal": [0.0, math.sin(math.radians(0.9)), math.cos(math.radians(0.9))]},
         {"normal_deg": 0.1}, "tilt", 0.9),
        ({"max_perpendicularity": 0.5}, {"perpendicularity_deg": 0.45}, {"perpendicularity_deg": 0.05},
         "perpendicularity", 0.45),
        ({"countersink_angle": 100.0, "countersink_angle_tolerance": 1.0}, {"countersink": {"angle_deg": 100.9}},
         {"countersink": {"diameter": None, "angle_deg": 0.1, "depth": None, "diameter_at_depth": None}},
         "countersink_angle", 0.9),
        ({"countersink_diameter": 7.0, "countersink_diameter_tolerance": "+0.1/-0"},
         {"countersink": {"diameter": 7.09}},
         {"countersink": {"diameter": 0.01, "angle_deg": None, "depth": None, "diameter_at_depth": None}},
         "countersink_diameter", 0.09),
        ({"countersink_depth": 1.2, "countersink_depth_tolerance": 0.05}, {"countersink": {"depth": 1.24}},
         {"countersink": {"diameter": None, "angle_deg": None, "depth": 0.01, "diameter_at_depth": None}},
         "countersink_depth", 0.04),
        ({"bore_diameter": 4.0, "bore_diameter_tolerance": 0.02}, {"bore": {"diameter": 4.015}},
         {"bore": {"diameter": 0.005, "floor_depth": None}}, "bore_diameter", 0.015),
    ],
)
def test_every_check_takes_its_own_uncertainty(nominal, hole_changes, uncertainty, check_name, value):
    # each value is inside its zone by the value alone, and value + 2u straddles the upper limit
    hole = dict(_uncertain_hole(3.0, **uncertainty), **hole_changes)
    simple = check(_record(hole), nominal_spec(**nominal))
    guarded = check(_record(hole), replace(nominal_spec(**nominal), decision_rule="guarded"))
    assert simple["holes"][0]["conformance"][check_name]["decision"] == "pass"
    entry = guarded["holes"][0]["conformance"][check_name]
    assert entry["value"] == pytest.approx(value)
    u = uncertainty[next(iter(uncertainty))]
    u = u if not isinstance(u, dict) else next(v for v in u.values() if v is not None)
    assert entry["expanded_uncertainty"] == pytest.approx(2 * u)
    assert (entry["decision"], entry["reason"]) == ("undecided", "straddles_upper")
    assert guarded["holes"][0]["undecided_checks"] == [check_name]


def test_a_fail_and_an_undecided_check_count_the_hole_out_of_tolerance():
    hole = _uncertain_hole(3.05, 0.001, center_in_plane=0.01)
    hole["center"] = [0.095, 0.0, 0.0]
    spec = replace(nominal_spec(diameter=3.0, tolerance="+0.036/-0", center=(0, 0, 0), position_tolerance=0.1),
                   decision_rule="guarded")
    out = check(_record(hole), spec)
    assert out["holes"][0]["failed_checks"] == ["diameter"] and out["holes"][0]["undecided_checks"] == ["position"]
    assert out["verdict"] == {"checked": 1, "out_of_tolerance": 1, "undecided": 0, "missing": [], "in_tolerance": False,
                              "decision_rule": "guarded", "coverage_factor": 2.0}


def test_an_unchecked_hole_has_no_conformance():
    out = check(_record(_hole(0, (0, 0, 0), 3.0), _hole(1, (9, 0, 0), 3.0)),
                replace(nominal_spec(diameter=3.0, tolerance=0.01, center=(0, 0, 0)), decision_rule="guarded"))
    assert out["holes"][1]["conformance"] is None and out["holes"][1]["undecided_checks"] is None


@pytest.mark.parametrize(
    "changes, match",
    [
        ({"decision_rule": "strict"}, "decision_rule must be one of simple, guarded, got 'strict'"),
        ({"coverage_factor": 0}, "coverage_factor must be a finite number > 0, got 0"),
        ({"coverage_factor": -1.0}, "coverage_factor must be a finite number > 0"),
        ({"coverage_factor": math.nan}, "coverage_factor must be a finite number > 0, got nan"),
        ({"coverage_factor": math.inf}, "coverage_factor must be a finite number > 0, got inf"),
        ({"coverage_factor": True}, "coverage_factor must be a finite number > 0, got True"),
        ({"coverage_factor": "2"}, "coverage_factor must be a finite number > 0, got '2'"),
    ],
)
def test_the_decision_rule_and_coverage_factor_are_validated(changes, match):
    with pytest.raises(SpecError, match=match):
        replace(nominal_spec(diameter=3.0, tolerance=0.01), **changes)


@pytest.mark.parametrize("u", [-0.001, math.nan, "0.001"])
def test_an_invalid_uncertainty_is_refused(u):
    with pytest.raises(ValueError, match=r"hole 0: uncertainty.diameter must be a finite number >= 0"):
        check(_record(_uncertain_hole(3.0, u)), _h9())


def test_describe_records_the_decision_rule():
    spec = _h9(coverage_factor=3)
    described = describe(spec)
    assert described["decision_rule"] == "guarded" and described["coverage_factor"] == 3.0
    named = describe(replace(parse_spec(SPEC_TEXT), decision_rule="guarded"))
    assert (named["decision_rule"], named["coverage_factor"]) == ("guarded", 2.0)
    assert describe(nominal_spec(diameter=3.0, tolerance=0.01))["decision_rule"] == "simple"
    record = dict(_record(_uncertain_hole(3.0, 0.001)), options={"method": "robust"})
    assert check(record, spec)["options"]["tolerances"] == described


def test_conformance_is_json_ready():
    import json

    out = check(_record(_uncertain_hole(3.0031, 0.002)), _h9())
    assert json.loads(json.dumps(out, allow_nan=False)) == out


# --- issue 23: numbers and bytes of spec files that gave tracebacks or wrong messages ------------------

_SPEC = 'name = "A"\ndiameter = {diameter}\ntolerance = 0.1\ncenter = [0, 0, 0]\nposition_tolerance = 1\n'


def test_a_spec_with_a_utf8_byte_order_mark_is_read():
    text = "[[hole]]\n" + _SPEC.format(diameter=2)
    assert parse_spec("\ufeff" + text) == parse_spec(text)


@pytest.mark.parametrize("diameter, match", [
    ("2" + "0" * 400, r"^hole\[1\]\.diameter: an integer of 401 digits is too large for a number$"),
    ("-1" + "0" * 400, r"^hole\[1\]\.diameter: an integer of 401 digits is too large for a number$"),
    ("2" + "0" * 5000, r"^invalid TOML: a number of more than 4300 digits$"),
])
def test_a_spec_integer_no_float_holds_is_refused_in_one_line(diameter, match):
    with pytest.raises(SpecError, match=match):
        parse_spec("[[hole]]\n" + _SPEC.format(diameter=diameter))


def test_a_huge_integer_in_a_vector_or_a_tolerance_is_refused():
    for key in ("center = [0, 1" + "0" * 400 + ", 0]", "tolerance = 1" + "0" * 400):
        text = "[[hole]]\n" + "\n".join(line for line in _SPEC.format(diameter=2).splitlines()
                                         if line.split(" =")[0] != key.split(" =")[0]) + "\n" + key + "\n"
        with pytest.raises(SpecError, match="an integer of 401 digits is too large for a number"):
            parse_spec(text)


def test_nominal_values_given_in_python_as_huge_integers_are_refused():
    with pytest.raises(SpecError, match="an integer of 401 digits"):
        nominal_spec(diameter=10 ** 400, tolerance=0.1)
    with pytest.raises(SpecError, match="an integer of 5001 digits"):
        nominal_spec(diameter=10 ** 5000, tolerance=0.1)


def test_a_normal_whose_length_overflows_is_the_direction_it_gives():
    # its length overflows: it was normalised to (0, 0, 0), and every tilt was 0
    record = _record(_hole(0, (0.0, 0.0, 0.0), 2.5, normal=(0.0, 0.0, 1.0)))
    huge = nominal_spec(diameter=2.5, tolerance=0.1, center=(0, 0, 0), position_tolerance=1,
                        normal=(1.7e308, 1.7e308, 0), max_tilt=5)
    plain = nominal_spec(diameter=2.5, tolerance=0.1, center=(0, 0, 0), position_tolerance=1,
                         normal=(1, 1, 0), max_tilt=5)
    tilt = check(record, plain)["holes"][0]["tilt_deg"]
    assert tilt == pytest.approx(90.0)
    assert check(record, huge)["holes"][0]["tilt_deg"] == pytest.approx(tilt)


# --- issue 25: a U wider than the tolerance zone -------------------------------------------------------


def test_guarded_notes_a_check_whose_u_exceeds_its_zone():
    import dataclasses

    from holecli.tolerance import UNCERTAINTY_NOTE, check, nominal_spec, uncertainty_exceeds_zone

    hole = {"index": 0, "center": [0.0, 0.0, 0.0], "diameter": 3.001, "normal": [0.0, 0.0, 1.0], "notes": [],
            "uncertainty": {"center_in_plane": 0.001, "center_along_normal": 0.001, "diameter": 0.004,
                            "normal_deg": 0.01}}
    record = {"holes": [hole]}
    tight = dataclasses.replace(nominal_spec(diameter=3.0, tolerance=0.005), decision_rule="guarded")  # 2U 0.016
    (checked,) = check(record, tight)["holes"]
    assert [note["code"] for note in checked["notes"]] == [UNCERTAINTY_NOTE]
    assert checked["notes"][0]["message"].startswith("diameter: 2U = 0.016 is wider than its tolerance zone 0.01")
    assert hole["notes"] == []  # the record given is not changed
    wide = dataclasses.replace(nominal_spec(diameter=3.0, tolerance=0.05), decision_rule="guarded")
    assert check(record, wide)["holes"][0]["notes"] == []
    simple = nominal_spec(diameter=3.0, tolerance=0.005)
    assert check(record, simple)["holes"][0]["notes"] == []
    assert uncertainty_exceeds_zone({"lower": None, "upper": 0.1, "expanded_uncertainty": 0.11})
    assert not uncertainty_exceeds_zone({"lower": 0.0, "upper": 0.1, "expanded_uncertainty": None})


# --- verdicts: the countersink gauge (issue 25, item 8) ------------------------------------------------


def _gauged(at_depth, gauge_depth=0.5, u=0.001):
    hole = _countersunk()
    hole["countersink"] = dict(hole["countersink"], diameter_at_depth=at_depth, gauge_depth=gauge_depth)
    hole["uncertainty"] = {"countersink": {"diameter_at_depth": u}}
    return hole


@pytest.mark.parametrize("at_depth, tolerance, expected", [
    (5.81, 0.05, True), (5.85, 0.05, True),  # on the upper limit
    (5.8501, 0.05, False), (5.7499, 0.05, False), (5.80, "+0.1/-0", True), (5.7999, "+0.1/-0", False),
])
def test_countersink_gauge_verdict(at_depth, tolerance, expected):
    spec = nominal_spec(countersink_gauge_diameter=5.8, countersink_gauge_tolerance=tolerance)
    hole = check(_record(_gauged(at_depth)), spec)["holes"][0]
    assert hole["countersink_gauge_deviation"] == pytest.approx(at_depth - 5.8, abs=1e-12)
    assert hole["in_tolerance"] is expected
    assert hole["failed_checks"] == ([] if expected else ["countersink_gauge"])
    entry = hole["conformance"]["countersink_gauge"]
    assert entry["expanded_uncertainty"] == pytest.approx(0.002)  # k = 2 times u of diameter_at_depth
    assert (entry["lower"], entry["upper"]) == (parse_band(tolerance).lower, parse_band(tolerance).upper)


def test_countersink_gauge_guarded_straddling_is_undecided():
    spec = replace(nominal_spec(countersink_gauge_diameter=5.8, countersink_gauge_tolerance=0.05),
                   decision_rule="guarded")
    hole = check(_record(_gauged(5.849, u=0.001)), spec)["holes"][0]
    assert hole["undecided_checks"] == ["countersink_gauge"]
    assert hole["conformance"]["countersink_gauge"]["reason"] == "straddles_upper"


@pytest.mark.parametrize("hole", [_gauged(None), _through()], ids=["depth-outside-the-cone", "no-countersink"])
def test_countersink_gauge_not_measured_fails(hole):
    spec = nominal_spec(countersink_gauge_diameter=5.8, countersink_gauge_tolerance=0.05)
    checked = check(_record(hole), spec)["holes"][0]
    assert checked["failed_checks"] == ["countersink_gauge_not_measured"]
    assert checked["countersink_gauge_deviation"] is None


def test_countersink_gauge_in_a_spec_file_and_its_describe():
    spec = parse_spec('[[hole]]\nname = "C1"\ncenter = [0, 0, 0]\ndiameter = 7.0\ntolerance = 0.05\n'
                      'countersink_gauge_diameter = 5.8\ncountersink_gauge_tolerance = "+0.05/-0"\n')
    [nominal] = spec.holes
    assert (nominal.countersink_gauge_diameter, nominal.countersink_gauge_band) == (5.8, Band(0.0, 0.05))
    hole = check(_record(_gauged(5.83)), spec)["holes"][0]
    assert hole["name"] == "C1" and hole["conformance"]["countersink_gauge"]["decision"] == "pass"
    described = describe(nominal_spec(countersink_gauge_diameter=5.8, countersink_gauge_tolerance=0.05))
    assert described["nominal"]["countersink_gauge_band"] == {"lower": -0.05, "upper": 0.05}


@pytest.mark.parametrize("text, message", [
    ("countersink_gauge_diameter = 5.8\n", "countersink_gauge_diameter needs countersink_gauge_tolerance"),
    ("countersink_gauge_tolerance = 0.05\n", "countersink_gauge_tolerance needs countersink_gauge_diameter"),
    ("countersink_gauge_diameter = -1\ncountersink_gauge_tolerance = 0.05\n",
     "countersink_gauge_diameter must be a number > 0"),
    ('countersink_gauge_diameter = "5.8 +/- 0.05"\ncountersink_gauge_tolerance = 0.05\n',
     "its tolerance goes in countersink_gauge_tolerance"),
    ('countersink_gauge_diameter = 5.8\ncountersink_gauge_tolerance = "0.05/0.05"\n',
     "countersink_gauge_tolerance: "),
])
def test_countersink_gauge_spec_errors(text, message):
    with pytest.raises(SpecError, match=message.replace("+", "\\+")):
        parse_spec('[[hole]]\nname = "C1"\ncenter = [0, 0, 0]\ndiameter = 7.0\ntolerance = 0.05\n' + text)
