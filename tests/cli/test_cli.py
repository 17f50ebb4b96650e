"""Tests of the holecli command line: parsed output, exit codes, one-line errors, the simulate command."""

import csv
import io
import json
import os
import re
import stat
import subprocess
import sys

import numpy as np
import pytest

from holecli import __version__, cli, report
from holecli.io import load_points, save_points
from holecli.simulation import synth

SAMPLES = os.path.join(os.path.dirname(__file__), os.pardir, os.pardir, "sample_clouds")

RECORD_KEYS = {"schema_version", "holecli_version", "file", "points", "dropped_points", "input_columns", "method", "options", "scales",
               "candidates", "plane", "holes", "timing"}
PLANE_KEYS = {"point", "normal", "rms", "inliers"}
HOLE_KEYS = {
    "index", "center", "diameter", "normal", "rim_points", "fit_rms", "max_residual", "roundness",
    "bias_correction", "partial", "arc_deg", "scan_lines", "type", "countersink", "counterbore", "bore", "axis",
    "perpendicularity_deg", "warnings", "notes", "uncertainty",
}  # fmt: skip


def _assert_one_line_error(result, *names, code=cli.EXIT_INPUT):
    assert result.exit_code == code, (result.exit_code, result.stderr, result.exception)
    assert result.stdout == ""
    lines = result.stderr.splitlines()
    assert len(lines) == 1, result.stderr
    assert lines[0].startswith("Error: ")
    for name in names:
        assert str(name) in lines[0]
    assert "Traceback" not in result.stderr
    # the CLI turned the failure into an exit code, not an escaped exception
    assert isinstance(result.exception, SystemExit)


def _rz(degrees):
    c, s = np.cos(np.radians(degrees)), np.sin(np.radians(degrees))
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _rx(degrees):
    c, s = np.cos(np.radians(degrees)), np.sin(np.radians(degrees))
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


# --- version and help ------------------------------------------------------------------------------


def test_version(run):
    result = run("--version")
    assert result.exit_code == 0
    assert result.stdout.strip() == f"holecli, version {__version__}"


@pytest.mark.parametrize("command", [None, *sorted(cli.main.commands)])
def test_every_help_has_examples_and_exit_codes(run, command):
    result = run(*([command] if command else []), "--help")
    assert result.exit_code == 0
    assert "Example" in result.stdout
    assert "Exit codes" in result.stdout
    assert result.stderr == ""


def test_there_are_commands():
    assert {"detect", "simulate"} <= set(cli.main.commands)


def test_python_m_holecli_help_works(repo_root):
    env = dict(os.environ, PYTHONPATH=str(repo_root))
    result = subprocess.run([sys.executable, "-m", "holecli", "--help"], capture_output=True, text=True, env=env,
                            cwd=repo_root, timeout=60)
    assert result.returncode == 0, result.stderr
    assert "Example" in result.stdout
    assert "detect" in result.stdout and "simulate" in result.stdout


def test_help_imports_neither_open3d_nor_scipy(modules_imported_by):
    commands = (["--help"], ["detect", "--help"], ["simulate", "--help"])
    assert modules_imported_by(commands, ("open3d", "scipy")) == "[]"


# --- detect: the happy path ---------------------------------------------------------------------


@pytest.mark.parametrize("extension", [".ply", ".pcd", ".csv"])
def test_detect_prints_the_json_record(run, table1_files, table1_truth, extension):
    path = table1_files[extension]
    result = run("detect", path, "--method", "paper")
    assert result.exit_code == cli.EXIT_OK, result.stderr
    assert "{" not in result.stderr
    record = json.loads(result.stdout)
    assert set(record) == RECORD_KEYS
    assert set(record["plane"]) == PLANE_KEYS
    assert len(record["holes"]) == 1
    assert set(record["holes"][0]) == HOLE_KEYS
    assert record["file"] == str(path)
    assert record["points"] == 7062
    assert record["dropped_points"] == 0
    assert record["method"] == "paper"
    hole = record["holes"][0]
    assert np.linalg.norm(np.subtract(hole["center"], table1_truth["center"])) < 0.010
    assert abs(hole["diameter"] - table1_truth["diameter"]) < 0.070


def test_detect_same_result_from_every_format(run, table1_files):
    records = [json.loads(run("detect", path, "--method", "paper").stdout) for path in table1_files.values()]
    for record in records[1:]:
        assert record["holes"][0]["center"] == records[0]["holes"][0]["center"]
        assert record["holes"][0]["diameter"] == records[0]["holes"][0]["diameter"]


