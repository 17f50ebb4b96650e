"""Warnings of a doubtful result on the command line: stderr lines, --quiet, --fail-on-warning and its
exit code 7, batch's summary."""

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
    assert "points_inside" in [w["code"] for w in record["holes"][0]["warnings"]]
    # the warnings that say why a value is null stay in the record
    assert "bore_not_seen" not in result.stderr


def test_quiet_says_no_warning(run, samples):
    result = run("detect", samples[0], "-q")
    assert result.exit_code == 0 and result.stderr == ""


def test_clean_scan_says_nothing(run, samples):
    result = run("detect", samples[1])
    assert result.exit_code == 0 and "warning" not in result.stderr


@pytest.mark.parametrize("codes, code", [
    ("points_inside", EXIT_WARNING), ("doubts", EXIT_WARNING), ("any", EXIT_WARNING),
    ("rim_gap,near_border", 0), ("bore_not_seen", EXIT_WARNING),
])
def test_fail_on_warning(run, samples, codes, code):
    result = run("detect", samples[0], "-q", "--fail-on-warning", codes)
    assert result.exit_code == code
    assert json.loads(result.stdout)["holes"]  # the record is still printed


def test_fail_on_warning_on_a_clean_scan(run, samples):
    assert run("detect", samples[1], "--fail-on-warning", "doubts").exit_code == 0
    # bore_not_seen is a warning too (a scan straight down the bore)
    assert run("detect", samples[1], "--fail-on-warning", "any").exit_code == EXIT_WARNING


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
    # a resumed batch counts the earlier records' warnings too
    resumed = run("batch", *samples, "-o", output, "--resume", "--fail-on-warning", "points_inside")
    assert resumed.exit_code == 7 and "1 doubtful hole" in resumed.stderr


def test_batch_csv_resume_reads_the_warnings_column(run, samples, tmp_path):
    output = tmp_path / "out.csv"
    assert run("batch", *samples, "--format", "csv", "-o", output).exit_code == 0
    resumed = run("batch", *samples, "--format", "csv", "-o", output, "--resume", "--fail-on-warning", "doubts")
    assert resumed.exit_code == 7


def test_exit_code_7_is_documented(repo_root):
    assert "  7  --fail-on-warning" in EXIT_CODES_HELP
    assert "  7    --fail-on-warning" in BATCH_EXIT_CODES_HELP
    assert "| 7 | `--fail-on-warning`" in (repo_root / "README.md").read_text(encoding="utf-8")
