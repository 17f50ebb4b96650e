"""Declared units of a spec (``units = "in"``) and the unit mistakes a check names (issue 25, item 3)."""

import math

import pytest

from holecli.errors import SpecError
from holecli.tolerance import Band, check, nominal_spec, parse_spec, unit_scale_match
from holecli.units import declared_units, min_diameter_beyond_scan, unit_mistake

# One hole of 3 mm at (10, 20, 0), as a spec in inches declares it.
SPEC_IN_INCHES = """units = "in"
[[hole]]
name = "A"
center = [0.3937007874015748, 0.7874015748031497, 0.0]
diameter = 0.11811023622047245
tolerance = 0.001
position_tolerance = 0.004
normal = [0, 0, 1]
max_tilt = 1
"""


def _record(center=(10.0, 20.0, 0.0), diameter=3.0, units=None):
    record = {"file": "scan.ply", "method": "robust",
              "holes": [{"index": 0, "center": list(center), "diameter": diameter, "normal": [0.0, 0.0, 1.0],
                         "warnings": []}]}
    if units is not None:
        record["units"] = units
    return record


def test_a_spec_declares_its_unit():
    assert parse_spec(SPEC_IN_INCHES).units == "in"
    assert parse_spec(SPEC_IN_INCHES.replace('units = "in"\n', "")).units is None


@pytest.mark.parametrize("line, match", [('units = "ft"', r"units must be one of 'mm', 'm', 'in'.*got 'ft'"),
                                         ("units = 25.4", r"units must be one of .*got float 25.4"),
                                         ('unit = "mm"', r"unknown top-level key 'unit'")])
def test_a_wrong_unit_is_refused(line, match):
    with pytest.raises(SpecError, match=match):
        parse_spec(SPEC_IN_INCHES.replace('units = "in"', line))


def test_a_spec_in_inches_is_converted_into_the_scans_millimetres():
    """Issue 25: a spec in inches reported every hole missing against a scan in mm."""
    checked = check(_record(diameter=3.0005, units="mm"), parse_spec(SPEC_IN_INCHES))
    verdict, hole = checked["verdict"], checked["holes"][0]
    assert verdict["in_tolerance"] and verdict["missing"] == [] and verdict["checked"] == 1
    assert verdict["spec_units"] == "in" and verdict["spec_units_assumed"] is False
    assert math.isclose(hole["diameter_deviation"], 0.0005, abs_tol=1e-12)
    entry = hole["conformance"]["diameter"]
    assert math.isclose(entry["upper"], 0.0254) and math.isclose(entry["lower"], -0.0254)
    assert math.isclose(hole["conformance"]["position"]["upper"], 0.1016)
    assert hole["conformance"]["tilt"]["upper"] == 1.0  # an angle is not converted
    assert checked["units"] == "mm"


def test_a_spec_in_millimetres_is_converted_into_the_scans_metres():
    spec = parse_spec(SPEC_IN_INCHES.replace('units = "in"', 'units = "m"').replace(
        "0.3937007874015748, 0.7874015748031497", "0.010, 0.020").replace("0.11811023622047245", "0.003")
        .replace("0.001\n", "0.00002\n").replace("0.004", "0.0001"))
    checked = check(_record(diameter=3.00001, units="mm"), spec)
    assert checked["verdict"]["in_tolerance"], checked["holes"][0]["conformance"]


def test_without_the_scans_unit_the_spec_unit_is_assumed_and_said():
    checked = check(_record(center=(0.3937, 0.7874, 0.0), diameter=0.1181), parse_spec(SPEC_IN_INCHES))
    assert checked["verdict"]["spec_units_assumed"] is True and checked["verdict"]["spec_units"] == "in"
    assert checked["units"] == "in" and list(checked)[:3] == ["file", "method", "units"]
    assert checked["verdict"]["in_tolerance"]


def test_a_spec_without_units_checks_as_before():
    spec = parse_spec(SPEC_IN_INCHES.replace('units = "in"\n', ""))
    checked = check(_record(center=(0.3937, 0.7874, 0.0), diameter=0.1181, units="mm"), spec)
    assert "spec_units" not in checked["verdict"] and checked["verdict"]["in_tolerance"]


