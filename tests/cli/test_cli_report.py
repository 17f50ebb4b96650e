"""``holecli report``: the quality records of a lot from JSON Lines or a results store (formats csv and
fai here; html and qif have their own tests in tests/quality/)."""

import csv
import io
import json
import shutil

import pytest

from holecli.cli.report import EXIT_NOTHING
from holecli.quality.tables import CHARACTERISTIC_COLUMNS, FAI_COLUMNS


def rows(text):
    return list(csv.DictReader(io.StringIO(text)))


def test_csv_has_a_row_per_characteristic_of_the_shift(run, shift_lot):
    result = run("report", shift_lot["jsonl"], "--format", "csv")
    assert result.exit_code == 0, result.stderr
    table = rows(result.stdout)
    assert list(table[0]) == list(CHARACTERISTIC_COLUMNS)
    records = [json.loads(line) for line in shift_lot["jsonl"].read_text().splitlines()]
    entries = sum(len(h.get("conformance") or {}) for r in records for h in r["holes"])
    assert len(table) == entries + 1  # and the missing L1 of part_003
    failed = [(row["label"], row["hole"], row["characteristic"]) for row in table if row["decision"] == "fail"]
    assert ("part_002", "C1", "diameter") in failed
    missing = [row for row in table if row["decision"] == "missing"]
    assert [(row["label"], row["hole"], row["characteristic"]) for row in missing] == [("part_003", "L1", "presence")]
    assert "4 measurements (2 pass, 2 fail)" in result.stderr


def test_fai_numbers_a_characteristic_alike_on_every_part(run, shift_lot):
    result = run("report", shift_lot["jsonl"], "--format", "fai", "--part-number", "PN-4711")
    assert result.exit_code == 0, result.stderr
    table = rows(result.stdout)
    assert list(table[0]) == list(FAI_COLUMNS)
    numbers = {}
    for row in table:
        assert row["part_number"] == "PN-4711"
        numbers.setdefault((row["reference_location"], row["requirement"]), set()).add(row["char_no"])
    assert all(len(found) == 1 for found in numbers.values())
    bad = next(row for row in table if row["serial_number"] == "part_002" and row["reference_location"] == "hole C1"
               and row["requirement"].startswith("diameter"))
    assert "NONCONFORMING" in bad["results"] and bad["nonconformance_number"] == ""
    absent = next(row for row in table if row["serial_number"] == "part_003" and row["reference_location"] == "hole L1"
                  and row["requirement"] == "hole L1 present")
    assert absent["results"] == "not found: NONCONFORMING"


def test_the_format_follows_the_output_s_extension(run, shift_lot, tmp_path):
    output = tmp_path / "characteristics.csv"
    assert run("report", shift_lot["jsonl"], "-o", output).exit_code == 0
    assert output.read_text().startswith(",".join(CHARACTERISTIC_COLUMNS))


def test_name_order_sorts_a_batch_s_lines_by_file(run, shift_lot, tmp_path):
    lines = shift_lot["jsonl"].read_text().splitlines()
    shuffled = tmp_path / "shuffled.jsonl"
    shuffled.write_text("\n".join(lines[::-1]) + "\n")
    read = rows(run("report", shuffled, "--format", "csv").stdout)
    named = rows(run("report", shuffled, "--format", "csv", "--order", "name").stdout)
    assert read[0]["label"] == "part_004" and named[0]["label"] == "part_001"


def test_a_detect_json_record_and_stdin_are_read(run, holecli_process, repo_root, tmp_path):
    record = holecli_process("detect", repo_root / "sample_clouds" / "panel.ply", "--spec",
                             repo_root / "sample_clouds" / "panel_tolerances.toml")
    assert record.returncode == 0, record.stderr
    (tmp_path / "panel.json").write_text(record.stdout)  # indented JSON
    by_file = holecli_process("report", tmp_path / "panel.json", "--format", "csv")
    by_stdin = holecli_process("report", "-", "--format", "csv", input=json.dumps(json.loads(record.stdout)) + "\n")
    assert by_file.returncode == by_stdin.returncode == 0, (by_file.stderr, by_stdin.stderr)
    assert len(rows(by_file.stdout)) == 2 + 6 + 3 + 2  # T1, C1, B1, L1 (panel_tolerances.toml)
    assert [row["measured"] for row in rows(by_stdin.stdout)] == [row["measured"] for row in rows(by_file.stdout)]