def test_detect_default_method(run, table1_files, table1_truth):
    result = run("detect", table1_files[".ply"])
    assert result.exit_code == cli.EXIT_OK, result.stderr
    record = json.loads(result.stdout)
    assert set(record) == RECORD_KEYS
    assert record["method"] == "robust"
    assert len(record["holes"]) == 1
    assert abs(record["holes"][0]["diameter"] - table1_truth["diameter"]) < 0.070


def test_detect_csv_format(run, table1_files):
    path = table1_files[".pcd"]
    result = run("detect", path, "--method", "paper", "--format", "csv")
    assert result.exit_code == cli.EXIT_OK, result.stderr
    rows = list(csv.reader(io.StringIO(result.stdout)))
    assert rows[0] == list(report.CSV_COLUMNS)
    assert len(rows) == 2
    row = dict(zip(report.CSV_COLUMNS, rows[1]))
    assert row["file"] == str(path)
    assert row["hole"] == "0"
    expected = json.loads(run("detect", path, "--method", "paper").stdout)["holes"][0]
    assert float(row["diameter"]) == expected["diameter"]
    assert [float(row[f"center_{axis}"]) for axis in "xyz"] == expected["center"]
    assert row["partial"] == "false"


def test_detect_table_format(run, table1_files):
    path = table1_files[".ply"]
    result = run("detect", path, "--method", "paper", "--format", "table")
    assert result.exit_code == cli.EXIT_OK, result.stderr
    diameter = json.loads(run("detect", path, "--method", "paper").stdout)["holes"][0]["diameter"]
    assert f"{diameter:.4f}" in result.stdout


def test_detect_output_file(run, table1_files, tmp_path):
    target = tmp_path / "result.json"
    result = run("detect", table1_files[".csv"], "--method", "paper", "--output", target)
    assert result.exit_code == cli.EXIT_OK, result.stderr
    assert result.stdout == ""
    written = json.loads(target.read_text())
    printed = json.loads(run("detect", table1_files[".csv"], "--method", "paper").stdout)
    written.pop("timing")
    printed.pop("timing")
    assert written == printed


def test_detect_output_into_a_missing_folder(run, table1_files, tmp_path):
    target = tmp_path / "missing" / "result.json"
    result = run("detect", table1_files[".ply"], "--method", "paper", "-o", target)
    _assert_one_line_error(result, target)
    assert not target.parent.exists()


def test_detect_reports_dropped_nan_rows(run, tmp_path):
    scan = synth.make_scan(synth.SceneSpec(nan_points=25), 0)
    finite = int(np.isfinite(scan.points).all(axis=1).sum())
    assert finite == len(scan.points) - 25
    for extension in (".csv", ".ply"):
        path = tmp_path / f"nan{extension}"
        save_points(path, scan.points)
        result = run("detect", path, "--method", "paper")
        assert result.exit_code == cli.EXIT_OK, result.stderr
        record = json.loads(result.stdout)
        assert record["dropped_points"] == 25
        assert record["points"] == finite


# --- detect: no hole -----------------------------------------------------------------------------


def _write_integer_grid(path):
    # On exact coordinates all the paper's triangles are equal, so it finds no hole (see test_rim).
    x, y = np.meshgrid(np.arange(30.0), np.arange(30.0))
    save_points(path, np.column_stack([x.ravel(), y.ravel(), np.full(x.size, 2.0)]))


@pytest.mark.parametrize("method", ["paper", "robust"])
def test_detect_no_hole_on_an_exact_grid(run, tmp_path, method):
    path = tmp_path / "flat.csv"
    _write_integer_grid(path)
    result = run("detect", path, "--method", method)
    assert result.exit_code == cli.EXIT_NO_HOLE, result.stderr
    record = json.loads(result.stdout)
    assert record["holes"] == []
    assert record["points"] == 900
    assert record["file"] == str(path)
    assert "no hole" in result.stderr
    assert "{" not in result.stderr


