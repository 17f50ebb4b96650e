"""The JSON Schema of the records (holecli/schema/record.schema.json) against real output, and the
provenance the records carry (issue 13)."""

import hashlib
import json
import os

import pytest

jsonschema = pytest.importorskip("jsonschema")

from holecli import __version__  # noqa: E402
from holecli.results import SCHEMA_VERSION  # noqa: E402
from holecli.schema import KINDS, record_schema  # noqa: E402

SAMPLES = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "sample_clouds")


def _validator(kind):
    schema = record_schema(kind)
    jsonschema.Draft202012Validator.check_schema(schema)
    return jsonschema.Draft202012Validator(schema)


def _valid(record, kind):
    errors = sorted(_validator(kind).iter_errors(record), key=lambda error: list(error.path))
    assert not errors, "\n".join(f"{list(error.path)}: {error.message}" for error in errors[:5])


def _sample(name):
    return os.path.join(SAMPLES, name)


def test_the_schema_is_a_valid_draft_2020_12_schema_shipped_with_the_package():
    schema = record_schema()
    jsonschema.Draft202012Validator.check_schema(schema)
    assert schema["$defs"]["detect_record"]["properties"]["schema_version"]["const"] == SCHEMA_VERSION
    # the schema's own name and title are of the version it describes (they said 2.2 under records of 2.3)
    assert schema["$id"].endswith(f":{SCHEMA_VERSION}") and schema["title"].endswith(f"schema {SCHEMA_VERSION}")
    for kind in KINDS:
        assert record_schema(kind)["$ref"] == f"#/$defs/{kind}"
    with pytest.raises(ValueError, match="kind must be one of"):
        record_schema("hole")


@pytest.fixture(scope="module")
def panel_record(tmp_path_factory):
    """``holecli detect`` of the sample panel (through, countersunk, counterbored and blind holes) with
    a spec file, --gauge-depth and --explain: every kind of field at once."""
    from click.testing import CliRunner

    from holecli import cli

    result = CliRunner().invoke(cli.main, ["detect", _sample("panel.ply"), "--gauge-depth", "0.5", "--explain",
                                           "--spec", _sample("panel_tolerances.toml")])
    assert result.exit_code in (cli.EXIT_OK, cli.EXIT_OUT_OF_TOLERANCE), result.stderr
    return json.loads(result.stdout)


def test_a_detect_record_with_every_kind_of_hole_verdicts_and_rejections_is_valid(panel_record):
    _valid(panel_record, "detect_record")
    _valid(panel_record, None)
    holes = panel_record["holes"]
    assert {hole["type"] for hole in holes} == {"through", "countersunk", "counterbored", "blind"}
    assert any(hole["countersink"] for hole in holes) and any(hole["counterbore"] for hole in holes)
    assert all("in_tolerance" in hole for hole in holes) and "verdict" in panel_record
    assert "rejected" in panel_record


def test_the_record_names_the_spec_file_and_the_sha256_of_its_bytes(panel_record):
    with open(_sample("panel_tolerances.toml"), "rb") as stream:
        digest = hashlib.sha256(stream.read()).hexdigest()
    assert panel_record["options"]["tolerances"] == {"spec_file": _sample("panel_tolerances.toml"),
                                                     "spec_sha256": digest, "nominal": None,
                                                     "decision_rule": "simple", "coverage_factor": 2.0}
    assert panel_record["options"]["gauge_depth"] == 0.5
    assert panel_record["schema_version"] == SCHEMA_VERSION and panel_record["holecli_version"] == __version__


def test_the_schema_refuses_what_is_not_a_record(panel_record):
    validator = _validator("detect_record")
    broken = dict(panel_record, elapsed_ms=1.0)  # the key of schema 1, moved under timing
    assert not validator.is_valid(broken)
    without = {key: value for key, value in panel_record.items() if key != "scales"}
    assert not validator.is_valid(without)
    hole = dict(panel_record["holes"][0], type="slot")
    assert not validator.is_valid(dict(panel_record, holes=[hole]))


@pytest.mark.parametrize("args", [
    ["--method", "paper"],
    ["--nominal-diameter", "3", "--tolerance", "+0.036/-0", "--view-dir", "0,0,-1", "--max-holes", "1"],
    ["--full-only", "--min-diameter", "1"],
    ["--units", "mm", "--output-units", "m", "--gauge-depth", "0.0005", "--explain"],
])
def test_detect_records_of_the_options_are_valid(run, args):
    result = run("detect", _sample("table1.ply"), *args)
    record = json.loads(result.stdout)
    _valid(record, "detect_record")