@pytest.mark.parametrize("measured, nominal, expected", [
    (0.006, 6.0, ("1/1000", "m", "mm")), (6000.0, 6.0, ("1000x", "mm", "m")),
    (76.2, 3.0, ("25.4x", "mm", "in")), (3.0 / 25.4, 3.0, ("1/25.4", "in", "mm")),
    (0.00299, 3.0, ("1/1000", "m", "mm")),  # within 1 %
    (0.00296, 3.0, None), (3.03, 3.0, None), (0.0, 3.0, None), (None, 3.0, None)])
def test_unit_mistake(measured, nominal, expected):
    assert unit_mistake(measured, nominal) == expected


def test_a_diameter_a_thousand_times_too_small_is_named_a_unit_mistake():
    """Issue 25: a scan in metres against a 3 mm tolerance read a plain "out of tolerance" (-2.997)."""
    spec = nominal_spec(diameter=3.0, tolerance=Band(-0.02, 0.02))
    checked = check(_record(diameter=0.002997), spec)
    hole = checked["holes"][0]
    assert hole["failed_checks"] == ["diameter"]
    (warning,) = hole["warnings"]
    assert warning["code"] == "unit_mismatch"
    assert "1/1000 of the nominal 3" in warning["message"] and "in m and the tolerances in mm" in warning["message"]
    # a hole simply out of tolerance gets no such warning
    assert check(_record(diameter=2.5), spec)["holes"][0]["warnings"] == []


def test_unit_scale_match_finds_the_factor_that_matches_every_spec_hole():
    """The scan in metres, the spec (without units) in mm: every hole far, all match at x1000."""
    spec = parse_spec(SPEC_IN_INCHES.replace('units = "in"\n', "").replace(
        "0.3937007874015748, 0.7874015748031497", "10.0, 20.0").replace("0.11811023622047245", "3.0"))
    record = check(_record(center=(0.010, 0.020, 0.0), diameter=0.003), spec)
    assert record["verdict"]["missing"] == ["A"]
    assert unit_scale_match(record, spec) == (1000.0, "m", "mm")
    # a scan in another frame (no factor explains it) gets no unit hint
    record = check(_record(center=(300.0, -40.0, 0.0)), spec)
    assert record["verdict"]["missing"] == ["A"] and unit_scale_match(record, spec) is None
    # and a spec that matched gets none
    assert unit_scale_match(check(_record(), spec), spec) is None


def test_unit_scale_match_of_a_spec_in_inches_without_the_scans_unit():
    spec = parse_spec(SPEC_IN_INCHES)
    record = check(_record(), spec)  # the scan taken to be in inches: 25.4 times too far
    assert record["verdict"]["missing"] == ["A"] and record["verdict"]["spec_units_assumed"]
    assert unit_scale_match(record, spec) == (pytest.approx(1 / 25.4), "mm", "in")


def test_declared_units_pops_the_key():
    data = {"units": "mm", "hole": []}
    assert declared_units(data) == "mm" and data == {"hole": []}
    with pytest.raises(ValueError, match="of the panel"):
        declared_units({"units": "cm"}, "panel")


def test_min_diameter_beyond_scan():
    # 10000 points 0.1 mm apart: a 10 mm patch; a 2 mm hole fits, a 20 mm one does not
    assert min_diameter_beyond_scan(2.0, 10_000, 0.1) is None
    assert min_diameter_beyond_scan(20.0, 10_000, 0.1) == pytest.approx(10.0)
    assert min_diameter_beyond_scan(None, 10_000, 0.1) is None
    assert min_diameter_beyond_scan(2.0, 10_000, None) is None


def test_spec_in_units_converts_lengths_not_angles():
    from holecli.tolerance import spec_in_units

    spec = parse_spec(SPEC_IN_INCHES)
    (hole,) = spec_in_units(spec, "mm").holes
    assert hole.center == pytest.approx((10.0, 20.0, 0.0)) and hole.diameter == pytest.approx(3.0)
    assert hole.band.upper == pytest.approx(0.0254) and hole.position_tolerance == pytest.approx(0.1016)
    assert hole.match_radius == pytest.approx(3.0) and hole.max_tilt == 1.0 and hole.normal == (0.0, 0.0, 1.0)
    assert spec_in_units(spec, None) is spec and spec_in_units(spec, "in") is spec
    undeclared = parse_spec(SPEC_IN_INCHES.replace('units = "in"\n', ""))
    assert spec_in_units(undeclared, "mm") is undeclared
