"""Tests of the command line's batch mode and tolerance verdicts: records, formats, exit codes, spec files,
interruption and resume of a real process."""

import csv
import io
import json
import re
import math
import os
import shutil
import signal
import stat
import subprocess
import sys
import time

import pytest

from holecli import cli, report
from holecli.io import save_points
from holecli.simulation import synth

RECORD_KEYS = {"schema_version", "holecli_version", "file", "points", "dropped_points", "input_columns", "method", "options", "scales",
               "candidates", "plane", "holes", "timing"}
BATCH_RECORD_KEYS = RECORD_KEYS | {"path"}
VERDICT_HOLE_KEYS = {"diameter_deviation", "position_deviation", "tilt_deg", "countersink_diameter_deviation",
                     "countersink_angle_deviation", "countersink_depth_deviation", "bore_diameter_deviation",
                     "in_tolerance", "failed_checks", "undecided_checks", "conformance"}

# What the verdict says of the default decision rule.
SIMPLE_VERDICT = {"undecided": 0, "decision_rule": "simple", "coverage_factor": 2.0}


def _scan(seed, holes=((0.0, 0.0, 2.5),), extent=(-2.8, 2.8, -2.8, 2.8)):
    """About 3,000 points on a 0.1 mm grid: quick to measure. Returns the synthetic scan."""
    scene = synth.SceneSpec(holes=tuple(synth.HoleSpec(center=(x, y), diameter=d) for x, y, d in holes),
                            extent=extent, spacing=0.1, rotation_deg=(10.0, 5.0, 7.0 * seed),
                            translation=(seed, 2.0, 3.0))
    return synth.make_scan(scene, seed)


def _broken_files(folder):
    """A truncated binary PLY, an empty CSV and a PLY that is only a header."""
    truncated = folder / "truncated.ply"
    save_points(truncated, _scan(9).points)
    data = truncated.read_bytes()
    truncated.write_bytes(data[: len(data) - 500])
    (folder / "empty.csv").write_text("")
    (folder / "header_only.ply").write_text("ply\nformat binary_little_endian 1.0\nelement vertex 2000\n"
                                            "property double x\nproperty double y\nproperty double z\nend_header\n")
    return [folder / "truncated.ply", folder / "empty.csv", folder / "header_only.ply"]


@pytest.fixture(scope="module")
def good_scans(tmp_path_factory):
    """Three scans with one 2.5 mm hole: {path: truth hole}."""
    folder = tmp_path_factory.mktemp("good")
    scans = {}
    for seed, extension in enumerate((".ply", ".csv", ".pcd")):
        scan = _scan(seed)
        path = folder / f"scan{seed}{extension}"
        save_points(path, scan.points)
        scans[path] = scan.truth["holes"][0]
    return scans


@pytest.fixture
def mixed(tmp_path, good_scans):
    """A folder with the good scans, the broken files and a file holecli skips."""
    for path in good_scans:
        shutil.copy(path, tmp_path / path.name)
    broken = _broken_files(tmp_path)
    (tmp_path / "notes.md").write_text("not a cloud\n")
    return tmp_path, [tmp_path / path.name for path in good_scans], broken



def _lines(text):
    return [json.loads(line) for line in text.splitlines()]


def _without_time(record):
    return {key: value for key, value in record.items() if key != "timing"}


# --- batch: records ----------------------------------------------------------------------------------


def test_batch_jsonl_one_record_per_file_broken_files_included(run, mixed):
    folder, good, broken = mixed
    result = run("batch", folder, "--jobs", "2")
    assert result.exit_code == cli.EXIT_FILE_FAILED, result.stderr
    records = _lines(result.stdout)
    assert sorted(record["file"] for record in records) == sorted(str(path) for path in good + broken)
    by_file = {record["file"]: record for record in records}
    for path in good:
        record = by_file[str(path)]
        assert set(record) == BATCH_RECORD_KEYS
        assert record["path"] == os.path.realpath(path)
        assert len(record["holes"]) == 1 and record["holes"][0]["diameter"] == pytest.approx(2.5, abs=0.05)
        # exactly the detect record, and the resolved path
        detected = json.loads(run("detect", path).stdout)
        assert _without_time(record) == dict(_without_time(detected), path=os.path.realpath(path))
    for path in broken:
        record = by_file[str(path)]
        assert set(record) == {"schema_version", "holecli_version", "file", "path", "error"}
        detected = run("detect", path)
        assert detected.exit_code == cli.EXIT_INPUT
        assert record["error"] == detected.stderr.strip().removeprefix("Error: ")
    # stderr: each failure and the summary; no traceback
    assert "Traceback" not in result.stderr
    assert result.stderr.count("holecli: failed: ") == 3
    summary = result.stderr.strip().splitlines()[-1]
    assert "6 files: 3 measured, 3 failed; 3 holes found" in summary
    assert "tolerances not checked" in summary


def test_batch_csv_header_once_one_row_per_hole_or_failure(run, mixed, tmp_path):
    folder, good, broken = mixed
    no_hole = folder / "plain.csv"
    save_points(no_hole, _scan(5, holes=()).points)
    two = folder / "two.ply"
    save_points(two, _scan(6, holes=((-2.0, 0.0, 1.5), (2.0, 0.0, 1.5)), extent=(-4, 4, -2.5, 2.5)).points)
    result = run("batch", folder, "--format", "csv", "--jobs", "1")
    assert result.exit_code == cli.EXIT_FILE_FAILED, result.stderr
    rows = list(csv.reader(io.StringIO(result.stdout)))
    assert rows[0] == list(report.BATCH_CSV_COLUMNS) == [*report.CSV_COLUMNS, "error", "path"]
    assert list(report.BATCH_CSV_COLUMNS) not in rows[1:]
    rows = [dict(zip(rows[0], row)) for row in rows[1:]]
    by_file = {}
    for row in rows:
        by_file.setdefault(row["file"], []).append(row)
    assert len(by_file) == 8
    assert [row["hole"] for row in by_file[str(two)]] == ["0", "1"]
    assert [(row["hole"], row["error"]) for row in by_file[str(no_hole)]] == [("", "")]
    for path in broken:
        (row,) = by_file[str(path)]
        assert row["error"].startswith(f"{path}: ")
        assert row["hole"] == "" and row["diameter"] == ""


def test_batch_output_file_and_a_file_given_twice(run, mixed, tmp_path):
    folder, good, _ = mixed
    target = folder / "results.jsonl"
    result = run("batch", good[0], folder, good[0], "--output", target)
    assert result.stdout == ""
    files = [record["file"] for record in _lines(target.read_text())]
    assert len(files) == len(set(files)) == 6  # the output file itself is not measured
    assert str(target) not in files


def test_batch_recursive_and_pattern(run, tmp_path, good_scans):
    first, second, third = good_scans
    (tmp_path / "cell" / "deep").mkdir(parents=True)
    shutil.copy(first, tmp_path / "part7_a.ply")
    shutil.copy(second, tmp_path / "cell" / "part7_b.csv")
    shutil.copy(third, tmp_path / "cell" / "deep" / "other.pcd")
    flat = _lines(run("batch", tmp_path).stdout)
    assert [record["file"] for record in flat] == [str(tmp_path / "part7_a.ply")]
    deep = _lines(run("batch", tmp_path, "--recursive").stdout)
    assert len(deep) == 3
    matched = _lines(run("batch", tmp_path, "-r", "--pattern", "PART7_*").stdout)
    assert sorted(record["file"] for record in matched) == [str(tmp_path / "cell" / "part7_b.csv"),
                                                             str(tmp_path / "part7_a.ply")]