def test_batch_lines_measured_and_failed_are_valid(run, tmp_path):
    import shutil

    shutil.copy(_sample("stripes_three_holes.ply"), tmp_path / "stripes.ply")
    (tmp_path / "broken.csv").write_text("not,a\ncloud\n")
    result = run("batch", tmp_path, "--jobs", "1", "--spec", _sample("stripes_three_holes.toml"), "--explain")
    lines = [json.loads(line) for line in result.stdout.splitlines()]
    assert len(lines) == 2
    for line in lines:
        _valid(line, "batch_line")
        _valid(line, None)
    measured, failed = sorted(lines, key=lambda line: "error" in line)
    _valid(measured, "batch_record")
    _valid(failed, "batch_error")
    assert not _validator("detect_record").is_valid(failed)
    # a striped scan: its line pitch is measured
    assert measured["scales"]["line_pitch"] > measured["scales"]["point_spacing"]


def test_two_identical_runs_differ_only_in_timing(run):
    def without_timing(text):
        record = json.loads(text)
        assert set(record["timing"]) == {"elapsed_ms", "read_ms", "stages"}
        record.pop("timing")
        return record

    first = run("detect", _sample("stripes_three_holes.ply"), "--explain")
    second = run("detect", _sample("stripes_three_holes.ply"), "--explain")
    assert first.stdout != second.stdout
    assert without_timing(first.stdout) == without_timing(second.stdout)


def test_the_record_says_how_the_file_was_read(run, tmp_path):
    import shutil

    scan = tmp_path / "scan.asc"
    shutil.copy(_sample("table1.ply"), scan)
    record = json.loads(run("detect", scan, "--input-format", "ply", "--scan", "0").stdout)
    _valid(record, "detect_record")
    assert (record["options"]["input_format"], record["options"]["scan"]) == ("ply", 0)
    plain = json.loads(run("detect", _sample("table1.ply")).stdout)
    assert (plain["options"]["input_format"], plain["options"]["scan"]) == (None, None)


def test_notes_are_apart_from_warnings_in_the_schema(panel_record):
    # schema 2.2: why a value is null is a note (a straight-down scan sees no bore wall), never a warning
    from holecli.tolerance import NOT_IN_SPEC_FRAME, UNCERTAINTY_NOTE
    from holecli.vocabulary import DOUBT_CODES, NOTE_CODES, UNIT_MISMATCH, WARNING_CODES

    defs = record_schema()["$defs"]
    # the shape's notes, and the check's (issue 25: a tied hole in another frame; a U wider than the
    # tolerance zone, guarded rule)
    assert set(defs["note"]["properties"]["code"]["enum"]) == set(NOTE_CODES) | {NOT_IN_SPEC_FRAME, UNCERTAINTY_NOTE}
    # (unit_mismatch: a tolerance check's, issue 25)
    assert set(defs["warning"]["properties"]["code"]["enum"]) == set(WARNING_CODES) | set(DOUBT_CODES) | {UNIT_MISMATCH}
    holes = panel_record["holes"]
    assert all(hole["warnings"] == [] for hole in holes)
    assert {note["code"] for hole in holes for note in hole["notes"]} == {"bore_not_seen", "axis_not_measured"}
    validator = _validator("detect_record")
    hole = holes[0]
    note_as_warning = dict(hole, warnings=hole["notes"], notes=[])
    assert not validator.is_valid(dict(panel_record, holes=[note_as_warning]))
    warning_as_note = dict(hole, notes=[{"code": "rim_gap", "message": "a gap"}])
    assert not validator.is_valid(dict(panel_record, holes=[warning_as_note]))
    without_notes = {key: value for key, value in hole.items() if key != "notes"}
    assert not validator.is_valid(dict(panel_record, holes=[without_notes]))


def test_every_rejection_check_and_estimator_is_in_the_schema():
    """The schema lists every check that can refuse a candidate (pocket, the edge loops' ...) and every
    estimator of an edge (edge_loops): a record holecli writes is always valid."""
    from holecli.vocabulary import ESTIMATORS, REJECTION_REASONS

    defs = record_schema()["$defs"]
    assert set(defs["rejection"]["properties"]["check"]["enum"]) == set(REJECTION_REASONS)
    text = json.dumps(record_schema())
    for estimator in [*ESTIMATORS, "edge_loops"]:
        assert f'"{estimator}"' in text, estimator
