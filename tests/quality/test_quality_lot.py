"""holecli.quality.lot: the characteristics of records, from a real lot's batch output."""

import json
import re

import pytest

from holecli.quality.lot import (PRESENCE, SIZE_CHECKS, ZONE_CHECKS, Lot, lot_from_records,
                                 measurement_from_record)


@pytest.fixture(scope="module")
def records(shift_lot):
    """The batch records of the simulated shift (tests/conftest.py's shift_lot), in file order."""
    return [json.loads(line) for line in shift_lot["jsonl"].read_text().splitlines()]


@pytest.fixture(scope="module")
def lot(records):
    return lot_from_records({"record": record, "source": f"shift.jsonl:{n}"} for n, record in enumerate(records, 1))


def test_every_conformance_entry_is_a_characteristic(lot, records):
    entries = sum(len(hole.get("conformance") or {}) for record in records for hole in record["holes"])
    missing = sum(len(record["verdict"]["missing"]) for record in records)
    assert len(lot.characteristics) == entries + missing == lot.summary()["characteristics"]


def test_a_size_characteristic_gives_back_the_nominal_and_the_limits(lot):
    # panel_tolerances.toml: C1 diameter 7.0 +-0.05
    for c in lot.series(("C1", "diameter")):
        assert c.nominal == pytest.approx(7.0, abs=1e-12)
        assert (c.lower, c.upper) == (pytest.approx(6.95), pytest.approx(7.05))
        assert c.deviation == pytest.approx(c.measured - 7.0, abs=1e-12)
        assert c.unit == ""  # a PLY declares no unit


def test_the_oversize_hole_fails_with_its_exceedance(lot):
    by_part = {lot.measurements[c.measurement].label: c for c in lot.series(("C1", "diameter"))}
    bad = by_part["part_002"]
    assert bad.decision == "fail" and bad.reason == "outside"
    assert bad.exceedance == pytest.approx(bad.measured - 7.05)
    assert bad.exceedance == pytest.approx(0.05, abs=0.01)
    assert all(c.exceedance == 0.0 for label, c in by_part.items() if label != "part_002")


def test_a_zone_characteristic_is_its_own_deviation_against_an_upper_limit(lot):
    for c in lot.series(("T1", "position")):
        assert c.name in ZONE_CHECKS and c.is_zone
        assert c.nominal == 0.0 and c.measured == c.deviation >= 0
        assert c.lower is None and c.lower_tolerance is None and c.upper == c.upper_tolerance == 0.1
        assert c.tolerance_zone == 0.1


def test_angles_are_in_degrees(lot):
    angles = lot.series(("C1", "countersink_angle"))
    assert angles and all(c.unit == "deg" and c.nominal == pytest.approx(100.0) for c in angles)


def test_a_missing_hole_is_a_presence_characteristic_and_not_a_key(lot):
    missing = [c for c in lot.characteristics if c.name == PRESENCE]
    assert [(lot.measurements[c.measurement].label, c.hole, c.decision) for c in missing] == [
        ("part_003", "L1", "missing")]
    assert all(name != PRESENCE for _, name in lot.keys)
    assert missing[0].exceedance is None and missing[0].test_uncertainty_ratio is None


def test_the_summary_counts_the_verdicts_and_the_rejected_parts(lot):
    summary = lot.summary()
    assert summary["measurements"] == summary["parts"] == 4
    assert summary["verdicts"] == {"pass": 2, "fail": 2, "undecided": 0, "unchecked": 0, "error": 0}
    assert summary["rejected"] == ["part_002", "part_003"]
    assert summary["holes"] == 4 + 4 + 3 + 4


def test_keys_are_in_first_seen_order_and_series_in_measurement_order(lot):
    assert lot.keys[:2] == (("T1", "diameter"), ("T1", "position"))
    orders = [c.measurement for c in lot.series(("T1", "diameter"))]
    assert orders == sorted(orders) == [0, 1, 2, 3]


def test_the_test_uncertainty_ratio_is_the_zone_over_twice_u():
    c = measurement_from_record(_record(value=0.01, lower=-0.02, upper=0.03, u=0.005), order=0,
                                source="x").characteristics[0]
    assert c.tolerance_zone == pytest.approx(0.05)
    assert c.test_uncertainty_ratio == pytest.approx(5.0)
    unknown = measurement_from_record(_record(u=None), order=0, source="x").characteristics[0]
    assert unknown.test_uncertainty_ratio is None


def test_a_value_not_measured_has_no_nominal_and_no_exceedance():
    record = _record(value=None, decision="fail", reason="not_measured")
    hole = record["holes"][0]
    hole["conformance"] = {"countersink_depth": hole["conformance"].pop("diameter")}  # no countersink measured
    c = measurement_from_record(record, order=0, source="x").characteristics[0]
    assert (c.measured, c.nominal, c.lower, c.upper, c.exceedance) == (None, None, None, None, None)
    assert c.reason == "not_measured"


def test_an_error_record_is_a_measurement_without_characteristics():
    m = measurement_from_record({"file": "scans/bad.ply", "path": "/x/scans/bad.ply", "error": "bad.ply: no points"},
                                order=3, source="shift.jsonl:4")
    assert (m.verdict, m.label, m.characteristics) == ("error", "bad", ())
    assert Lot((m,)).summary()["rejected"] == ["bad"]


def test_the_store_s_serial_names_the_measurement():
    m = measurement_from_record(_record(), order=0, source="abc", meta={"part": "P7", "serial": "SN-12"},
                                id="abc", received="2026-12-04T03:00:00.000Z")
    assert (m.label, m.part, m.serial, m.id) == ("SN-12", "P7", "SN-12", "abc")