# --- batch: exit codes -------------------------------------------------------------------------------


def test_batch_exit_0_every_file_measured(run, good_scans):
    result = run("batch", *good_scans, "--jobs", "2")
    assert result.exit_code == cli.EXIT_OK, result.stderr
    assert len(_lines(result.stdout)) == 3


def test_batch_exit_4_a_file_without_a_hole(run, good_scans, tmp_path):
    plain = tmp_path / "plain.ply"
    save_points(plain, _scan(5, holes=()).points)
    result = run("batch", *good_scans, plain)
    assert result.exit_code == cli.EXIT_NO_HOLE, result.stderr
    assert "1 file without a hole" in result.stderr


def test_batch_exit_5_out_of_tolerance_over_6_and_4(run, good_scans, tmp_path):
    plain = tmp_path / "plain.ply"
    save_points(plain, _scan(5, holes=()).points)
    (tmp_path / "empty.csv").write_text("")
    files = [*good_scans, plain, tmp_path / "empty.csv"]
    result = run("batch", *files, "--nominal-diameter", "2.5", "--tolerance", "0.1")
    # a file without a hole fails the verdict (its nominal is missing): 5 before 6 and 4
    assert result.exit_code == cli.EXIT_OUT_OF_TOLERANCE, result.stderr
    records = {record["file"]: record for record in _lines(result.stdout)}
    assert records[str(plain)]["verdict"] == {"checked": 0, "out_of_tolerance": 0, "missing": [None],
                                              "in_tolerance": False, **SIMPLE_VERDICT}
    assert all(records[str(path)]["verdict"]["in_tolerance"] for path in good_scans)
    # the part without a hole is rejected, and its hole counted as missing (not as out of tolerance)
    assert "parts rejected: 1 of 4; holes out of tolerance: 0, nominal holes missing: 1" in result.stderr
    result = run("batch", *good_scans, "--nominal-diameter", "2.0", "--tolerance", "0.1")
    assert result.exit_code == cli.EXIT_OUT_OF_TOLERANCE
    assert "parts rejected: 3 of 3; holes out of tolerance: 3, nominal holes missing: 0" in result.stderr


def test_batch_exit_6_failed_before_4_no_hole(run, good_scans, tmp_path):
    plain = tmp_path / "plain.ply"
    save_points(plain, _scan(5, holes=()).points)
    (tmp_path / "empty.csv").write_text("")
    result = run("batch", *good_scans, plain, tmp_path / "empty.csv")
    assert result.exit_code == cli.EXIT_FILE_FAILED
    result = run("batch", *good_scans, tmp_path / "empty.csv", "--nominal-diameter", "2.5", "--tolerance", "0.1")
    assert result.exit_code == cli.EXIT_FILE_FAILED  # in tolerance, but a file failed


@pytest.mark.parametrize(
    "args, message",
    [
        (["{folder}/missing"], "missing: no such file or folder"),
        (["{empty}"], "no point-cloud files (.ply, .pcd, .csv, .txt, .xyz, .e57, .las, .laz) found"),
        (["{folder}", "--pattern", "zzz*"], "matching 'zzz*' found"),
        (["{folder}", "--spec", "{folder}/missing.toml"], "missing.toml: cannot read: No such file or directory"),
        (["{folder}", "--output", "{folder}/no/such/out.jsonl"], "cannot write output"),
    ],
)
def test_batch_exit_3_input_errors(run, mixed, tmp_path_factory, args, message):
    folder, _, _ = mixed
    empty = tmp_path_factory.mktemp("empty")
    result = run("batch", *(arg.format(folder=folder, empty=empty) for arg in args))
    assert result.exit_code == cli.EXIT_INPUT, result.stderr
    assert result.stdout == ""
    assert result.stderr.count("\n") == 1 and result.stderr.startswith("Error: ")
    assert message in result.stderr


@pytest.mark.parametrize(
    "args, message",
    [
        (["--resume"], "--resume needs --output"),
        (["--spec", "x.toml", "--nominal-diameter", "3", "--tolerance", "0.1"],
         "--spec cannot be combined with --nominal-diameter, --tolerance"),
        (["--tolerance", "0.1"], "--tolerance needs --nominal-diameter"),
        (["--jobs", "0"], "--jobs"),
        (["--format", "table"], "--format"),  # (json is taken for JSON Lines)
    ],
)
def test_batch_usage_errors_exit_2(run, good_scans, args, message):
    result = run("batch", next(iter(good_scans)), *args)
    assert result.exit_code == cli.EXIT_USAGE
    assert result.stdout == ""
    assert message in result.stderr


def test_batch_help_documents_exit_codes_and_imports_nothing_heavy(repo_root):
    code = (
        "import sys\n"
        "import holecli.cli\n"
        "try:\n"
        "    holecli.cli.main(['batch', '--help'])\n"
        "except SystemExit:\n"
        "    pass\n"
        "print(sorted(name for name in ('open3d', 'scipy', 'rich') if name in sys.modules), file=sys.stderr)\n"
    )
    env = dict(os.environ, PYTHONPATH=str(repo_root))
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, cwd=repo_root,
                            timeout=60)
    assert result.stderr.strip().splitlines()[-1] == "[]"
    for line in ("130", "  3 ", "  5 ", "  6 ", "  4 ", "  0 ", "the first that applies"):
        assert line in result.stdout


# --- tolerance verdicts on detect ----------------------------------------------------------------------


@pytest.fixture(scope="module")
def one_scan(good_scans):
    path, truth = next(iter(good_scans.items()))
    return path, truth


def _detect(run, path, *options):
    result = run("detect", path, *options)
    return result, json.loads(result.stdout) if result.stdout else None


def test_detect_without_tolerance_options_is_unchanged(run, one_scan):
    result, record = _detect(run, one_scan[0])
    assert result.exit_code == cli.EXIT_OK
    assert set(record) == RECORD_KEYS
    assert not VERDICT_HOLE_KEYS & set(record["holes"][0])


@pytest.mark.parametrize(
    "tolerance, offset, in_tolerance",
    [
        ("0.1", 0.0, True),
        ("0.1", 0.3, False),
        ("+0.2/-0", -0.1, True),  # measured 2.5 against a nominal 2.4
        ("+0.2/0", 0.1, False),  # measured 2.5 against a nominal 2.6: below the lower deviation 0
        ("0.05/-0.3", 0.2, True),
        ("±0.1", -0.3, False),
        ("-0.1/-0.3", 0.2, True),  # nominal 2.7, measured 2.5: deviation -0.2
    ],
)
def test_detect_diameter_tolerance_forms_and_exit_codes(run, one_scan, tolerance, offset, in_tolerance):
    path, truth = one_scan
    nominal = truth["diameter"] + offset
    result, record = _detect(run, path, "--nominal-diameter", nominal, "--tolerance", tolerance)
    assert result.exit_code == (cli.EXIT_OK if in_tolerance else cli.EXIT_OUT_OF_TOLERANCE), result.stderr
    hole = record["holes"][0]
    assert VERDICT_HOLE_KEYS <= set(hole) and "name" not in hole
    assert hole["diameter_deviation"] == pytest.approx(hole["diameter"] - nominal, abs=1e-12)
    assert hole["in_tolerance"] is in_tolerance
    assert record["verdict"] == {"checked": 1, "out_of_tolerance": 0 if in_tolerance else 1, "missing": [],
                                 "in_tolerance": in_tolerance, **SIMPLE_VERDICT}
    assert ("out of tolerance" in result.stderr) is not in_tolerance