def test_detect_no_hole_csv_is_one_row_with_only_the_file(run, tmp_path):
    path = tmp_path / "flat.csv"
    _write_integer_grid(path)
    result = run("detect", path, "--method", "paper", "--format", "csv")
    assert result.exit_code == cli.EXIT_NO_HOLE
    rows = list(csv.reader(io.StringIO(result.stdout)))
    provenance = report.CSV_COLUMNS.index("schema_version")
    assert rows[0] == list(report.CSV_COLUMNS) and len(rows) == 2
    assert rows[1][:provenance] == [str(path)] + [""] * (provenance - 1)
    assert dict(zip(report.CSV_COLUMNS, rows[1]))["method"] == "paper"


def test_no_hole_found_says_why(run):
    """The "no hole found" line counts the refused candidates by check, most frequent first, and points
    to --explain (which lists them); with --explain it does not."""
    scan = os.path.join(SAMPLES, "no_hole.csv")
    result = run("detect", scan)
    assert result.exit_code == cli.EXIT_NO_HOLE
    line = result.stderr.strip().splitlines()[-1]
    assert re.fullmatch(r"holecli: no hole found in .*no_hole\.csv \(\d+ candidates? refused: \d+ [a-z_]+"
                        r"(, \d+ [a-z_]+)*; --explain lists them\)", line), line
    explained = run("detect", scan, "--explain")
    checks = [r["check"] for r in json.loads(explained.stdout)["rejected"]]
    assert f"{len(checks)} candidate" in explained.stderr and "--explain lists" not in explained.stderr


def test_detect_jsonl_is_the_record_on_one_line_and_batch_takes_json(run):
    """Issue 25, item 9: detect --format jsonl writes batch's line (appending to a log keeps one record
    a line), and batch --format json is its JSON Lines (the two commands share their format words)."""
    scan = os.path.join(SAMPLES, "table1.ply")
    line = run("detect", scan, "--format", "jsonl")
    assert line.exit_code == 0 and line.stdout.count("\n") == 1
    record, indented = json.loads(line.stdout), json.loads(run("detect", scan).stdout)
    assert record.keys() == indented.keys() and record["holes"] == indented["holes"]  # (timing differs)
    batch = run("batch", scan, "--format", "json", "-q")
    assert batch.exit_code == 0 and batch.stdout.count("\n") == 1
    assert json.loads(batch.stdout)["holes"] == json.loads(line.stdout)["holes"]


def test_detect_a_folder_points_to_batch(run, tmp_path):
    result = run("detect", tmp_path)
    assert result.exit_code == cli.EXIT_INPUT
    assert result.stderr.strip() == f"Error: {tmp_path}: is a directory (to measure every scan in it: holecli batch {tmp_path})"


def test_detect_robust_finds_no_hole_on_a_simulated_plain_surface(run, tmp_path):
    # A float grid without a hole (the paper method invents one here from round-off: not asserted).
    path = tmp_path / "plain.ply"
    assert run("simulate", path, "--no-hole").exit_code == 0
    result = run("detect", path, "--method", "robust")
    assert result.exit_code == cli.EXIT_NO_HOLE, result.stdout
    assert json.loads(result.stdout)["holes"] == []


# --- detect: bad input -----------------------------------------------------------------------------


def _truncated_ply(folder):
    path = folder / "truncated.ply"
    save_points(path, synth.make_scan(synth.table1_scene(), 0).points)
    data = path.read_bytes()
    path.write_bytes(data[: len(data) - 1000])
    return path


def _write(name, content):
    def make(folder):
        path = folder / name
        if isinstance(content, bytes):
            path.write_bytes(content)
        else:
            path.write_text(content)
        return path

    return make


def _five_points(folder):
    path = folder / "five.csv"
    save_points(path, np.random.default_rng(0).normal(size=(5, 3)))
    return path


BAD_INPUTS = {
    "missing": lambda folder: folder / "missing.ply",
    "directory": lambda folder: (folder / "adir.ply").mkdir() or folder / "adir.ply",
    "obj": _write("mesh.obj", "v 1 2 3\nv 4 5 6\nv 7 8 0\n"),
    "empty ply": _write("empty.ply", ""),
    "empty csv": _write("empty.csv", ""),
    "garbled ply header": _write("garbled.ply", "ply\nformat bogus 1.0\nelement vertex 3\nend_header\n1 2 3\n"),
    "ply without end_header": _write("noend.ply", b"ply\nformat ascii 1.0\nelement vertex 3\n\x00\x01\x02"),
    "csv non-numeric": _write("word.csv", "x,y,z\n1,2,3\n4,five,6\n7,8,9\n"),
    "csv too few points": _five_points,
    "truncated binary ply": _truncated_ply,
}


