"""The results store (holecli.store), the same assertions against SQLite and a real PostgreSQL."""

import copy
import json
import re

import pytest

from holecli.store import StoreError, open_store


def query(location, sql):
    """The rows of a plain SQL query (no parameters) run on the store's own engine, outside holecli."""
    if location.startswith("postgresql://"):
        import psycopg

        with psycopg.connect(location) as connection:
            return [tuple(row) for row in connection.execute(sql).fetchall()]
    import sqlite3
    from contextlib import closing

    with closing(sqlite3.connect(location)) as connection:
        return [tuple(row) for row in connection.execute(sql).fetchall()]


def without_added_keys(answer):
    return {key: value for key, value in answer.items()
            if key not in ("id", "received", "processing_ms", "stored", "meta")}


@pytest.mark.parametrize("name", ["panel_record", "table1_record", "error_record"])
def test_a_record_comes_back_exactly_as_added(store_location, name, request):
    record = request.getfixturevalue(name)
    with open_store(store_location) as store:
        id = store.add(record, processing_ms=81.25, meta={"part": "P7", "serial": "S-001", "fixture": "F2"})
        answer = store.get(id)
    assert re.fullmatch(r"[0-9a-f]{32}", id)
    assert without_added_keys(answer) == record
    assert list(without_added_keys(answer)) == list(record)  # the keys in their order too
    assert json.dumps(without_added_keys(answer)) == json.dumps(record)  # every float to its last digit
    assert answer["id"] == id and answer["stored"] is True and answer["processing_ms"] == 81.25
    assert re.fullmatch(r"\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d\.\d{3}Z", answer["received"])
    assert answer["meta"] == {"part": "P7", "serial": "S-001", "cell": None, "operator": None, "fixture": "F2"}


def test_an_unknown_id_gives_none(store_location):
    with open_store(store_location) as store:
        assert store.get("0" * 32) is None
        assert store.count() == 0 and store.find() == []


def test_the_id_and_received_given_are_kept(store_location, table1_record):
    with open_store(store_location) as store:
        id = store.add(table1_record, id="cell7-000001", received="2026-12-03T11:00:00.5+01:00")
        answer = store.get(id)
    assert id == "cell7-000001"
    assert answer["received"] == "2026-12-03T10:00:00.500Z"
    assert answer["processing_ms"] is None


def test_a_taken_id_is_refused_and_nothing_changes(store_location, table1_record, panel_record):
    with open_store(store_location) as store:
        store.add(table1_record, id="same")
        with pytest.raises(StoreError, match="same"):
            store.add(panel_record, id="same")
        assert store.count() == 1
        assert without_added_keys(store.get("same")) == table1_record
    holes = query(store_location, "SELECT count(*) FROM hole")
    assert holes == [(1,)]


def test_bad_metadata_is_refused_before_anything_is_written(store_location, table1_record):
    with open_store(store_location) as store:
        with pytest.raises(ValueError, match="200"):
            store.add(table1_record, meta={"part": "x" * 201})
        assert store.count() == 0


@pytest.fixture
def filled(store_location, panel_record, table1_record, error_record):
    """A store with six measurements of two parts, on three days."""
    failing = copy.deepcopy(panel_record)
    failing["verdict"].update(in_tolerance=False, out_of_tolerance=1)
    failing["holes"][0].update(in_tolerance=False, failed_checks=["diameter"])
    failing["holes"][0]["conformance"]["diameter"].update(value=0.06, decision="fail", reason="above")
    rows = [
        ("m1", "2026-11-30T08:00:00Z", panel_record, {"part": "P7", "serial": "S1"}),
        ("m2", "2026-12-01T08:00:00Z", failing, {"part": "P7", "serial": "S2", "cell": "C1"}),
        ("m3", "2026-12-01T12:30:00Z", table1_record, {"part": "P9", "serial": "S1"}),
        ("m4", "2026-12-02T09:15:00Z", error_record, {"part": "P7", "serial": "S3"}),
        ("m5", "2026-12-02T23:59:59.999Z", panel_record, {"part": "P7", "serial": "S4", "operator": "ana"}),
        ("m6", "2026-12-03T00:00:00Z", panel_record, {}),
    ]
    with open_store(store_location) as store:
        for id, received, record, meta in rows:
            store.add(record, id=id, received=received, meta=meta, processing_ms=10.0, source="batch")
    return store_location