def test_a_store_s_measurements_are_reported_with_their_metadata(holecli_process, shift_lot, repo_root, tmp_path):
    store = tmp_path / "results.sqlite"
    spec = repo_root / "sample_clouds" / "panel_tolerances.toml"
    for number in (1, 2):
        batch = holecli_process("batch", shift_lot["scans"] / f"part_00{number}.ply", "--spec", spec, "--store", store,
                                "--meta", "part=P7", "--meta", f"serial=SN-{number}", "-o", tmp_path / f"{number}.jsonl")
        assert batch.returncode in (0, 5), batch.stderr
    result = holecli_process("report", "--store", store, "--part", "P7", "--format", "csv")
    assert result.returncode == 0, result.stderr
    table = rows(result.stdout)
    assert [row["serial"] for row in table][0] == "SN-1" and table[-1]["serial"] == "SN-2"  # oldest first
    assert all(row["part"] == "P7" and len(row["id"]) == 32 and row["received"].endswith("Z") for row in table)
    one = rows(holecli_process("report", "--store", store, "--serial", "SN-2", "--format", "csv").stdout)
    assert {row["serial"] for row in one} == {"SN-2"}
    none = holecli_process("report", "--store", store, "--part", "P8", "--format", "csv")
    assert none.returncode == EXIT_NOTHING
    assert none.stderr == f"Error: nothing to report: no measurement in the store {store} (part P8)\n"


def test_a_postgresql_store_is_reported_too(holecli_process, shift_lot, repo_root, postgres_store_url):
    batch = holecli_process("batch", shift_lot["scans"] / "part_002.ply", "--spec",
                            repo_root / "sample_clouds" / "panel_tolerances.toml", "--store", postgres_store_url,
                            "--meta", "serial=SN-2", "-o", "-")
    assert batch.returncode == 5, batch.stderr
    result = holecli_process("report", "--store", postgres_store_url, "--format", "fai")
    assert result.returncode == 0, result.stderr
    assert {row["serial_number"] for row in rows(result.stdout)} == {"SN-2"}


def test_a_missing_store_is_refused_and_not_created(run, tmp_path):
    store = tmp_path / "nothing.sqlite"
    result = run("report", "--store", store)
    assert (result.exit_code, result.stderr) == (3, f"Error: {store}: no such results store\n")
    assert not store.exists()


def test_an_empty_sqlite_file_is_refused_and_left_empty(run, tmp_path):
    store = tmp_path / "empty.sqlite"
    store.write_bytes(b"")
    result = run("report", "--store", store)
    assert result.exit_code == 3 and "not a holecli results store" in result.stderr
    assert store.read_bytes() == b""


@pytest.mark.parametrize("content, message", [
    ('{"file": "a.ply", "holes": []}\nnot json\n', "bad.jsonl:2: not JSON (Expecting value)"),
    ('{"file": "a.ply", "holes": []}\n[1]\n', "bad.jsonl:2: a record is a JSON object, got list"),
    ('{"holes": []}\n', 'bad.jsonl:1: not a holecli record: no "file"'),
    ('{"file": "a.ply"}\n', 'bad.jsonl:1: not a holecli record: no "holes" list and no "error"'),
    ("file,hole,diameter\nscan.ply,0,3.0\n", "bad.jsonl:1: not JSON"),
])
def test_what_is_not_a_record_is_refused_with_its_line(run, tmp_path, monkeypatch, content, message):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "bad.jsonl").write_text(content)
    (tmp_path / "report.csv").write_text("an earlier report\n")
    result = run("report", "bad.jsonl", "-o", "report.csv")
    assert result.exit_code == 3
    assert result.stderr.startswith(f"Error: {message}") and result.stderr.count("\n") == 1
    assert (tmp_path / "report.csv").read_text() == "an earlier report\n"  # nothing written


def test_a_file_that_is_not_text_or_cannot_be_read_is_refused(run, tmp_path):
    (tmp_path / "binary.jsonl").write_bytes(b"\xff\xfe\x00garbage")
    result = run("report", tmp_path / "binary.jsonl")
    assert result.exit_code == 3 and "not a text file of JSON records (not UTF-8 at byte 0)" in result.stderr
    missing = run("report", tmp_path / "missing.jsonl")
    assert missing.exit_code == 3
    assert missing.stderr == f"Error: {tmp_path / 'missing.jsonl'}: cannot read: No such file or directory\n"


def test_an_empty_file_is_nothing_to_report(run, tmp_path):
    (tmp_path / "empty.jsonl").write_text("\n\n")
    result = run("report", tmp_path / "empty.jsonl")
    assert result.exit_code == EXIT_NOTHING and "nothing to report" in result.stderr