def test_an_unchecked_hole_gives_no_characteristic():
    record = {"file": "a.ply", "holes": [{"index": 0, "center": [0, 0, 0], "normal": [0, 0, 1], "diameter": 4.0,
                                          "warnings": []}]}
    m = measurement_from_record(record, order=0, source="x")
    assert m.characteristics == () and m.verdict == "unchecked"


def test_the_hole_s_warnings_go_with_its_characteristics():
    record = _record()
    record["holes"][0]["warnings"] = [{"code": "points_inside", "message": "..."}]
    assert measurement_from_record(record, order=0, source="x").characteristics[0].warnings == ("points_inside",)


def _hole(**changes):
    hole = {"index": 0, "name": "T1", "center": [0, 0, 0], "normal": [0, 0, 1], "diameter": 4.0, "warnings": [],
            "conformance": {"diameter": {"value": 0.0, "lower": -1, "upper": 1, "expanded_uncertainty": 0.1,
                                         "decision": "pass", "reason": "inside"}}}
    hole.update(changes)
    return hole


def _entry(**changes):
    return {"diameter": {"value": 0.0, "lower": -1, "upper": 1, "expanded_uncertainty": 0.1, "decision": "pass",
                         "reason": "inside", **changes}}


@pytest.mark.parametrize("record, message", [
    ([1, 2], "a record is a JSON object"),
    ({"holes": []}, 'no "file"'),
    ({"file": "a.ply"}, 'no "holes" list'),
    ({"file": "a.ply", "holes": ["x"]}, "hole 0 is not a JSON object"),
    ({"file": "a.ply", "holes": [_hole(conformance={"diameter": {"value": 1}})]}, "not a conformance entry"),
    ({"file": "a.ply", "holes": [_hole(conformance=_entry(decision="<i>x</i>"))]}, "not a conformance entry"),
    ({"file": "a.ply", "holes": [_hole(conformance=_entry(upper=None))]}, "conformance.diameter.upper must be"),
    ({"file": "a.ply", "holes": [_hole(conformance=_entry(value=1e308))]}, "conformance.diameter.value must be a fin"),
    ({"file": "a.ply", "holes": [_hole(conformance=_entry(expanded_uncertainty=-1))]}, "expanded_uncertainty must be >= 0"),
    ({"file": "a.ply", "holes": [_hole(conformance=_entry(reason=5))]}, "reason must be a string"),
    ({"file": "a.ply", "holes": [_hole(warnings="rim_gap")]}, "hole 0: warnings is not a list"),
    ({"file": "a.ply", "holes": [_hole(warnings=[{"code": None}])]}, "hole 0: a warning has no code"),
    ({"file": "a.ply", "holes": [_hole(index=[0])]}, "hole 0: index must be an integer"),
    ({"file": "a.ply", "holes": [_hole(name=5)]}, "hole 0: name must be a non-empty string"),
    ({"file": "a.ply", "holes": [_hole(normal=None)]}, "hole 0: normal must be 3 finite numbers"),
    ({"file": "a.ply", "holes": [_hole(center=[0, 0])]}, "hole 0: center must be 3 finite numbers"),
    ({"file": "a.ply", "holes": [_hole(diameter=-1)]}, "hole 0: diameter must be a positive number"),
    ({"file": "a.ply", "units": "ft", "holes": []}, "units must be one of mm, m, in or null, got 'ft'"),
    ({"file": "a.ply", "verdict": "pass", "holes": []}, "verdict must be a JSON object"),
    ({"file": "a.ply", "verdict": {"missing": "L1"}, "holes": []}, "verdict.missing must be a list of hole names"),
    ({"file": "a.ply", "verdict": {"coverage_factor": "2"}, "holes": []}, "verdict.coverage_factor must be a number"),
    ({"file": "a.ply", "options": [], "holes": []}, "options must be a JSON object"),
    ({"file": "a.ply", "options": {"tolerances": "x"}, "holes": []}, "options.tolerances must be a JSON object"),
])
def test_what_is_not_a_record_is_refused_with_its_source(record, message):
    with pytest.raises(ValueError, match=f"^shift.jsonl:7: .*{re.escape(message)}"):
        lot_from_records([{"record": record, "source": "shift.jsonl:7"}])


def test_size_and_zone_checks_cover_every_check_the_tolerances_make():
    from holecli.tolerance.spec import _UNCERTAINTY_PATHS
    assert set(SIZE_CHECKS) | set(ZONE_CHECKS) == set(_UNCERTAINTY_PATHS)
    assert not set(SIZE_CHECKS) & set(ZONE_CHECKS)


def _record(value=0.01, lower=-0.05, upper=0.05, u=0.01, decision="pass", reason="inside", diameter=4.01):
    entry = {"value": value, "lower": lower, "upper": upper, "expanded_uncertainty": u, "decision": decision,
             "reason": reason}
    return {"file": "scans/p.ply", "units": "mm", "verdict": {"in_tolerance": decision == "pass", "missing": []},
            "holes": [{"index": 0, "name": "T1", "center": [0.0, 0.0, 0.0], "normal": [0.0, 0.0, 1.0],
                       "diameter": 4.01 if diameter is None else diameter, "warnings": [],
                       "conformance": {"diameter": entry}}]}


def test_an_unnamed_hole_is_its_measurement_s_own_characteristic():
    # checked against a nominal without a name (detect --nominal-diameter): the index says nothing of
    # which hole it is in another scan
    first, second = _record(), _record()
    for record in (first, second):
        del record["holes"][0]["name"]
    lot = lot_from_records([{"record": first, "source": "a:1"}, {"record": second, "source": "a:2"}])
    holes = [c.hole for c in lot.characteristics]
    assert holes == ["#0/1", "#0/2"] and not any(c.named for c in lot.characteristics)
    assert lot.keys == ()
