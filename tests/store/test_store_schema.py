"""The rows of a record (holecli.store.schema): pure functions, fed real records."""

import json

import pytest

from holecli.store import schema


def test_the_verdict_word_of_each_kind_of_record(panel_record, table1_record, error_record):
    assert schema.verdict_word(panel_record) == "pass"
    assert schema.verdict_word(table1_record) == "unchecked"
    assert schema.verdict_word(error_record) == "error"
    failing = dict(panel_record, verdict=dict(panel_record["verdict"], in_tolerance=False, out_of_tolerance=1))
    assert schema.verdict_word(failing) == "fail"
    missing = dict(panel_record, verdict=dict(panel_record["verdict"], in_tolerance=False, missing=["X1"]))
    assert schema.verdict_word(missing) == "fail"
    undecided = dict(panel_record, verdict=dict(panel_record["verdict"], in_tolerance=False, undecided=1))
    assert schema.verdict_word(undecided) == "undecided"


def test_the_measurement_row_of_a_checked_record(panel_record):
    row = schema.measurement_row(panel_record, id="a" * 32, received="2026-12-03T10:00:00.000Z", processing_ms=85.5,
                                 meta={"part": "P7", "serial": "S1", "fixture": "F2"}, source="batch")
    assert list(row) == [name for name, _, _ in schema.MEASUREMENT_COLUMNS]
    assert row["id"] == "a" * 32 and row["source"] == "batch"
    assert (row["part"], row["serial"], row["cell"], row["operator"]) == ("P7", "S1", None, None)
    assert json.loads(row["meta"]) == {"part": "P7", "serial": "S1", "cell": None, "operator": None, "fixture": "F2"}
    assert row["spec"].endswith("panel_tolerances.toml")
    assert row["spec_sha256"] == panel_record["options"]["tolerances"]["spec_sha256"]
    assert (row["verdict"], row["holes"], row["points"]) == ("pass", 4, 57156)
    assert row["file"] == panel_record["file"] and row["path"] == panel_record["path"]
    assert json.loads(row["options"]) == panel_record["options"]
    assert row["schema_version"] == panel_record["schema_version"] and row["error"] is None
    assert json.loads(row["record"]) == panel_record


def test_the_measurement_row_of_an_error_record_has_no_holes(error_record):
    row = schema.measurement_row(error_record, id="e", received="2026-12-03T10:00:00.000Z")
    assert (row["verdict"], row["holes"], row["error"]) == ("error", None, error_record["error"])
    assert row["points"] is None and row["options"] is None
    assert schema.hole_rows(error_record, "e") == [] and schema.characteristic_rows(error_record, "e") == []


def test_the_hole_rows_of_a_checked_record(panel_record):
    rows = schema.hole_rows(panel_record, "m")
    assert [row["idx"] for row in rows] == [0, 1, 2, 3]
    assert [row["name"] for row in rows] == ["T1", "C1", "B1", "L1"]
    assert all(list(row) == [name for name, _, _ in schema.HOLE_COLUMNS] for row in rows)
    t1, c1 = rows[0], rows[1]
    hole = panel_record["holes"][0]
    assert (t1["x"], t1["y"], t1["z"]) == tuple(hole["center"])
    assert (t1["nx"], t1["ny"], t1["nz"]) == tuple(hole["normal"])
    assert t1["diameter"] == hole["diameter"] and t1["u_diameter"] == hole["uncertainty"]["diameter"]
    assert t1["type"] == "through" and t1["in_tolerance"] == 1 and t1["countersink_diameter"] is None
    countersink = panel_record["holes"][1]["countersink"]
    assert (c1["countersink_diameter"], c1["countersink_angle"], c1["countersink_depth"]) == (
        countersink["diameter"], countersink["angle_deg"], countersink["depth"])
    assert c1["perpendicularity_deg"] == panel_record["holes"][1]["perpendicularity_deg"]
    assert json.loads(t1["warnings"]) == [warning["code"] for warning in hole["warnings"]]


