"""Warnings of a doubtful result on the command line: stderr lines, --quiet, --fail-on-warning and its
exit code 7, batch's summary; the notes (why a value is null, issue 24) apart from them."""

import csv
import io
import json

import pytest

from holecli.cli.exits import BATCH_EXIT_CODES_HELP, EXIT_CODES_HELP, EXIT_WARNING

REFLECTIONS = "sample_clouds/table1_inside100.csv"  # 100 reflections in the hole: points_inside
CLEAN = "sample_clouds/table1.ply"


@pytest.fixture
def samples(repo_root):
    return repo_root / REFLECTIONS, repo_root / CLEAN


def test_detect_says_each_doubt_on_stderr(run, samples):
    result = run("detect", samples[0])
    assert result.exit_code == 0
    lines = [line for line in result.stderr.splitlines() if line.startswith("holecli: warning:")]
    assert len(lines) == 1
    assert lines[0].startswith(f"holecli: warning: {samples[0]} hole 0: points_inside: surface points inside")
    record = json.loads(result.stdout)
    assert [w["code"] for w in record["holes"][0]["warnings"]] == ["points_inside"]
    # the notes, which say why a value is null, are in the record (and with -v on stderr), not warnings
    assert [n["code"] for n in record["holes"][0]["notes"]] == ["bore_not_seen", "axis_not_measured"]
    assert "bore_not_seen" not in result.stderr


def test_quiet_says_no_warning(run, samples):
    result = run("detect", samples[0], "-q")
    assert result.exit_code == 0 and result.stderr == ""


def test_clean_scan_says_nothing(run, samples):
    result = run("detect", samples[1])
    assert result.exit_code == 0 and "warning" not in result.stderr


@pytest.mark.parametrize("codes, code", [
    ("points_inside", EXIT_WARNING), ("doubts", EXIT_WARNING), ("any", EXIT_WARNING),
    ("rim_gap,near_border", 0), ("bore_not_cylindrical", 0),
])
def test_fail_on_warning(run, samples, codes, code):
    result = run("detect", samples[0], "-q", "--fail-on-warning", codes)
    assert result.exit_code == code
    assert json.loads(result.stdout)["holes"]  # the record is still printed


def test_fail_on_warning_on_a_clean_scan(run, samples):
    assert run("detect", samples[1], "--fail-on-warning", "doubts").exit_code == 0
    # a scan straight down the bore: no warning, its bore and axis not measured are notes
    result = run("detect", samples[1], "--fail-on-warning", "any")
    assert result.exit_code == 0 and result.stderr == ""
    [hole] = json.loads(result.stdout)["holes"]
    assert hole["warnings"] == [] and hole["bore"]["diameter"] is None and hole["axis"] is None
    assert [n["code"] for n in hole["notes"]] == ["bore_not_seen", "axis_not_measured"]


@pytest.mark.parametrize("seed, options", [
    (11, ["--noise-z", "0.005"]),
    (12, ["--pattern", "stripes", "--spacing", "0.05", "--line-pitch", "0.15", "--hole", "0,0,3", "--hole", "5,0,4",
          "--extent", "-3,8,-3,3"]),
    (13, ["--pattern", "random"]),
    (14, ["--panel", "sample_clouds/panel.toml", "--spacing", "0.1", "--range-noise", "0.005"]),
])
def test_fail_on_warning_any_passes_clean_straight_down_simulated_scans(run, repo_root, tmp_path, monkeypatch,
                                                                          seed, options):
    # holecli's own simulators, straight down: no bore wall, no through hole's axis. Notes, no warning.
    monkeypatch.chdir(repo_root)
    scan = tmp_path / "scan.ply"
    assert run("simulate", scan, "-q", "--seed", seed, *options).exit_code == 0
    result = run("detect", scan, "--fail-on-warning", "any")
    assert result.exit_code == 0 and result.stderr == ""
    holes = json.loads(result.stdout)["holes"]
    assert holes and all(hole["warnings"] == [] for hole in holes)
    assert all("bore_not_seen" in [note["code"] for note in hole["notes"]] for hole in holes)
    assert any(note["code"] == "axis_not_measured" for hole in holes for note in hole["notes"])


@pytest.mark.parametrize("codes", ["bore_not_seen", "rim_gap,axis_not_measured", "gauge_depth_outside_cone"])
def test_fail_on_warning_refuses_a_note(run, samples, codes):
    # a note never fails a run: naming one is a usage error, not a check that silently passes
    result = run("detect", samples[1], "--fail-on-warning", codes)
    assert result.exit_code == 2 and result.stdout == ""
    assert "a note (why a value is null), not a warning" in result.stderr


def test_verbose_says_the_notes(run, samples):
    result = run("detect", samples[1], "-v")
    assert result.exit_code == 0
    assert "holecli:   hole 0 note: bore_not_seen: too few points on the bore wall" in result.stderr
    assert "holecli:   hole 0 note: axis_not_measured: " in result.stderr
    assert "holecli: warning:" not in result.stderr