@pytest.mark.parametrize("make", BAD_INPUTS.values(), ids=BAD_INPUTS.keys())
@pytest.mark.parametrize("fmt", ["json", "csv"])
def test_bad_input_is_one_line_error(run, tmp_path, make, fmt):
    path = make(tmp_path)
    result = run("detect", path, "--method", "paper", "--format", fmt)
    _assert_one_line_error(result, path.name)
    assert result.stderr.startswith(f"Error: {path}: ")


@pytest.mark.parametrize("make", BAD_INPUTS.values(), ids=BAD_INPUTS.keys())
def test_bad_input_keeps_an_existing_output_file(run, tmp_path, make):
    path = make(tmp_path)
    target = tmp_path / "previous.json"
    target.write_text('{"previous": true}\n')
    result = run("detect", path, "--output", target)
    _assert_one_line_error(result, path.name)
    assert target.read_text() == '{"previous": true}\n'
    assert sorted(p.name for p in tmp_path.iterdir() if p.name.startswith(".")) == []


@pytest.mark.parametrize(
    "args",
    [
        ["detect", "{scan}", "--format", "yaml"],
        ["detect", "{scan}", "--method", "magic"],
        ["detect"],
        ["detect", "{scan}", "--no-such-option"],
        ["detect", "{scan}", "--method", "paper", "--max-holes", "2"],
        ["no-such-command"],
        ["simulate", "out.ply", "--rotation", "1,2"],
    ],
)
def test_usage_errors_exit_2(run, table1_files, args):
    result = run(*(arg.format(scan=table1_files[".ply"]) for arg in args))
    assert result.exit_code == cli.EXIT_USAGE
    assert result.stdout == ""
    assert "Traceback" not in result.stderr


# --- simulate --------------------------------------------------------------------------------------


def test_simulate_writes_the_table1_scene_and_its_truth(run, tmp_path):
    out = tmp_path / "out.ply"
    result = run("simulate", out)
    assert result.exit_code == 0, result.stderr
    assert result.stdout == ""
    truth = json.loads((tmp_path / "out.truth.json").read_text())
    points = load_points(out)
    assert len(points) == truth["points"] == 7062
    assert len(truth["holes"]) == 1
    hole = truth["holes"][0]
    rotation = _rz(20.0) @ _rx(32.0)  # Rz(20) Ry(0) Rx(32)
    np.testing.assert_allclose(hole["center"], rotation @ (1.0, 1.0, 0.0) + (3.0, 4.0, 5.0), atol=1e-12)
    np.testing.assert_allclose(hole["normal"], rotation[:, 2], atol=1e-12)
    assert hole["diameter"] == 3.0
    assert truth["spacing"] == 0.0908
    # The points are the scene's: on the rotated plane, none inside the hole.
    heights = (points - (3.0, 4.0, 5.0)) @ rotation[:, 2]
    assert np.max(np.abs(heights)) < 1e-9
    assert np.min(np.linalg.norm(points - hole["center"], axis=1)) > 1.5


def test_simulate_output_is_detected(run, tmp_path):
    out = tmp_path / "scene.csv"
    assert run("simulate", out, "--seed", "3").exit_code == 0
    truth = json.loads((tmp_path / "scene.truth.json").read_text())["holes"][0]
    record = json.loads(run("detect", out, "--method", "paper").stdout)
    assert np.linalg.norm(np.subtract(record["holes"][0]["center"], truth["center"])) < 0.010


@pytest.mark.parametrize("angle", [82.0, 110.0])
def test_simulate_countersink_angle_is_the_cone_detect_measures(run, tmp_path, angle):
    out = tmp_path / "countersunk.ply"
    result = run("simulate", out, "--hole", "0,0,3", "--countersink", "5", "--countersink-angle", str(angle),
                 "--extent", "-4,4,-4,4", "--spacing", "0.05", "--bore-depth", "3", "--rotation", "0,0,0",
                 "--translation", "0,0,0")
    assert result.exit_code == 0, result.stderr
    hole = json.loads(run("detect", out).stdout)["holes"][0]
    assert hole["type"] == "countersunk"
    assert abs(hole["countersink"]["angle_deg"] - angle) < 0.1
    assert abs(hole["countersink"]["depth"] - 1.0 / np.tan(np.radians(angle / 2))) < 0.005
    assert abs(hole["bore"]["diameter"] - 3.0) < 0.005