@pytest.mark.parametrize("arguments, message", [
    ((), "give RESULTS files"),
    (("x.jsonl", "--store", "s.sqlite"), "give RESULTS files or --store, not both"),
    (("x.jsonl", "--part", "P7"), "--part filters a --store's measurements: give --store"),
    (("x.jsonl", "--since", "2026-12-04"), "--since filters a --store's measurements"),
    (("-", "-"), "- (stdin) can be given once"),
    (("x.jsonl", "--format", "csv", "--no-pictures"), "--no-pictures is for --format html"),
    (("x.jsonl", "--format", "fai", "--title", "T"), "--title is for --format html"),
    (("x.jsonl", "-q", "-v"), "--quiet and --verbose cannot be combined"),
])
def test_usage_errors(run, arguments, message):
    result = run("report", *arguments)
    assert result.exit_code == 2 and message in result.stderr


def test_a_bad_date_is_a_usage_error(run, shift_lot, tmp_path):
    store = tmp_path / "s.sqlite"
    from holecli.store import open_store

    with open_store(store) as opened:
        opened.add(json.loads(shift_lot["jsonl"].read_text().splitlines()[0]))
    result = run("report", "--store", store, "--since", "yesterday")
    assert result.exit_code == 2 and "ISO-8601" in result.stderr


def test_the_report_never_replaces_its_input(run, shift_lot, tmp_path):
    copy = tmp_path / "shift.jsonl"
    shutil.copy(shift_lot["jsonl"], copy)
    before = copy.read_bytes()
    result = run("report", copy, "--format", "csv", "-o", copy)
    assert result.exit_code == 2 and "is the same file as RESULTS" in result.stderr
    assert copy.read_bytes() == before


def test_a_service_answer_keeps_its_metadata(run, shift_lot, tmp_path):
    record = json.loads(shift_lot["jsonl"].read_text().splitlines()[0])
    answer = {**record, "id": "a" * 32, "received": "2026-12-04T06:00:00.000Z", "processing_ms": 80.0, "stored": True,
              "meta": {"part": "P7", "serial": "SN-9", "cell": None, "operator": None}}
    (tmp_path / "answers.jsonl").write_text(json.dumps(answer) + "\n")
    table = rows(run("report", tmp_path / "answers.jsonl", "--format", "csv").stdout)
    assert {(row["part"], row["serial"], row["label"], row["id"]) for row in table} == {("P7", "SN-9", "SN-9", "a" * 32)}


def test_the_scan_is_drawn_around_the_doubtful_holes_only(shift_lot, tmp_path):
    pytest.importorskip("matplotlib")
    from holecli.cli.report import read_results, scan_views
    from holecli.quality.lot import lot_from_records

    lot = lot_from_records(read_results(str(shift_lot["jsonl"])))
    views = scan_views(lot, 50)
    labels = {(lot.measurements[order].label, lot.measurements[order].record["holes"][index]["name"])
              for order, index in views}
    assert labels == {("part_002", "C1")}  # the oversize hole; the missing L1 has no hole to draw
    (view,) = views.values()
    assert view["png"].startswith(b"\x89PNG") and view["pixels_seen"] > 100
    assert scan_views(lot, 0) == {}


def test_a_scan_that_is_gone_is_said_so(shift_lot, tmp_path):
    from holecli.cli.report import scan_views
    from holecli.quality.lot import lot_from_records

    record = json.loads(shift_lot["jsonl"].read_text().splitlines()[1])  # part_002
    record["file"] = record["path"] = str(tmp_path / "gone.ply")
    lot = lot_from_records([{"record": record, "source": "x:1"}])
    (view,) = scan_views(lot, 5).values()
    assert view["unavailable"].startswith(f"the scan {tmp_path / 'gone.ply'} cannot be read now (")


def test_qif_features_stand_at_the_spec_s_nominals_when_the_spec_is_still_there(shift_lot, tmp_path, monkeypatch):
    from holecli.cli.report import lot_spec, read_results
    from holecli.quality.lot import lot_from_records

    lot = lot_from_records(read_results(str(shift_lot["jsonl"])))
    spec = lot_spec(lot)  # the records name the spec by its absolute path
    assert spec is not None and [hole.name for hole in spec.holes] == ["T1", "C1", "B1", "L1"]
    # the same path with other content: not the spec the records were checked against
    record = json.loads(shift_lot["jsonl"].read_text().splitlines()[0])
    changed = tmp_path / "spec.toml"
    with open(record["options"]["tolerances"]["spec_file"]) as original:
        changed.write_text(original.read() + "\n# edited\n")
    record["options"]["tolerances"]["spec_file"] = str(changed)
    assert lot_spec(lot_from_records([{"record": record, "source": "x:1"}])) is None
    record["options"]["tolerances"]["spec_file"] = str(tmp_path / "gone.toml")
    assert lot_spec(lot_from_records([{"record": record, "source": "x:1"}])) is None