def test_detect_position_and_tilt(run, one_scan):
    path, truth = one_scan
    center = ",".join(str(value) for value in truth["center"])
    normal = ",".join(str(-value) for value in truth["normal"])  # the sign does not matter
    result, record = _detect(run, path, "--nominal-center", center, "--position-tolerance", "0.05",
                             "--nominal-normal", normal, "--max-tilt", "0.5")
    assert result.exit_code == cli.EXIT_OK, result.stderr
    hole = record["holes"][0]
    assert hole["position_deviation"]["in_plane"] < 0.05
    assert abs(hole["position_deviation"]["along_normal"]) < 0.01
    assert hole["tilt_deg"] < 0.5
    assert hole["diameter_deviation"] is None
    shifted = ",".join(str(value + 0.3) for value in truth["center"])
    result, record = _detect(run, path, "--nominal-center", shifted, "--position-tolerance", "0.05")
    assert result.exit_code == cli.EXIT_OUT_OF_TOLERANCE
    assert record["holes"][0]["failed_checks"] == ["position"]


def test_detect_table_and_csv_show_the_verdicts(run, one_scan):
    path, truth = one_scan
    options = ["--nominal-diameter", truth["diameter"], "--tolerance", "0.1"]
    result = run("detect", path, "--format", "table", *options)
    assert result.exit_code == cli.EXIT_OK
    assert "IN TOLERANCE" in result.stdout
    result = run("detect", path, "--format", "csv", *options)
    rows = list(csv.DictReader(io.StringIO(result.stdout)))
    assert rows[0]["in_tolerance"] == "true" and rows[0]["failed_checks"] == ""
    assert float(rows[0]["diameter_deviation"]) == pytest.approx(float(rows[0]["diameter"]) - truth["diameter"])


@pytest.mark.parametrize(
    "options, message",
    [
        (["--tolerance", "0.1"], "--tolerance needs --nominal-diameter"),
        (["--nominal-diameter", "3"], "--nominal-diameter needs --tolerance"),
        (["--position-tolerance", "0.1"], "--position-tolerance needs --nominal-center"),
        (["--max-tilt", "1"], "--max-tilt needs --nominal-normal"),
        (["--nominal-center", "0,0,0"], "give a tolerance"),
        (["--nominal-diameter", "3", "--tolerance", "-0.1"], "symmetric tolerance must be a number >= 0"),
        (["--nominal-diameter", "3", "--tolerance", "0.1/0.1"], "with its sign"),
        (["--nominal-diameter", "-3", "--tolerance", "0.1"], "--nominal-diameter"),
        (["--nominal-normal", "0,0,0", "--max-tilt", "1"], "--nominal-normal must not be the zero vector"),
        (["--nominal-normal", "0,0,1", "--max-tilt", "95"], "--max-tilt"),
        (["--spec", "part.toml", "--max-tilt", "1"], "--spec cannot be combined with --max-tilt"),
    ],
)
def test_detect_tolerance_option_errors_exit_2(run, one_scan, options, message):
    result = run("detect", one_scan[0], *options)
    assert result.exit_code == cli.EXIT_USAGE, result.stderr
    assert result.stdout == ""
    assert message in result.stderr
    assert "Traceback" not in result.stderr


# --- spec files ------------------------------------------------------------------------------------


def _spec_text(holes):
    tables = []
    for name, center, diameter, extra in holes:
        tables.append(f'[[hole]]\nname = "{name}"\ncenter = [{", ".join(map(str, center))}]\n'
                      f"diameter = {diameter}\ntolerance = \"+0.1/-0.1\"\n{extra}")
    return "\n".join(tables)


def test_detect_spec_matching_missing_and_extra(run, tmp_path):
    scan = _scan(4, holes=((-2.0, 0.0, 1.5), (2.0, 0.0, 1.5)), extent=(-4, 4, -2.5, 2.5))
    path = tmp_path / "two.ply"
    save_points(path, scan.points)
    left, right = scan.truth["holes"]
    spec = tmp_path / "part.toml"
    far = [c + 20.0 for c in left["center"]]
    spec.write_text(_spec_text([("L", left["center"], 1.5, "position_tolerance = 0.05\n"), ("FAR", far, 1.5, "")]))
    result, record = _detect(run, path, "--spec", spec)
    assert result.exit_code == cli.EXIT_OUT_OF_TOLERANCE, result.stderr
    names = {tuple(round(c, 1) for c in hole["center"]): hole["name"] for hole in record["holes"]}
    assert names[tuple(round(c, 1) for c in left["center"])] == "L"
    assert names[tuple(round(c, 1) for c in right["center"])] is None  # measured, no nominal: reported
    assert record["verdict"] == {"checked": 1, "out_of_tolerance": 0, "missing": ["FAR"], "in_tolerance": False,
                                 **SIMPLE_VERDICT}
    assert "missing: FAR" in result.stderr
    # every nominal matched: in tolerance, the extra measured hole does not fail the verdict
    spec.write_text(_spec_text([("L", left["center"], 1.5, "")]))
    result, record = _detect(run, path, "--spec", spec, "--format", "json")
    assert result.exit_code == cli.EXIT_OK, result.stderr
    assert record["verdict"]["in_tolerance"] is True
    # the same spec in a batch, CSV
    result = run("batch", path, "--spec", spec, "--format", "csv")
    rows = list(csv.DictReader(io.StringIO(result.stdout)))
    assert sorted(row["name"] for row in rows) == ["", "L"]


def test_a_spec_far_from_every_measured_hole_says_how_far(run, tmp_path):
    """Issue 25: a scan in the robot's frame against the part's spec reported every hole missing with no
    hint; the line now gives the nearest distance and names the likely cause. Not when one is matched."""
    scan = _scan(4, holes=((-2.0, 0.0, 1.5), (2.0, 0.0, 1.5)), extent=(-4, 4, -2.5, 2.5))
    path = tmp_path / "two.ply"
    save_points(path, scan.points)
    left, _ = scan.truth["holes"]
    spec = tmp_path / "part.toml"
    spec.write_text(_spec_text([("A", [c + 500.0 for c in left["center"]], 1.5, ""),
                                ("B", [c + 700.0 for c in left["center"]], 1.5, "")]))
    result, _ = _detect(run, path, "--spec", spec)
    assert result.exit_code == cli.EXIT_OUT_OF_TOLERANCE
    assert "missing: A, B" in result.stderr and re.search(r"the nearest is 86\d(\.\d)? from A", result.stderr)
    assert "same frame and unit" in result.stderr
    spec.write_text(_spec_text([("L", left["center"], 1.5, ""), ("B", [c + 700.0 for c in left["center"]], 1.5, "")]))
    result, _ = _detect(run, path, "--spec", spec)
    assert "missing: B" in result.stderr and "nearest" not in result.stderr