def test_simulate_repeated_hole_option(run, tmp_path):
    out = tmp_path / "two.pcd"
    result = run("simulate", out, "--hole", "0,0,2", "--hole", "3,3,1.5", "--truth", tmp_path / "t.json")
    assert result.exit_code == 0, result.stderr
    truth = json.loads((tmp_path / "t.json").read_text())
    assert [hole["diameter"] for hole in truth["holes"]] == [2.0, 1.5]
    rotation = _rz(20.0) @ _rx(32.0)
    np.testing.assert_allclose(truth["holes"][1]["center"], rotation @ (3.0, 3.0, 0.0) + (3.0, 4.0, 5.0), atol=1e-12)
    assert len(load_points(out)) == truth["points"]


def test_simulate_unknown_extension(run, tmp_path):
    out = tmp_path / "scene.obj"
    result = run("simulate", out)
    _assert_one_line_error(result, out.name)
    assert list(tmp_path.iterdir()) == []


def test_simulate_into_a_missing_folder(run, tmp_path):
    out = tmp_path / "missing" / "scene.ply"
    _assert_one_line_error(run("simulate", out), out.name)


# --- where --output goes, and stdout that cannot be written (issue 8, items 1, 4 and 15) ------------


def test_detect_output_through_a_symlink_replaces_the_target_and_keeps_the_link(run, table1_files, tmp_path):
    target = tmp_path / "results" / "table1.json"
    target.parent.mkdir()
    target.write_text("old\n")
    link = tmp_path / "latest.json"
    link.symlink_to(target)
    result = run("detect", table1_files[".ply"], "-o", link)
    assert result.exit_code == 0, result.stderr
    assert link.is_symlink() and os.readlink(link) == str(target)
    assert json.loads(target.read_text())["holes"][0]["diameter"] == pytest.approx(3.0, abs=0.01)


def test_detect_output_to_a_fifo_writes_through_it(run, table1_files, tmp_path, fifo_reader):
    fifo = tmp_path / "results.fifo"
    os.mkfifo(fifo)
    finish = fifo_reader(fifo)  # its read end opened before the run (a FIFO without a reader is refused)
    result = run("detect", table1_files[".ply"], "-o", fifo)
    received = [finish().decode()]
    assert result.exit_code == 0, result.stderr
    assert json.loads(received[0])["holes"][0]["diameter"] == pytest.approx(3.0, abs=0.01)
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode)
    assert os.listdir(tmp_path) == ["results.fifo"]


def test_detect_output_to_a_device_writes_to_it_and_keeps_it(run, table1_files, tmp_path):
    node = tmp_path / "null"
    try:
        os.mknod(node, stat.S_IFCHR | 0o666, os.makedev(1, 3))  # a /dev/null of our own, not the system's
        open(node, "wb").close()
    except OSError as error:
        pytest.skip(f"cannot make or use a device node here: {error}")
    result = run("detect", table1_files[".ply"], "-o", node)
    assert result.exit_code == 0, result.stderr
    assert stat.S_ISCHR(os.lstat(node).st_mode) and os.lstat(node).st_rdev == os.makedev(1, 3)
    assert os.listdir(tmp_path) == ["null"]


def test_detect_output_dash_is_stdout(run, table1_files, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    result = run("detect", table1_files[".ply"], "-o", "-")
    assert result.exit_code == 0, result.stderr
    assert json.loads(result.stdout)["holes"]
    assert os.listdir(tmp_path) == []


@pytest.mark.slow
def test_detect_output_removes_temporaries_left_by_a_killed_run(holecli_process, table1_files, tmp_path):
    output = tmp_path / "result.json"
    with holecli_process("detect", table1_files[".ply"], "-o", output, start=True) as writer:
        writer.wait(60)
    output.unlink()
    stale = tmp_path / f".result.json.{writer.pid}.1234abcd.tmp"  # that process is gone
    stale.write_text('{"half": ')
    result = holecli_process("detect", table1_files[".ply"], "-o", output)
    assert result.returncode == 0, result.stderr
    assert os.listdir(tmp_path) == ["result.json"]


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="no /dev/full")
@pytest.mark.parametrize("fmt", ["json", "csv", "table"])
def test_detect_stdout_on_a_full_disk_is_one_line_error(holecli_process, table1_files, fmt):
    with open("/dev/full", "w") as full:
        result = holecli_process("detect", table1_files[".ply"], "--format", fmt, stdout=full,
                                 stderr=subprocess.PIPE)
    assert result.returncode == cli.EXIT_INPUT
    assert result.stderr == "Error: stdout: cannot write output: No space left on device\n"