def test_an_unchecked_hole_has_no_name_and_in_tolerance_null(table1_record):
    (row,) = schema.hole_rows(table1_record, "m")
    assert row["name"] is None and row["in_tolerance"] is None
    assert row["diameter"] == pytest.approx(3.0, abs=0.01)
    assert schema.characteristic_rows(table1_record, "m") == []


def test_a_characteristic_row_per_conformance_entry(panel_record):
    rows = schema.characteristic_rows(panel_record, "m")
    expected = [(idx, name) for idx, hole in enumerate(panel_record["holes"]) for name in hole["conformance"]]
    assert [(row["hole_idx"], row["name"]) for row in rows] == expected
    assert len(rows) == 13
    first = rows[0]
    entry = panel_record["holes"][0]["conformance"]["diameter"]
    assert (first["value"], first["lower"], first["upper"], first["expanded_uncertainty"], first["decision"],
            first["reason"]) == (entry["value"], entry["lower"], entry["upper"], entry["expanded_uncertainty"],
                                 entry["decision"], entry["reason"])
    assert rows[1]["name"] == "position" and rows[1]["lower"] is None


@pytest.mark.parametrize("meta, match", [
    ({"part number": "x"}, "not a word"),
    ({"1part": "x"}, "not a word"),
    ({"part": 7}, "a string is expected"),
    ({"part": "x" * 201}, "longer than 200"),
])
def test_bad_metadata_is_refused(panel_record, meta, match):
    with pytest.raises(ValueError, match=match):
        schema.measurement_row(panel_record, id="m", received="2026-12-03T10:00:00.000Z", meta=meta)


def test_a_record_with_a_nan_is_refused(table1_record):
    bad = dict(table1_record, points=float("nan"))
    with pytest.raises(ValueError):
        schema.measurement_row(bad, id="m", received="2026-12-03T10:00:00.000Z")


def test_a_file_name_that_is_not_utf8_survives_in_the_record(table1_record):
    name = b"scan\xff.ply".decode("utf-8", "surrogateescape")
    row = schema.measurement_row(dict(table1_record, file=name), id="m", received="2026-12-03T10:00:00.000Z")
    assert row["file"] == "scan\ufffd.ply"
    assert json.loads(row["record"])["file"] == name
    row["record"].encode("ascii")  # storable in any text column


@pytest.mark.parametrize("text, expected", [
    ("2026-12-03", "2026-12-03T00:00:00.000Z"),
    ("2026-12-03T10:00:00", "2026-12-03T10:00:00.000Z"),
    ("2026-12-03T10:00:00.123456Z", "2026-12-03T10:00:00.123Z"),
    ("2026-12-03T01:00:00+02:00", "2026-12-02T23:00:00.000Z"),
])
def test_moments_are_written_in_utc_with_milliseconds(text, expected):
    assert schema.utc_text(text) == expected


def test_a_moment_that_is_not_iso_8601_is_refused():
    with pytest.raises(ValueError, match="ISO-8601"):
        schema.utc_text("yesterday")


def test_the_ddl_of_both_engines_names_every_table_and_index():
    for engine in ("sqlite", "postgres"):
        text = "\n".join(schema.ddl(engine))
        for table in schema.TABLES:
            assert f"CREATE TABLE IF NOT EXISTS {table} (" in text
        assert text.count("CREATE INDEX") == 3
    assert "timestamptz" in "\n".join(schema.ddl("postgres")) and "jsonb" not in "\n".join(schema.ddl("postgres"))


@pytest.mark.parametrize("hole, word", [
    ({}, "unchecked"),                                                        # no tolerance given
    ({"in_tolerance": None, "failed_checks": None}, "unchecked"),            # no nominal applies to it
    ({"in_tolerance": True, "failed_checks": [], "undecided_checks": []}, "pass"),
    ({"in_tolerance": False, "failed_checks": ["diameter"], "undecided_checks": []}, "fail"),
    ({"in_tolerance": False, "failed_checks": ["diameter"], "undecided_checks": ["position"]}, "fail"),
    ({"in_tolerance": False, "failed_checks": [], "undecided_checks": ["position"]}, "undecided"),
])
def test_the_verdict_word_of_a_hole(hole, word):
    assert schema.hole_verdict_word(hole) == word