def test_batch_spec_missing_holes_are_csv_rows(run, tmp_path, good_scans):
    path, truth = next(iter(good_scans.items()))
    spec = tmp_path / "part.toml"
    spec.write_text(_spec_text([("A", truth["center"], 2.5, ""), ("B", [c + 30 for c in truth["center"]], 2.5, "")]))
    result = run("batch", path, "--spec", spec, "--format", "csv")
    assert result.exit_code == cli.EXIT_OUT_OF_TOLERANCE
    rows = list(csv.DictReader(io.StringIO(result.stdout)))
    assert [(row["hole"], row["name"], row["in_tolerance"]) for row in rows] == [("0", "A", "true"),
                                                                                 ("", "B", "false")]


@pytest.mark.parametrize(
    "text, message",
    [
        ("[[hole]\n", "invalid TOML"),
        ('[[hole]]\nname = "A"\ncenter = [0, 0, 0]\ndiameter = 3\n', "hole 1 ('A'): missing key 'tolerance'"),
        ('[[hole]]\nname = "A"\ncenter = [0, 0, 0]\ndiameter = 3\ntolerance = -0.1\n',
         "hole 1 ('A'): tolerance: a symmetric tolerance must be a number >= 0"),
        ('[[hole]]\nname = "A"\ncenter = [0, 0]\ndiameter = 3\ntolerance = 0.1\n', "center must be 3 finite numbers"),
        (b"\xff\xfe", "not a UTF-8 text file"),
    ],
)
@pytest.mark.parametrize("command", ["detect", "batch"])
def test_bad_spec_file_is_a_one_line_input_error(run, tmp_path, one_scan, text, message, command):
    spec = tmp_path / "part.toml"
    if isinstance(text, bytes):
        spec.write_bytes(text)
    else:
        spec.write_text(text)
    result = run(command, one_scan[0], "--spec", spec)
    assert result.exit_code == cli.EXIT_INPUT, result.stderr
    assert result.stdout == ""
    assert result.stderr.startswith(f"Error: {spec}: ") and result.stderr.count("\n") == 1
    assert message in result.stderr


def test_spec_file_that_is_a_folder(run, tmp_path, one_scan):
    result = run("detect", one_scan[0], "--spec", tmp_path)
    assert result.exit_code == cli.EXIT_INPUT
    assert result.stderr == f"Error: {tmp_path}: not a regular file (a folder): a spec must be a TOML file\n"


# --- resume (in process) -------------------------------------------------------------------------------


@pytest.mark.parametrize("fmt", ["jsonl", "csv"])
def test_resume_skips_the_files_done_and_keeps_one_header(run, mixed, tmp_path_factory, fmt):
    folder, good, broken = mixed
    target = tmp_path_factory.mktemp("out") / f"out.{fmt}"
    first = run("batch", good[0], broken[0], "--format", fmt, "-o", target)
    assert first.exit_code == cli.EXIT_FILE_FAILED
    with open(target, "a") as stream:
        stream.write('{"file": "half' if fmt == "jsonl" else "half,written")  # a run stopped mid-line
    result = run("batch", folder, "--format", fmt, "-o", target, "--resume")
    assert result.exit_code == cli.EXIT_FILE_FAILED, result.stderr
    assert "(2 files from the earlier run in" in result.stderr
    text = target.read_text()
    assert "half" not in text
    if fmt == "jsonl":
        files = [record["file"] for record in _lines(text)]
    else:
        rows = list(csv.reader(io.StringIO(text)))
        assert rows.count(list(report.BATCH_CSV_COLUMNS)) == 1 and rows[0] == list(report.BATCH_CSV_COLUMNS)
        files = [row[0] for row in rows[1:]]
    assert sorted(files) == sorted(str(path) for path in good + broken)
    # nothing left: the exit code still tells about the earlier records
    again = run("batch", folder, "--format", fmt, "-o", target, "--resume")
    assert again.exit_code == cli.EXIT_FILE_FAILED
    assert target.read_text() == text


def test_resume_refuses_a_file_of_another_kind(run, good_scans, tmp_path):
    target = tmp_path / "out.jsonl"
    target.write_text("file,hole\n")
    result = run("batch", *good_scans, "-o", target, "--resume")
    assert result.exit_code == cli.EXIT_INPUT
    assert "cannot resume: line 1 is not a holecli batch record" in result.stderr
    assert target.read_text() == "file,hole\n"


@pytest.mark.parametrize("fmt", ["jsonl", "csv"])
@pytest.mark.parametrize("changed, named", [
    (("--nominal-diameter", "2.5", "--tolerance", "0.2"), 'the tolerance options (--nominal-diameter, --tolerance, '
                                                          '...): {"band":{"lower":-0.1,"upper":0.1}} there, '
                                                          '{"band":{"lower":-0.2,"upper":0.2}} now'),
    (("--nominal-diameter", "2.5", "--tolerance", "0.1", "--gauge-depth", "0.1"), "--gauge-depth: none there, 0.1 now"),
    (("--nominal-diameter", "2.5", "--tolerance", "0.1", "--units", "m"), "--units/--output-units: mm there, m now"),
    (("--nominal-diameter", "2.5", "--tolerance", "0.1", "--decision-rule", "guarded"),
     "--decision-rule: simple there, guarded now"),
    ((), "--decision-rule: simple there, none now"),
], ids=["tolerance", "gauge-depth", "units", "decision-rule", "no-tolerances"])
def test_resume_refuses_other_options_and_leaves_the_output_as_it_was(run, good_scans, tmp_path, fmt, changed, named):
    first, *rest = good_scans
    target = tmp_path / f"out.{fmt}"
    assert run("batch", first, "--format", fmt, "-o", target, "--nominal-diameter", "2.5", "--tolerance", "0.1",
               "--units", "mm").exit_code == 0
    with open(target, "a") as output:
        output.write('{"file": "cut in the mid')  # a last line left without its newline is kept too
    before = target.read_bytes()
    units = () if "--units" in changed else ("--units", "mm")
    result = run("batch", *good_scans, "--format", fmt, "-o", target, "--resume", *units, *changed)
    assert result.exit_code == cli.EXIT_USAGE, result.stderr
    assert result.stderr.count("\n") == 1 and result.stderr.startswith(f"Error: {target}: cannot resume with other "
                                                                         f"options than its records were made with")
    assert named in result.stderr
    assert target.read_bytes() == before
    # the same options (written otherwise: 0.10 for 0.1) go on with the rest
    target.write_bytes(before[: before.rfind(b"\n") + 1])
    result = run("batch", *good_scans, "--format", fmt, "-o", target, "--resume", "--units", "mm",
                 "--nominal-diameter", "2.50", "--tolerance", "0.10")
    assert result.exit_code == 0, result.stderr


def test_resume_compares_the_spec_by_its_content(run, good_scans, tmp_path):
    first = next(iter(good_scans))
    spec = tmp_path / "part.toml"
    spec.write_text('[[hole]]\nname = "A"\ncenter = [0, 0, 0]\ndiameter = 2.5\ntolerance = 0.1\n')
    target = tmp_path / "out.jsonl"
    assert run("batch", first, "-o", target, "--spec", spec).exit_code in (0, cli.EXIT_OUT_OF_TOLERANCE)
    spec.write_text(spec.read_text().replace("0.1", "0.05"))
    result = run("batch", *good_scans, "-o", target, "--resume", "--spec", spec)
    assert result.exit_code == cli.EXIT_USAGE
    assert "--spec (the file's content): " in result.stderr and len(target.read_text().splitlines()) == 1