# --- spec files that are not spec files (issue 8, item 4) --------------------------------------------


def test_detect_spec_nested_too_deeply_is_one_line_error(run, table1_files, tmp_path):
    spec = tmp_path / "deep.toml"
    spec.write_text("a = " + "[" * 5000 + "]" * 5000 + "\n")
    result = run("detect", table1_files[".ply"], "--spec", spec)
    _assert_one_line_error(result, spec, "nested too deeply")


@pytest.mark.parametrize("kind", ["device", "fifo", "huge"])
def test_detect_spec_that_is_not_a_spec_file_is_refused_before_reading(run, table1_files, tmp_path, kind):
    if kind == "device":
        spec = "/dev/zero"
    elif kind == "fifo":
        spec = tmp_path / "spec.toml"
        os.mkfifo(spec)  # opening it would block until a writer came
    else:
        spec = tmp_path / "spec.toml"
        with open(spec, "wb") as stream:
            stream.truncate(cli.MAX_SPEC_BYTES + 1)  # sparse: no disk used
    result = run("detect", table1_files[".ply"], "--spec", spec)
    _assert_one_line_error(result, spec, "too large" if kind == "huge" else "not a regular file")


# --- numbers are plain decimals (issue 8, item 16) ------------------------------------------------------


@pytest.mark.parametrize("args", [
    ["--nominal-diameter", "1_0", "--tolerance", "0.1"],
    ["--nominal-diameter", "٣", "--tolerance", "0.1"],
    ["--nominal-diameter", "3", "--tolerance", "0.1_0"],
    ["--nominal-diameter", "nan", "--tolerance", "0.1"],
    ["--view-dir", "0,0,1_0"],
    ["--min-diameter", "0x10"],
])
def test_numbers_that_float_would_take_are_usage_errors(run, table1_files, args):
    result = run("detect", table1_files[".ply"], *args)
    assert result.exit_code == 2, result.stdout
    assert "Traceback" not in result.stderr


# --- stderr carries holecli's own messages only (issue 8, item 8) ------------------------------------


def test_library_warnings_do_not_reach_stderr(repo_root, tmp_path):
    # A command that makes numpy warn, run as the holecli program runs its commands.
    code = (
        "import sys, numpy, click\n"
        "from holecli import cli\n"
        "@cli.main.command()\n"
        "def warn():\n"
        "    numpy.array([numpy.nan]).astype(numpy.int64)\n"
        "    click.echo('done', err=True)\n"
        "sys.argv = ['holecli', 'warn']\n"
        "from holecli.__main__ import main\n"
        "sys.exit(main())\n"
    )
    env = dict(os.environ, PYTHONPATH=str(repo_root))
    env.pop("PYTHONWARNINGS", None)
    quiet = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=60)
    assert quiet.returncode == 0 and quiet.stderr == "done\n"
    # and the check is what silences it: asked for, the warning shows
    loud = subprocess.run([sys.executable, "-W", "default", "-c", code], capture_output=True, text=True, env=env,
                          timeout=60)
    assert "RuntimeWarning" in loud.stderr


def test_simulate_blind_hole_is_measured_at_its_edge_not_as_a_countersink(run, tmp_path):
    scan = tmp_path / "blind.ply"
    result = run("simulate", scan, "--bottom-depth", "0.5", "--bore-depth", "0.5")
    assert result.exit_code == 0, result.stderr
    points = load_points(scan)
    plain = tmp_path / "plain.ply"
    assert run("simulate", plain).exit_code == 0
    assert len(points) > len(load_points(plain))  # the floor is scanned
    detected = run("detect", scan)
    assert detected.exit_code == 0, detected.stderr
    (hole,) = json.loads(detected.stdout)["holes"]
    assert hole["diameter"] == pytest.approx(3.0, abs=0.01)


def test_simulate_floor_above_the_bore_wall_is_an_invalid_scene(run, tmp_path):
    result = run("simulate", tmp_path / "blind.ply", "--bottom-depth", "0.2", "--bore-depth", "0.5")
    _assert_one_line_error(result, "bottom_depth")