def test_the_table_gives_warnings_and_notes(run, samples):
    result = run("detect", samples[0], "--format", "table")
    below = result.stdout[result.stdout.index("below the edge"):]
    header = next(line for line in below.splitlines() if "warnings" in line)
    assert header.index("warnings") < header.index("notes")
    assert "points_inside" in below and "bore_not_seen" in below


def test_fail_on_warning_unknown_code_is_a_usage_error(run, samples):
    result = run("detect", samples[1], "--fail-on-warning", "rim_gapp")
    assert result.exit_code == 2 and "rim_gapp: not a warning code" in result.stderr


def test_out_of_tolerance_comes_before_a_warning(run, samples):
    result = run("detect", samples[0], "-q", "--fail-on-warning", "any", "--nominal-diameter", "5",
                 "--tolerance", "0.01")
    assert result.exit_code == 5


def test_batch_counts_doubtful_holes_and_fails_on_warning(run, samples, tmp_path):
    output = tmp_path / "out.jsonl"
    result = run("batch", *samples, "-o", output)
    assert result.exit_code == 0
    assert "1 doubtful hole (points_inside 1)" in result.stderr
    assert "holecli: warning:" not in result.stderr
    assert run("batch", *samples, "-o", tmp_path / "b.jsonl", "--fail-on-warning", "points_inside").exit_code == 7
    assert run("batch", samples[1], "-o", tmp_path / "c.jsonl", "--fail-on-warning", "doubts").exit_code == 0
    assert run("batch", samples[1], "-o", tmp_path / "d.jsonl", "--fail-on-warning", "any").exit_code == 0
    # a resumed batch counts the earlier records' warnings too
    resumed = run("batch", *samples, "-o", output, "--resume", "--fail-on-warning", "points_inside")
    assert resumed.exit_code == 7 and "1 doubtful hole" in resumed.stderr


def test_batch_resume_of_records_before_schema_2_2_takes_no_note_for_a_warning(run, samples, tmp_path):
    # schema 2.1 gave bore_not_seen and axis_not_measured as warnings: resumed, they are no doubt
    output = tmp_path / "old.jsonl"
    assert run("batch", samples[1], "-o", output).exit_code == 0
    record = json.loads(output.read_text())
    hole = record["holes"][0]
    hole["warnings"], record["schema_version"] = hole.pop("notes"), "2.1"
    output.write_text(json.dumps(record) + "\n")
    resumed = run("batch", *samples, "-o", output, "--resume", "--fail-on-warning", "any")
    assert resumed.exit_code == 7 and "1 doubtful hole (points_inside 1)" in resumed.stderr
    assert run("batch", samples[1], "-o", output, "--resume", "--fail-on-warning", "any").exit_code == 7
    only_old = tmp_path / "only_old.jsonl"
    only_old.write_text(json.dumps(record) + "\n")
    assert run("batch", samples[1], "-o", only_old, "--resume", "--fail-on-warning", "any").exit_code == 0


def test_batch_csv_resume_refuses_a_csv_without_the_notes_column(run, samples, tmp_path):
    from holecli.report import BATCH_CSV_COLUMNS

    output = tmp_path / "out.csv"
    assert run("batch", samples[1], "--format", "csv", "-o", output).exit_code == 0
    rows = list(csv.reader(io.StringIO(output.read_text())))
    notes = BATCH_CSV_COLUMNS.index("notes")
    assert rows[1][notes] == "bore_not_seen;axis_not_measured" and rows[1][BATCH_CSV_COLUMNS.index("warnings")] == ""
    # a 2.1 CSV: no notes column, nor the later u_* ones (issue 25), then error and path
    output.write_text("".join(",".join(row[:notes] + row[-2:]) + "\n" for row in rows))
    resumed = run("batch", samples[1], "--format", "csv", "-o", output, "--resume")
    assert resumed.exit_code == 3
    assert "written before schema 2.2, without the notes column" in resumed.stderr


def test_batch_csv_resume_reads_the_warnings_column(run, samples, tmp_path):
    output = tmp_path / "out.csv"
    assert run("batch", *samples, "--format", "csv", "-o", output).exit_code == 0
    resumed = run("batch", *samples, "--format", "csv", "-o", output, "--resume", "--fail-on-warning", "doubts")
    assert resumed.exit_code == 7


def test_exit_code_7_is_documented(repo_root):
    assert "  7  --fail-on-warning" in EXIT_CODES_HELP
    assert "  7    --fail-on-warning" in BATCH_EXIT_CODES_HELP
    exit_codes = (repo_root / "docs" / "reference" / "exit-codes.md").read_text(encoding="utf-8")
    assert "| 7 | `--fail-on-warning`" in exit_codes