def test_the_qif_the_command_writes_is_valid_qif_3(run, shift_lot, repo_root, tmp_path):
    etree = pytest.importorskip("lxml.etree")
    schema = etree.XMLSchema(etree.parse(str(repo_root / "tests" / "data" / "qif3" / "QIFApplications" /
                                             "QIFDocument.xsd")))
    output = tmp_path / "shift.qif"
    result = run("report", shift_lot["jsonl"], "-o", output, "--part-number", "PANEL-60")
    assert result.exit_code == 0, result.stderr
    document = etree.parse(str(output))
    assert schema.validate(document), schema.error_log
    statuses = document.getroot().findall(".//{http://qifstandards.org/xsd/qif3}CharacteristicStatusEnum")
    # part_003's missing L1: its presence FAIL, its diameter and position (checked on the others) NOT_ANALYZED
    assert {status.text for status in statuses} == {"PASS", "FAIL", "NOT_ANALYZED"}


def test_a_scan_not_measured_and_a_hole_not_checked_have_their_rows(run, shift_lot, repo_root, tmp_path):
    records = [json.loads(line) for line in shift_lot["jsonl"].read_text().splitlines()][:1]
    records.append({"file": "scans/broken.ply", "path": "/scans/broken.ply", "error": "scans/broken.ply: no points"})
    unchecked = json.loads(json.dumps(records[0]))
    unchecked.pop("verdict")
    for hole in unchecked["holes"]:
        for key in ("name", "conformance", "in_tolerance", "failed_checks", "undecided_checks"):
            hole.pop(key, None)
    unchecked["file"] = "scans/unchecked.ply"
    records.append(unchecked)
    (tmp_path / "mixed.jsonl").write_text("".join(json.dumps(record) + "\n" for record in records))
    table = rows(run("report", tmp_path / "mixed.jsonl", "--format", "csv").stdout)
    error = [row for row in table if row["label"] == "broken"]
    assert [(row["decision"], row["reason"]) for row in error] == [("error", "scans/broken.ply: no points")]
    plain = [row for row in table if row["label"] == "unchecked"]
    assert [row["hole"] for row in plain] == ["#0", "#1", "#2", "#3"]
    assert {(row["characteristic"], row["decision"]) for row in plain} == {("diameter", "unchecked")}
    assert float(plain[0]["measured"]) == unchecked["holes"][0]["diameter"]
    fai = rows(run("report", tmp_path / "mixed.jsonl", "--format", "fai").stdout)
    assert [row["results"] for row in fai if row["serial_number"] == "unchecked"] == [
        "not checked: the scan was measured without tolerances"]
    assert [row["results"] for row in fai if row["serial_number"] == "broken"] == [
        "not measured: scans/broken.ply: no points"]


def test_order_name_refuses_a_line_that_is_not_a_record_as_read_order_does(run, tmp_path):
    (tmp_path / "bad.jsonl").write_text('{"file": "a.ply", "holes": []}\n[1, 2]\n')
    for order in ("read", "name"):
        result = run("report", tmp_path / "bad.jsonl", "--order", order, "--format", "csv")
        assert result.exit_code == 3 and "bad.jsonl:2: a record is a JSON object, got list" in result.stderr


def test_lot_spec_refuses_a_spec_mapped_by_a_registration(shift_lot):
    from holecli.cli.report import lot_spec, read_results
    from holecli.quality.lot import lot_from_records

    entries = read_results(str(shift_lot["jsonl"]))
    entries[0]["record"]["options"]["tolerances"]["registration"] = {"file": "registration.json", "sha256": "0" * 64}
    assert lot_spec(lot_from_records(entries)) is None  # its nominals are in the part's frame, not the scan's


def test_a_postgresql_database_without_a_store_is_refused_and_left_empty(run, postgres_store_url):
    result = run("report", "--store", postgres_store_url)
    assert result.exit_code == 3 and "not a holecli results store (the database holds no tables of one)" in result.stderr
    import psycopg

    with psycopg.connect(postgres_store_url) as connection:
        tables = connection.execute("SELECT count(*) FROM information_schema.tables WHERE table_schema = "
                                    "current_schema()").fetchone()[0]
    assert tables == 0


def test_no_picture_of_a_scan_whose_unit_the_record_does_not_give(shift_lot):
    pytest.importorskip("matplotlib")
    from holecli.cli.report import scan_views
    from holecli.quality.lot import lot_from_records

    record = json.loads(shift_lot["jsonl"].read_text().splitlines()[1])  # part_002, its C1 oversize
    record["units"] = "in"  # as detect --units mm --output-units in writes it: the PLY declares nothing
    (view,) = scan_views(lot_from_records([{"record": record, "source": "x:1"}]), 5).values()
    assert view == {"unavailable": f"the record is in in and the scan {record['file']} declares no unit: the unit "
                                   f"of its points is not known"}