# --- interruption of a real process ---------------------------------------------------------------------


@pytest.fixture(scope="module")
def many_scans(tmp_path_factory):
    """60 small scans (about 3,000 points each), enough to stop a run in the middle."""
    folder = tmp_path_factory.mktemp("many")
    points = _scan(1).points
    for index in range(60):
        save_points(folder / f"scan_{index:02d}.ply", points + index)
    return folder


def _start(repo_root, *args):
    env = dict(os.environ, PYTHONPATH=str(repo_root))
    return subprocess.Popen([sys.executable, "-m", "holecli", "batch", *map(str, args)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env=env, cwd=repo_root)


def _wait_for_a_line(path, process, timeout=30.0):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if path.exists() and b"\n" in path.read_bytes():
            return
        assert process.poll() is None, process.communicate()
        time.sleep(0.01)
    process.kill()
    pytest.fail("no record within the time limit")


@pytest.mark.slow
@pytest.mark.parametrize("signal_number", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
def test_interrupt_a_real_batch_then_resume(repo_root, many_scans, tmp_path, signal_number):
    target = tmp_path / "out.jsonl"
    process = _start(repo_root, many_scans, "--output", target, "--jobs", "1")
    _wait_for_a_line(target, process)
    os.kill(process.pid, signal_number)
    stdout, stderr = process.communicate(timeout=30)
    assert process.returncode == cli.EXIT_INTERRUPTED, stderr
    assert stdout == ""
    assert "Traceback" not in stderr
    assert "interrupted after" in stderr and "--resume" in stderr
    text = target.read_text()
    assert text.endswith("\n")
    done = [record["file"] for record in _lines(text)]  # every line parses
    assert 1 <= len(done) < 60
    assert len(set(done)) == len(done)

    process = _start(repo_root, many_scans, "--output", target, "--jobs", "2", "--resume")
    stdout, stderr = process.communicate(timeout=60)
    assert process.returncode == cli.EXIT_OK, stderr
    files = [record["file"] for record in _lines(target.read_text())]
    assert sorted(files) == sorted(str(path) for path in many_scans.iterdir())
    assert files[: len(done)] == done
    assert f"({len(done)} files from the earlier run in" in stderr or f"({len(done)} file from" in stderr


def test_a_record_that_cannot_be_written_becomes_an_error_record(run, good_scans, monkeypatch):
    from holecli.batch import pool

    measure = pool.measure_record

    def with_nan(path, options, spec=None, explain=False):
        record = measure(path, options, spec)
        record["holes"][0]["fit_rms"] = float("nan")
        return record

    monkeypatch.setattr(pool, "measure_record", with_nan)
    first = next(iter(good_scans))
    result = run("batch", first, "--jobs", "1")
    assert result.exit_code == cli.EXIT_FILE_FAILED
    (record,) = _lines(result.stdout)
    assert record["file"] == str(first)
    assert "the record cannot be written" in record["error"]


# --- faults (issue 8, items 4, 10, 12, 13) -------------------------------------------------------------


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="no /dev/full")
@pytest.mark.parametrize("fmt", ["jsonl", "csv"])
def test_batch_stdout_on_a_full_disk_is_one_line_error(holecli_process, good_scans, fmt):
    with open("/dev/full", "w") as full:
        result = holecli_process("batch", *good_scans, "--format", fmt, "--jobs", "1", stdout=full,
                                 stderr=subprocess.PIPE)
    assert result.returncode == cli.EXIT_INPUT
    assert result.stderr.splitlines()[-1] == "Error: stdout: cannot write output: No space left on device"
    assert "Traceback" not in result.stderr


@pytest.mark.slow
def test_batch_csv_with_a_file_name_that_is_not_utf8(good_scans, tmp_path, repo_root, holecli_process):
    folder = tmp_path / "scans"
    folder.mkdir()
    source = next(iter(good_scans))
    raw_name = os.fsencode(folder) + b"/panel_\xff" + os.fsencode(source.suffix)
    with open(raw_name, "wb") as stream:
        stream.write(source.read_bytes())
    output = tmp_path / "out.csv"
    result = holecli_process("batch", folder, "--format", "csv", "-o", output)
    assert result.returncode == 0, result.stderr
    data = output.read_bytes()
    assert b"panel_\xff" in data  # the name as its own bytes, as ls shows it
    rows = list(csv.reader(io.StringIO(data.decode("utf-8", "surrogateescape"))))
    assert len(rows) == 2 and rows[1][rows[0].index("path")] == os.fsdecode(os.path.realpath(raw_name))
    again = holecli_process("batch", folder, "--format", "csv", "-o", output, "--resume")
    assert again.returncode == 0, again.stderr
    assert output.read_bytes() == data  # matched on resume: not measured twice
    jsonl = holecli_process("batch", folder)
    assert jsonl.returncode == 0 and 'panel_\\udcff.ply"' in jsonl.stdout  # JSON escapes it


def test_resume_from_another_folder_matches_the_files_by_resolved_path(run, good_scans, tmp_path, monkeypatch):
    scans = tmp_path / "cell" / "scans"
    scans.mkdir(parents=True)
    for path in good_scans:
        shutil.copy(path, scans / path.name)
    output = tmp_path / "out.jsonl"
    monkeypatch.chdir(tmp_path / "cell")
    first = run("batch", "scans", "-o", output, "--jobs", "1")
    assert first.exit_code == 0, first.stderr
    text = output.read_text()
    monkeypatch.chdir(tmp_path)
    again = run("batch", "cell/scans", "-o", output, "--resume")
    assert again.exit_code == 0, again.stderr
    assert output.read_text() == text
    assert "(3 files from the earlier run in" in again.stderr


def test_a_second_batch_on_the_same_output_is_refused(run, good_scans, tmp_path):
    import fcntl

    output = tmp_path / "out.jsonl"
    output.write_text('{"file": "a.ply"}\n')
    with open(output, "a") as holder:
        fcntl.flock(holder, fcntl.LOCK_EX)  # as a running batch holds it
        for extra in ([], ["--resume"]):
            result = run("batch", *good_scans, "-o", output, *extra)
            assert result.exit_code == cli.EXIT_INPUT
            assert result.stderr.splitlines() == [f"Error: {output}: another holecli batch is writing this file "
                                                  f"(it is locked); wait for it to finish or give another --output"]
    assert output.read_text() == '{"file": "a.ply"}\n'


@pytest.mark.parametrize("device", ["/dev/zero", "/dev/null"])
def test_resume_onto_a_device_is_refused_at_once(holecli_process, good_scans, device):
    if not os.path.exists(device):
        pytest.skip(f"no {device}")
    result = holecli_process("batch", *good_scans, "-o", device, "--resume", timeout=30)
    assert result.returncode == cli.EXIT_INPUT
    assert result.stderr == f"Error: {device}: cannot resume: not a regular file\n"


def test_batch_output_to_a_device_is_written_directly(run, good_scans):
    if not os.path.exists("/dev/null"):
        pytest.skip("no /dev/null")
    result = run("batch", *good_scans, "-o", "/dev/null", "--jobs", "1")
    assert result.exit_code == 0, result.stderr
    assert stat.S_ISCHR(os.stat("/dev/null").st_mode)


def test_a_fifo_named_to_batch_is_an_error_record_not_a_hang(holecli_process, good_scans, tmp_path):
    fifo = tmp_path / "live.pcd"
    os.mkfifo(fifo)
    result = holecli_process("batch", fifo, next(iter(good_scans)), "--jobs", "1", timeout=60)
    assert result.returncode == cli.EXIT_FILE_FAILED, result.stderr
    records = {record["file"]: record for record in _lines(result.stdout)}
    assert "not a regular file" in records[str(fifo)]["error"]


def test_batch_explain_gives_every_record_its_rejected_list(run, good_scans, tmp_path):
    result = run("batch", *good_scans, "--explain", "--jobs", "2")
    assert result.exit_code == 0, result.stderr
    records = _lines(result.stdout)
    assert len(records) == len(good_scans)
    assert all(isinstance(record["rejected"], list) for record in records)
    plain = _lines(run("batch", *good_scans, "--jobs", "1").stdout)
    assert all("rejected" not in record for record in plain)
    assert run("batch", *good_scans, "--explain", "--format", "csv").exit_code == 2


# --- countersink, bore and perpendicularity checks, --gauge-depth (issue 12) ------------------------------

# sample_clouds/panel.ply (sample_clouds/panel.toml): a through hole T1, a countersunk C1 (7.0 at the
# surface, 100 degrees), a counterbored B1 and a blind L1, 4.0 each, none with its bore wall seen.
PANEL_CENTERS = {"T1": (-20.0, 8.0, 0.0), "C1": (-6.0, 8.0, 0.0), "B1": (8.0, 8.0, 0.0), "L1": (20.0, 8.0, 0.0)}
C1 = ["--nominal-center", "-6,8,0"]


@pytest.fixture(scope="module")
def panel(repo_root):
    return repo_root / "sample_clouds" / "panel.ply"


@pytest.fixture(scope="module")
def bored_scan(tmp_path_factory):
    """A 2.5 mm through hole whose bore wall is scanned 2 mm deep: its bore diameter is measured."""
    scene = synth.SceneSpec(holes=(synth.HoleSpec(center=(0.0, 0.0), diameter=2.5, bore_depth=2.0),),
                            extent=(-2.8, 2.8, -2.8, 2.8), spacing=0.1, rotation_deg=(10.0, 5.0, 0.0),
                            translation=(0.0, 2.0, 3.0))
    path = tmp_path_factory.mktemp("bored") / "bored.ply"
    save_points(path, synth.make_scan(scene, 0).points)
    return path


def test_detect_countersink_checks_pass_and_fail(run, panel):
    in_tolerance = [*C1, "--countersink-diameter", "7", "--countersink-diameter-tolerance", "+0.1/-0.1",
                    "--countersink-angle", "100", "--countersink-angle-tolerance", "1",
                    "--countersink-depth", "1.26", "--countersink-depth-tolerance", "0.05",
                    "--max-perpendicularity", "0.5"]
    result, record = _detect(run, panel, *in_tolerance)
    assert result.exit_code == cli.EXIT_OK, result.stderr
    checked = [hole for hole in record["holes"] if hole["in_tolerance"] is not None]
    assert len(checked) == 1
    (hole,) = checked
    assert hole["type"] == "countersunk" and hole["failed_checks"] == []
    assert hole["countersink_diameter_deviation"] == pytest.approx(hole["countersink"]["diameter"] - 7.0, abs=1e-12)
    assert hole["countersink_angle_deviation"] == pytest.approx(hole["countersink"]["angle_deg"] - 100.0, abs=1e-12)
    assert hole["countersink_depth_deviation"] == pytest.approx(hole["countersink"]["depth"] - 1.26, abs=1e-12)
    assert hole["bore_diameter_deviation"] is None and hole["diameter_deviation"] is None
    # 98 +1/-0.5 is exceeded by the 100 degrees measured, 102 +/-1 is not reached, 0.005 perpendicularity is too little
    for options, failed in [
        (["--countersink-angle", "98", "--countersink-angle-tolerance", "+1/-0.5"], ["countersink_angle"]),
        (["--countersink-angle", "102", "--countersink-angle-tolerance", "+/-1"], ["countersink_angle"]),
        (["--countersink-diameter", "7.2", "--countersink-diameter-tolerance", "+0.1/-0.1"], ["countersink_diameter"]),
        (["--max-perpendicularity", "0.005"], ["perpendicularity"]),
    ]:
        result, record = _detect(run, panel, *C1, *options)
        assert result.exit_code == cli.EXIT_OUT_OF_TOLERANCE, (options, result.stderr)
        (hole,) = [hole for hole in record["holes"] if hole["in_tolerance"] is not None]
        assert hole["failed_checks"] == failed
        assert "out of tolerance: 1 of 1 checked holes in" in result.stderr
    assert hole["perpendicularity_deg"] > 0.005


def test_detect_a_check_that_the_scan_does_not_measure_fails_as_not_measured(run, panel):
    options = ["--nominal-center", "20,8,0", "--nominal-diameter", "4", "--tolerance", "0.1",
               "--countersink-angle", "100", "--countersink-angle-tolerance", "1",
               "--bore-diameter", "4", "--bore-diameter-tolerance", "0.1"]
    result, record = _detect(run, panel, *options)  # the blind hole: no countersink, no bore wall seen
    assert result.exit_code == cli.EXIT_OUT_OF_TOLERANCE, result.stderr
    (hole,) = [hole for hole in record["holes"] if hole["in_tolerance"] is not None]
    assert hole["type"] == "blind" and hole["in_tolerance"] is False
    assert hole["failed_checks"] == ["countersink_angle_not_measured", "bore_diameter_not_measured"]
    assert hole["countersink_angle_deviation"] is None and hole["bore_diameter_deviation"] is None
    assert abs(hole["diameter_deviation"]) < 0.1
    assert "(1 with a check not measured)" in result.stderr
    table = run("detect", panel, "--format", "table", *options)
    assert table.exit_code == cli.EXIT_OUT_OF_TOLERANCE
    cells = " ".join(table.stdout.replace("│", " ").split())  # the wrapped cell read across its lines
    assert "OUT: countersink_angle not measured, bore_diameter not measured" in cells
    rows = list(csv.DictReader(io.StringIO(run("detect", panel, "--format", "csv", *options).stdout)))
    (row,) = [row for row in rows if row["in_tolerance"]]
    assert row["failed_checks"] == "countersink_angle_not_measured;bore_diameter_not_measured"
    assert row["countersink_angle_deviation"] == "" and row["in_tolerance"] == "false"


def test_detect_bore_diameter_check_and_its_csv_column(run, bored_scan):
    result, record = _detect(run, bored_scan, "--bore-diameter", "2.5", "--bore-diameter-tolerance", "+0.01/-0.01")
    assert result.exit_code == cli.EXIT_OK, result.stderr
    (hole,) = record["holes"]
    assert hole["bore"]["diameter"] == pytest.approx(2.5, abs=0.01)
    assert hole["bore_diameter_deviation"] == pytest.approx(hole["bore"]["diameter"] - 2.5, abs=1e-12)
    result = run("detect", bored_scan, "--format", "csv", "--bore-diameter", "2.45", "--bore-diameter-tolerance",
                 "+0.02/-0")
    assert result.exit_code == cli.EXIT_OUT_OF_TOLERANCE
    (row,) = csv.DictReader(io.StringIO(result.stdout))
    assert float(row["bore_diameter_deviation"]) == pytest.approx(0.05, abs=0.01)
    assert row["failed_checks"] == "bore_diameter"
    table = run("detect", bored_scan, "--format", "table", "--bore-diameter", "2.45", "--bore-diameter-tolerance",
                "+0.02/-0")
    assert "OUT: bore_diameter +0.05" in table.stdout


def test_spec_file_with_feature_checks_in_detect_and_batch(run, panel, tmp_path):
    spec = tmp_path / "panel.toml"
    tables = {
        "T1": "bore_diameter = 4.0\nbore_diameter_tolerance = 0.05\n",
        "C1": 'countersink_diameter = 7.0\ncountersink_diameter_tolerance = "+0.1/-0"\ncountersink_angle = 100\n'
              'countersink_angle_tolerance = "+/-1"\nmax_perpendicularity = 0.5\n',
        "B1": "max_perpendicularity = 0.5\n",
        "L1": "countersink_depth = 1.0\ncountersink_depth_tolerance = 0.1\n",
    }
    spec.write_text(_spec_text([(name, PANEL_CENTERS[name], 7.0 if name in ("C1", "B1") else 4.0, extra)
                                for name, extra in tables.items()]).replace('tolerance = "+0.1/-0.1"', "tolerance = 0.2"))
    result, record = _detect(run, panel, "--spec", spec)
    assert result.exit_code == cli.EXIT_OUT_OF_TOLERANCE, result.stderr
    by_name = {hole["name"]: hole for hole in record["holes"]}
    assert by_name["C1"]["failed_checks"] == [] and by_name["B1"]["failed_checks"] == []
    assert by_name["T1"]["failed_checks"] == ["bore_diameter_not_measured"]
    assert by_name["L1"]["failed_checks"] == ["countersink_depth_not_measured"]
    assert record["verdict"] == {"checked": 4, "out_of_tolerance": 2, "missing": [], "in_tolerance": False,
                                 **SIMPLE_VERDICT}
    result = run("batch", panel, "--spec", spec, "--format", "csv")
    assert result.exit_code == cli.EXIT_OUT_OF_TOLERANCE, result.stderr
    rows = {row["name"]: row for row in csv.DictReader(io.StringIO(result.stdout))}
    assert float(rows["C1"]["countersink_angle_deviation"]) == pytest.approx(
        by_name["C1"]["countersink_angle_deviation"])
    assert rows["T1"]["failed_checks"] == "bore_diameter_not_measured"


def test_gauge_depth_reaches_detect_and_the_workers_of_batch(run, panel, tmp_path):
    result, record = _detect(run, panel, "--gauge-depth", "0.5")
    assert result.exit_code == cli.EXIT_OK, result.stderr
    (countersink,) = [hole["countersink"] for hole in record["holes"] if hole["countersink"]]
    assert countersink["gauge_depth"] == 0.5
    # a 100 degree cone narrows by 2 * 0.5 * tan(50 degrees) in 0.5 below the surface
    assert countersink["diameter_at_depth"] == pytest.approx(countersink["diameter"] - math.tan(math.radians(50)),
                                                             abs=0.01)
    copy = tmp_path / "panel_copy.ply"
    shutil.copy(panel, copy)
    result = run("batch", panel, copy, "--gauge-depth", "0.5", "--jobs", "2")
    assert result.exit_code == cli.EXIT_OK, result.stderr
    for line in result.stdout.splitlines():
        (batch_countersink,) = [hole["countersink"] for hole in json.loads(line)["holes"] if hole["countersink"]]
        assert batch_countersink["gauge_depth"] == 0.5
        assert batch_countersink["diameter_at_depth"] == pytest.approx(countersink["diameter_at_depth"], abs=1e-9)
    result, record = _detect(run, panel)
    assert all(hole["countersink"]["diameter_at_depth"] is None for hole in record["holes"] if hole["countersink"])


@pytest.mark.parametrize(
    "options, message",
    [
        (["--countersink-angle", "100"], "--countersink-angle needs --countersink-angle-tolerance"),
        (["--countersink-angle-tolerance", "1"], "--countersink-angle-tolerance needs --countersink-angle"),
        (["--countersink-diameter", "7"], "--countersink-diameter needs --countersink-diameter-tolerance"),
        (["--countersink-depth-tolerance", "0.1"], "--countersink-depth-tolerance needs --countersink-depth"),
        (["--bore-diameter", "4"], "--bore-diameter needs --bore-diameter-tolerance"),
        (["--countersink-angle", "100 +/- 1", "--countersink-angle-tolerance", "1"],
         "give its tolerance with --countersink-angle-tolerance"),
        (["--countersink-angle", "180", "--countersink-angle-tolerance", "1"], "0<x<180"),
        (["--countersink-angle", "100", "--countersink-angle-tolerance", "1/0.5"], "with its sign"),
        (["--countersink-angle", "100", "--countersink-angle-tolerance", "-0.5/+1"], "did you mean +1/-0.5"),
        (["--countersink-diameter", "0", "--countersink-diameter-tolerance", "0.1"], "--countersink-diameter"),
        (["--bore-diameter", "4", "--bore-diameter-tolerance", "1_0"], "expected a number"),
        (["--max-perpendicularity", "95"], "--max-perpendicularity"),
        (["--spec", "part.toml", "--countersink-angle", "100", "--countersink-angle-tolerance", "1"],
         "--spec cannot be combined with --countersink-angle, --countersink-angle-tolerance"),
        (["--gauge-depth", "-1"], "--gauge-depth"),
        (["--gauge-depth", "nan"], "not a plain decimal number"),
        (["--method", "paper", "--gauge-depth", "0.5"], "--gauge-depth cannot be used with --method paper"),
    ],
)
@pytest.mark.parametrize("command", ["detect", "batch"])
def test_feature_check_and_gauge_depth_option_errors_exit_2(run, one_scan, options, message, command):
    result = run(command, one_scan[0], *options)
    assert result.exit_code == cli.EXIT_USAGE, result.stderr
    assert result.stdout == ""
    assert message in result.stderr
    assert "Traceback" not in result.stderr


@pytest.mark.parametrize("command", ["detect", "batch"])
def test_every_tolerance_and_detection_option_has_a_metavar_and_help(run, command):
    import click

    params = {param.name: param for param in cli.main.commands[command].params}
    expected = {"gauge_depth": "DEPTH", "countersink_diameter": "D", "countersink_angle": "DEG",
                "countersink_depth": "D", "bore_diameter": "D", "max_perpendicularity": "DEG",
                "countersink_diameter_tolerance": "T|+U/-L", "countersink_angle_tolerance": "T|+U/-L",
                "countersink_depth_tolerance": "T|+U/-L", "bore_diameter_tolerance": "T|+U/-L"}
    context = click.Context(cli.main.commands[command])
    for name, metavar in expected.items():
        assert params[name].help, name
        assert params[name].make_metavar(context) == metavar, name
    help_text = run(command, "--help").stdout
    for name in expected:
        assert f"--{name.replace('_', '-')} " in help_text


def test_the_table_cell_of_a_verdict_shows_each_failed_check_with_its_value():
    from holecli.cli.render import verdict_cell

    hole = {"name": "A1", "in_tolerance": False, "diameter_deviation": -0.0029,
            "position_deviation": {"in_plane": 0.061, "along_normal": 0.0}, "tilt_deg": 0.72,
            "perpendicularity_deg": 1.5, "countersink_angle_deviation": 1.214, "bore_diameter_deviation": None,
            "failed_checks": ["diameter", "position", "tilt", "countersink_angle", "bore_diameter_not_measured",
                              "perpendicularity"]}
    assert verdict_cell(hole) == ("A1: OUT: diameter -0.0029, position 0.061, tilt 0.72, countersink_angle +1.214, "
                                  "bore_diameter not measured, perpendicularity 1.5")
    assert verdict_cell(dict(hole, in_tolerance=True, failed_checks=[])) == "A1: in"
    assert verdict_cell({"in_tolerance": None, "failed_checks": None}) == "not checked"


def test_the_sample_panel_spec_gives_the_verdict_the_readme_shows(run, panel, repo_root):
    result, record = _detect(run, panel, "--spec", repo_root / "sample_clouds" / "panel_tolerances.toml")
    assert result.exit_code == cli.EXIT_OK, result.stderr
    assert {hole["name"]: hole["failed_checks"] for hole in record["holes"]} == {"T1": [], "C1": [], "B1": [], "L1": []}


# --- issue 23, item 7: folders that cannot be listed, files that cannot be read ------------------------


def _as_without_permission_override():
    """preexec_fn: a process that file permissions apply to. Root (as the suite runs here) loses
    CAP_DAC_OVERRIDE and CAP_DAC_READ_SEARCH from its bounding set, which the program then starts
    without: it cannot read a mode-000 file or list a mode-000 folder, as any other user."""
    if os.geteuid() != 0:
        return
    import ctypes

    libc = ctypes.CDLL(None, use_errno=True)
    for capability in (1, 2):  # CAP_DAC_OVERRIDE, CAP_DAC_READ_SEARCH
        if libc.prctl(24, capability, 0, 0, 0) != 0:  # PR_CAPBSET_DROP
            os._exit(99)


@pytest.fixture
def locked(tmp_path, good_scans):
    """A folder with a good scan, a subfolder holding another that cannot be listed, and a scan
    that cannot be read (mode 000)."""
    good = list(good_scans)
    shutil.copy(good[0], tmp_path / "a.ply")
    (tmp_path / "sub").mkdir()
    shutil.copy(good[1], tmp_path / "sub" / "b.csv")
    shutil.copy(good[2], tmp_path / "c.pcd")
    os.chmod(tmp_path / "c.pcd", 0)
    os.chmod(tmp_path / "sub", 0)
    yield tmp_path
    os.chmod(tmp_path / "sub", 0o755)


def _run_without_override(holecli_process, *args):
    done = holecli_process(*args, preexec_fn=_as_without_permission_override)
    if done.returncode == 99:
        pytest.skip("cannot drop the capabilities that let root read anything")
    return done


def test_batch_r_gives_a_subfolder_it_cannot_list_an_error_record(holecli_process, locked):
    done = _run_without_override(holecli_process, "batch", "-r", "--jobs", "1", locked)
    records = {record["file"]: record for record in map(json.loads, done.stdout.splitlines())}
    sub = str(locked / "sub")
    assert records[sub]["error"] == f"{sub}: cannot list this folder (Permission denied): its files are not measured"
    assert "holes" in records[str(locked / "a.ply")]
    assert done.returncode == 6  # some file could not be measured: not 0
    assert f"failed: {sub}: cannot list this folder" in done.stderr


def test_batch_resume_does_not_repeat_the_record_of_a_folder_it_cannot_list(holecli_process, locked, tmp_path):
    output = tmp_path / "out.jsonl"
    os.chmod(locked / "c.pcd", 0o644)
    _run_without_override(holecli_process, "batch", "-r", "--jobs", "1", locked, "-o", output)
    done = _run_without_override(holecli_process, "batch", "-r", "--jobs", "1", locked, "-o", output, "--resume")
    files = [json.loads(line)["file"] for line in output.read_text().splitlines()]
    assert sorted(files) == sorted([str(locked / "a.ply"), str(locked / "c.pcd"), str(locked / "sub")])
    assert done.returncode == 6


def test_batch_of_a_folder_it_cannot_list_is_an_input_error(holecli_process, locked):
    done = _run_without_override(holecli_process, "batch", "--jobs", "1", locked / "sub")
    assert done.returncode == 3
    assert done.stderr == f"Error: {locked / 'sub'}: cannot list this folder: Permission denied\n"


def test_batch_gives_a_named_file_it_cannot_read_an_error_record(holecli_process, locked):
    # was: a usage error (exit 2) from click before anything was measured
    done = _run_without_override(holecli_process, "batch", "--jobs", "1", locked / "c.pcd", locked / "a.ply")
    records = {record["file"]: record for record in map(json.loads, done.stdout.splitlines())}
    assert records[str(locked / "c.pcd")]["error"] == f"{locked / 'c.pcd'}: unreadable file (permission denied)"
    assert "holes" in records[str(locked / "a.ply")]
    assert done.returncode == 6


# --- issue 23, item 6: one line, not a traceback ------------------------------------------------------

_HUGE_SPEC = ('[[hole]]\nname = "A"\ndiameter = 2' + "0" * 400 + '\ntolerance = 0.1\ncenter = [0, 0, 0]\n'
              'position_tolerance = 1\n')


@pytest.mark.parametrize("command", ["detect", "batch", "register"])
def test_a_spec_integer_no_float_holds_is_one_line_in_every_command(holecli_process, good_scans, tmp_path, command):
    spec = tmp_path / "huge.toml"
    spec.write_text(_HUGE_SPEC)
    done = holecli_process(command, next(iter(good_scans)), "--spec", spec)
    assert done.returncode == 3
    assert done.stderr == f"Error: {spec}: hole[1].diameter: an integer of 401 digits is too large for a number\n"


def test_a_panel_integer_no_float_holds_is_one_line(holecli_process, tmp_path):
    panel = tmp_path / "panel.toml"
    panel.write_text("[panel]\nwidth = 1" + "0" * 400 + "\nheight = 10\nthickness = 1\n")
    done = holecli_process("simulate", tmp_path / "out.ply", "--panel", panel)
    assert done.returncode == 3
    assert done.stderr == f"Error: {panel}: panel.width: an integer of 401 digits is too large for a number\n"


def test_a_spec_integer_of_more_than_4300_digits_is_one_line(holecli_process, good_scans, tmp_path):
    spec = tmp_path / "huge.toml"
    spec.write_text(_HUGE_SPEC.replace("0" * 400, "0" * 5000))
    done = holecli_process("detect", next(iter(good_scans)), "--spec", spec)
    assert done.returncode == 3
    assert done.stderr == f"Error: {spec}: invalid TOML: a number of more than 4300 digits\n"


def test_a_coverage_factor_no_float_holds_is_a_usage_error(run, good_scans):
    result = run("detect", next(iter(good_scans)), "--nominal-diameter", "2.5", "--tolerance", "0.1",
                 "--decision-rule", "guarded", "--coverage-factor", "1e400")
    assert result.exit_code == 2
    assert "Invalid value for '--coverage-factor': '1e400' is too large" in result.stderr


def test_register_of_stdin_is_one_line(holecli_process, repo_root):
    done = holecli_process("register", "-", "--spec", repo_root / "sample_clouds" / "panel_tolerances.toml")
    assert done.returncode == 2
    assert done.stderr == "Error: -: holecli register cannot read a scan from standard input: give each scan as a file\n"