def ids(summaries):
    return [summary["id"] for summary in summaries]


def test_find_gives_newest_first_and_counts(filled):
    with open_store(filled) as store:
        assert store.count() == 6
        assert ids(store.find()) == ["m6", "m5", "m4", "m3", "m2", "m1"]
        assert ids(store.find(limit=2)) == ["m6", "m5"]
        assert ids(store.find(limit=None)) == ["m6", "m5", "m4", "m3", "m2", "m1"]


@pytest.mark.parametrize("filters, expected", [
    ({"part": "P7"}, ["m5", "m4", "m2", "m1"]),
    ({"serial": "S1"}, ["m3", "m1"]),
    ({"part": "P7", "serial": "S1"}, ["m1"]),
    ({"part": "nothing"}, []),
    ({"since": "2026-12-01"}, ["m6", "m5", "m4", "m3", "m2"]),
    ({"since": "2026-12-01T12:30:00"}, ["m6", "m5", "m4", "m3"]),
    ({"since": "2026-12-01T13:30:00+01:00"}, ["m6", "m5", "m4", "m3"]),  # an offset: 12:30 UTC
    ({"until": "2026-12-02"}, ["m5", "m4", "m3", "m2", "m1"]),  # a date: to the end of that day
    ({"until": "2026-12-01T12:30:00Z"}, ["m3", "m2", "m1"]),  # a moment: included
    ({"since": "2026-12-01", "until": "2026-12-01"}, ["m3", "m2"]),
    ({"verdict": "pass"}, ["m6", "m5", "m1"]),
    ({"verdict": "fail"}, ["m2"]),
    ({"verdict": "unchecked"}, ["m3"]),
    ({"verdict": "error"}, ["m4"]),
    ({"verdict": "undecided"}, []),
    ({"part": "P7", "verdict": "pass", "limit": 1}, ["m5"]),
])
def test_find_filters(filled, filters, expected):
    with open_store(filled) as store:
        assert ids(store.find(**filters)) == expected


def test_a_summary_says_who_what_when(filled):
    with open_store(filled) as store:
        (summary,) = store.find(serial="S4")
        (error,) = store.find(verdict="error")
    assert summary == {"id": "m5", "received": "2026-12-02T23:59:59.999Z", "file": summary["file"], "part": "P7",
                       "serial": "S4", "cell": None, "operator": "ana", "spec": summary["spec"], "verdict": "pass",
                       "holes": 4, "processing_ms": 10.0}
    assert summary["file"].endswith("panel.ply") and summary["spec"].endswith("panel_tolerances.toml")
    assert error["holes"] is None and error["spec"] is None and error["file"].endswith("missing.ply")


@pytest.mark.parametrize("filters, match", [
    ({"verdict": "ok"}, "verdict must be one of"),
    ({"since": "last week"}, "ISO-8601"),
    ({"limit": 0}, "positive integer"),
    ({"limit": "10"}, "positive integer"),
])
def test_find_refuses_bad_filters(store_location, filters, match):
    with open_store(store_location) as store:
        with pytest.raises(ValueError, match=match):
            store.find(**filters)


def test_the_diameters_of_a_part_are_plain_sql(filled, panel_record):
    # statistical process control: T1's diameter of part P7's measurements in December, oldest first
    rows = query(filled, "SELECT m.id, h.diameter FROM hole h JOIN measurement m ON m.id = h.measurement_id "
                         "WHERE m.part = 'P7' AND h.name = 'T1' AND m.received >= '2026-12-01' "
                         "ORDER BY m.received")
    assert rows == [("m2", panel_record["holes"][0]["diameter"]), ("m5", panel_record["holes"][0]["diameter"])]
    failures = query(filled, "SELECT count(*) FROM characteristic c JOIN measurement m ON m.id = c.measurement_id "
                             "WHERE m.id = 'm1' AND c.decision = 'pass'")
    assert failures == [(13,)]
    info = dict(query(filled, "SELECT key, value FROM store_info"))
    assert info["schema_version"] == "1" and set(info) == {"schema_version", "created", "holecli_version"}


def test_a_store_opened_again_has_what_was_added(store_location, table1_record):
    with open_store(store_location) as store:
        id = store.add(table1_record)
    with open_store(store_location) as store:
        assert store.count() == 1 and store.get(id)["file"] == table1_record["file"]


def test_the_same_answers_from_both_engines(tmp_path, postgres_store_url, panel_record, error_record):
    answers = []
    for location in (str(tmp_path / "results.sqlite"), postgres_store_url):
        with open_store(location) as store:
            store.add(panel_record, id="a", received="2026-12-03T10:00:00Z", processing_ms=1.5, meta={"part": "P"})
            store.add(error_record, id="b", received="2026-12-03T10:00:01Z")
            answers.append((store.get("a"), store.get("b"), store.find(), store.count()))
    assert answers[0] == answers[1]
    assert json.dumps(answers[0]) == json.dumps(answers[1])


def test_a_closed_store_says_so(store_location, table1_record):
    store = open_store(store_location)
    store.close()
    store.close()
    with pytest.raises(StoreError, match="closed"):
        store.add(table1_record)


# The example queries of the docs' "Results store" page (docs-pending/i27-store.md), on both engines.
DIAMETERS_OVER_TIME = """
SELECT m.received, m.serial, h.diameter, h.u_diameter
FROM hole h JOIN measurement m ON m.id = h.measurement_id
WHERE m.part = 'P7' AND h.name = 'T1'
ORDER BY m.received
"""
FAILURES_OF_A_WEEK = """
SELECT m.received, m.serial, h.name AS hole, c.name AS characteristic, c.value, c.lower, c.upper
FROM characteristic c
JOIN measurement m ON m.id = c.measurement_id
JOIN hole h ON h.measurement_id = c.measurement_id AND h.idx = c.hole_idx
WHERE c.decision = 'fail' AND m.received >= '2026-11-30' AND m.received < '2026-12-07'
ORDER BY m.received, h.idx
"""
CHARACTERISTICS_OF_A_SERIAL = """
SELECT h.name AS hole, c.name AS characteristic, c.value, c.lower, c.upper, c.expanded_uncertainty, c.decision
FROM characteristic c
JOIN hole h ON h.measurement_id = c.measurement_id AND h.idx = c.hole_idx
JOIN measurement m ON m.id = c.measurement_id
WHERE m.serial = 'S4'
ORDER BY m.received, h.idx, c.name
"""


def test_the_docs_example_queries(filled, panel_record):
    diameters = query(filled, DIAMETERS_OVER_TIME)
    assert [row[1:3] for row in diameters] == [(serial, panel_record["holes"][0]["diameter"])
                                               for serial in ("S1", "S2", "S4")]
    assert str(diameters[0][0]).startswith("2026-11-30")
    failures = query(filled, FAILURES_OF_A_WEEK)
    assert [row[1:7] for row in failures] == [("S2", "T1", "diameter", 0.06, -0.05, 0.05)]
    characteristics = query(filled, CHARACTERISTICS_OF_A_SERIAL)
    assert len(characteristics) == 13 and {row[6] for row in characteristics} == {"pass"}
    assert characteristics[0][:2] == ("T1", "diameter")
