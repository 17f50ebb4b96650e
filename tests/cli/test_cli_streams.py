"""Tests of pipes and streams on the command line: ``holecli detect -`` (stdin), ``--input-format``,
``--output -`` and the exit code of a broken pipe (real processes where a real pipe is needed)."""

import json
import os
import shutil
import subprocess
import sys
import tempfile

import pytest
from click.testing import CliRunner

from holecli import cli
from holecli.cli import options as cli_options
from holecli.io import INPUT_FORMATS, STDIN_NAME, WRITE_EXTENSIONS, read_stream, save_points

# The formats a scan can be written in here (E57, LAS and LAZ are read only: their stdin is tested in
# tests/io/test_scanner_formats.py's files through the same temporary-file path).
WRITTEN_FORMATS = tuple(extension[1:] for extension in WRITE_EXTENSIONS)
from holecli.simulation import synth

PROBLEMS_AT_EXIT = ("Traceback", "Exception ignored", "BrokenPipeError")


def _invoke(*args, stdin=None):
    """The CLI in-process with ``stdin`` (bytes) as standard input."""
    return CliRunner().invoke(cli.main, [str(arg) for arg in args], input=stdin)


def _comparable(record):
    """The record without what says where and how fast it was read (the options keep the rest)."""
    out = {key: value for key, value in record.items() if key not in ("file", "timing")}
    out["options"] = dict(out["options"], input_format=None)
    return out


def _quick_scan(seed):
    """About 3,000 points with one 2.5 mm hole: quick to measure."""
    scene = synth.SceneSpec(holes=(synth.HoleSpec(center=(0.0, 0.0), diameter=2.5),), extent=(-2.8, 2.8, -2.8, 2.8),
                            spacing=0.1, rotation_deg=(10.0, 5.0, 7.0 * seed), translation=(seed, 2.0, 3.0))
    return synth.make_scan(scene, seed)


@pytest.fixture(scope="module")
def scan_files(tmp_path_factory, table1_scan):
    """The Table I scan in every format (binary PLY and PCD, ascii PLY, the three text formats)."""
    folder = tmp_path_factory.mktemp("formats")
    files = {}
    for fmt in WRITTEN_FORMATS:
        files[fmt] = folder / f"table1.{fmt}"
        save_points(files[fmt], table1_scan.points)
    header = (f"ply\nformat ascii 1.0\nelement vertex {len(table1_scan.points)}\n"
              "property double x\nproperty double y\nproperty double z\nend_header\n")
    rows = "".join(f"{x!r} {y!r} {z!r}\n" for x, y, z in table1_scan.points.tolist())
    files["ascii ply"] = folder / "table1_ascii.ply"
    files["ascii ply"].write_text(header + rows)
    return files


@pytest.fixture(scope="module")
def quick_folder(tmp_path_factory):
    """Six quick scans (binary PLY) in a folder."""
    folder = tmp_path_factory.mktemp("quick")
    for seed in range(6):
        save_points(folder / f"scan{seed}.ply", _quick_scan(seed).points)
    return folder


# --- holecli detect - ----------------------------------------------------------------------------


@pytest.mark.parametrize("fmt", [*WRITTEN_FORMATS, "ascii ply"])
def test_detect_reads_stdin_in_every_format(run, scan_files, fmt):
    path = scan_files[fmt]
    from_file = run("detect", path)
    assert from_file.exit_code == 0, from_file.stderr
    result = _invoke("detect", "-", "--input-format", fmt.split()[-1], stdin=path.read_bytes())
    assert result.exit_code == 0, result.stderr
    record = json.loads(result.stdout)
    assert record["file"] == STDIN_NAME
    assert _comparable(record) == _comparable(json.loads(from_file.stdout))


def test_detect_reads_binary_ply_from_a_real_pipe(holecli_process, scan_files):
    data = scan_files["ply"].read_bytes()
    assert b"binary_little_endian" in data[:200]
    process = holecli_process("detect", "-", "--input-format", "ply", "--format", "csv", start=True,
                              stdin=subprocess.PIPE, text=False)
    stdout, stderr = process.communicate(data, timeout=120)
    assert process.returncode == 0, stderr
    rows = stdout.decode().splitlines()
    assert len(rows) == 2 and rows[1].startswith(f"{STDIN_NAME},0,")


def test_detect_stdin_needs_input_format(run):
    result = run("detect", "-")
    assert result.exit_code == cli.EXIT_USAGE
    assert "--input-format" in result.stderr and "stdin" in result.stderr
    assert result.stdout == ""


def test_detect_input_format_choices_are_checked(run):
    result = run("detect", "-", "--input-format", "asc")
    assert result.exit_code == cli.EXIT_USAGE
    assert "asc" in result.stderr


@pytest.mark.parametrize("damage", ["truncated", "extra bytes", "empty", "text as ply"])
def test_detect_stdin_refuses_damaged_data_like_a_file(scan_files, damage):
    data = scan_files["ply"].read_bytes()
    stdin = {"truncated": data[:-100], "extra bytes": data + b"\0" * 24, "empty": b"",
             "text as ply": scan_files["csv"].read_bytes()}[damage]
    result = _invoke("detect", "-", "--input-format", "ply", stdin=stdin)
    assert result.exit_code == cli.EXIT_INPUT, result.stderr
    assert result.stdout == ""
    lines = result.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"Error: {STDIN_NAME}: "), result.stderr


def test_detect_stdin_beyond_the_bound_is_refused(scan_files, monkeypatch):
    monkeypatch.setattr("holecli.io.stream.MAX_STREAM_BYTES", 1000)
    result = _invoke("detect", "-", "--input-format", "ply", stdin=scan_files["ply"].read_bytes())
    assert result.exit_code == cli.EXIT_INPUT
    assert result.stderr == f"Error: {STDIN_NAME}: more than 1000 bytes: too large to read from a stream " \
                            "(give the file's name instead)\n"


def test_read_stream_reads_no_further_than_its_bound_and_leaves_no_temporary(tmp_path, monkeypatch):
    import io

    from holecli.errors import LoadError

    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))

    class Endless(io.RawIOBase):
        taken = 0

        def readable(self):
            return True

        def readinto(self, buffer):
            buffer[:] = b"0" * len(buffer)
            self.taken += len(buffer)
            return len(buffer)

    endless = Endless()
    with pytest.raises(LoadError, match="more than 5000000 bytes"):
        read_stream(endless, "xyz", max_bytes=5_000_000)
    assert endless.taken <= 5_000_001
    cloud = read_stream(io.BytesIO(b"0 0 0\n1 0 0\nnan 0 0\n0 1 0\n"), "xyz", name="-")
    assert (cloud.path, cloud.dropped, cloud.points.shape) == ("-", 1, (3, 3))
    assert os.listdir(tmp_path) == []


def test_detect_stdin_that_is_a_terminal_is_refused_without_waiting(holecli_process):
    import pty

    leader, follower = pty.openpty()
    try:
        result = holecli_process("detect", "-", "--input-format", "ply", stdin=follower, capture_output=True,
                                 timeout=60)
    finally:
        os.close(leader)
        os.close(follower)
    assert result.returncode == cli.EXIT_INPUT
    assert result.stderr.startswith(f"Error: {STDIN_NAME}: is a terminal")
    assert len(result.stderr.splitlines()) == 1


def test_detect_stdin_failure_keeps_an_existing_output_file(tmp_path):
    output = tmp_path / "result.json"
    output.write_text("the old result\n")
    result = _invoke("detect", "-", "--input-format", "csv", "-o", output, stdin=b"x,y,z\n1,2\n")
    assert result.exit_code == cli.EXIT_INPUT
    assert output.read_text() == "the old result\n"
    assert os.listdir(tmp_path) == ["result.json"]


# --- --input-format on files ---------------------------------------------------------------------


@pytest.mark.parametrize("fmt, odd_name", [("xyz", "scan.asc"), ("ply", "scan.dat"), ("pcd", "scan.PCD.bak"),
                                           ("csv", "scan")])
def test_detect_input_format_overrides_the_extension(run, scan_files, tmp_path, fmt, odd_name):
    odd = tmp_path / odd_name
    shutil.copy(scan_files[fmt], odd)
    refused = run("detect", odd)
    assert refused.exit_code == cli.EXIT_INPUT and "unsupported extension" in refused.stderr
    result = run("detect", odd, "--input-format", fmt.upper())
    assert result.exit_code == 0, result.stderr
    record = json.loads(result.stdout)
    assert record["file"] == str(odd)
    assert _comparable(record) == _comparable(json.loads(run("detect", scan_files[fmt]).stdout))


def test_detect_input_format_reads_a_file_in_that_format_and_refuses_another(run, scan_files):
    result = run("detect", scan_files["ply"], "--input-format", "csv")
    assert result.exit_code == cli.EXIT_INPUT
    assert result.stderr.startswith(f"Error: {scan_files['ply']}: ")


def test_batch_input_format_takes_every_file_the_pattern_matches(run, scan_files, tmp_path):
    for name in ("a.asc", "b.ASC"):
        shutil.copy(scan_files["xyz"], tmp_path / name)
    shutil.copy(scan_files["ply"], tmp_path / "c.ply")
    (tmp_path / "notes.md").write_text("not a cloud\n")
    (tmp_path / ".hidden.asc").write_text("0 0 0\n")

    without = run("batch", tmp_path, "-j", "1")
    assert [json.loads(line)["file"] for line in without.stdout.splitlines()] == [str(tmp_path / "c.ply")]

    result = run("batch", tmp_path, "--input-format", "xyz", "--pattern", "*.asc", "-j", "1")
    assert result.exit_code == 0, result.stderr
    records = [json.loads(line) for line in result.stdout.splitlines()]
    assert [record["file"] for record in records] == [str(tmp_path / "a.asc"), str(tmp_path / "b.ASC")]
    assert all(len(record["holes"]) == 1 for record in records)

    # without --pattern every (visible) file of the folder is read in that format
    everything = run("batch", tmp_path, "--input-format", "xyz", "-j", "1")
    assert everything.exit_code == cli.EXIT_FILE_FAILED
    by_file = {os.path.basename(record["file"]): record for record in map(json.loads, everything.stdout.splitlines())}
    assert sorted(by_file) == ["a.asc", "b.ASC", "c.ply", "notes.md"]
    assert "error" in by_file["c.ply"] and "error" in by_file["notes.md"] and "holes" in by_file["a.asc"]


def test_batch_input_format_on_named_files_and_no_match(run, scan_files, tmp_path):
    odd = tmp_path / "scan.dat"
    shutil.copy(scan_files["pcd"], odd)
    result = run("batch", odd, "--input-format", "pcd")
    assert result.exit_code == 0, result.stderr
    assert json.loads(result.stdout)["holes"]
    none = run("batch", tmp_path, "--input-format", "pcd", "--pattern", "*.asc")
    assert none.exit_code == cli.EXIT_INPUT
    assert none.stderr == f"Error: {tmp_path}: no files matching '*.asc' found\n"


# --- --output - ----------------------------------------------------------------------------------


@pytest.mark.parametrize("fmt", ["json", "csv", "table"])
def test_detect_output_dash_writes_every_format_to_stdout(run, scan_files, tmp_path, monkeypatch, fmt):
    monkeypatch.chdir(tmp_path)
    expected = run("detect", scan_files["ply"], "--format", fmt)
    result = run("detect", scan_files["ply"], "--format", fmt, "--output", "-")
    assert result.exit_code == 0, result.stderr
    if fmt == "json":
        assert _comparable(json.loads(result.stdout)) == _comparable(json.loads(expected.stdout))
    else:
        assert result.stdout.splitlines()[:2] == expected.stdout.splitlines()[:2]
    assert os.listdir(tmp_path) == []


def test_output_dash_never_touches_a_file_named_dash(run, quick_folder, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "-").write_text("keep me\n")
    detect = run("detect", quick_folder / "scan0.ply", "-o", "-")
    assert detect.exit_code == 0 and json.loads(detect.stdout)["holes"]
    batch = run("batch", quick_folder, "-o", "-", "-j", "1")
    assert batch.exit_code == 0 and len(batch.stdout.splitlines()) == 6
    assert (tmp_path / "-").read_text() == "keep me\n"
    assert os.listdir(tmp_path) == ["-"]
    # the file itself is reached as ./-
    assert run("detect", quick_folder / "scan0.ply", "-o", "./-").exit_code == 0
    assert json.loads((tmp_path / "-").read_text())["holes"]


@pytest.mark.parametrize("fmt", ["jsonl", "csv"])
def test_batch_output_dash_is_stdout(run, quick_folder, tmp_path, monkeypatch, fmt):
    monkeypatch.chdir(tmp_path)
    expected = run("batch", quick_folder, "--format", fmt, "-j", "1")
    result = run("batch", quick_folder, "--format", fmt, "-j", "1", "--output", "-")
    assert result.exit_code == 0, result.stderr
    lines = result.stdout.splitlines()
    assert len(lines) == 6 + (fmt == "csv")
    if fmt == "csv":
        assert lines[0] == expected.stdout.splitlines()[0]
    else:
        assert [json.loads(line)["file"] for line in lines] == [json.loads(line)["file"]
                                                                 for line in expected.stdout.splitlines()]
    assert os.listdir(tmp_path) == []


def test_batch_resume_needs_a_real_output(run, quick_folder):
    result = run("batch", quick_folder, "-o", "-", "--resume")
    assert result.exit_code == cli.EXIT_USAGE and "--resume needs --output" in result.stderr


# --- broken pipes --------------------------------------------------------------------------------


def test_exit_code_help_documents_the_broken_pipe():
    assert cli.EXIT_BROKEN_PIPE == 141
    assert "141  broken pipe" in cli.EXIT_CODES_HELP
    assert "141  broken pipe" in cli.BATCH_EXIT_CODES_HELP


def _assert_quiet_broken_pipe(returncode, stderr, name="stdout"):
    assert returncode == cli.EXIT_BROKEN_PIPE, stderr
    assert not any(problem in stderr for problem in PROBLEMS_AT_EXIT), stderr
    lines = stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"Error: {name}: broken pipe"), stderr


@pytest.mark.parametrize("fmt", ["json", "csv", "table"])
def test_detect_into_a_pipe_closed_before_the_result_exits_141(holecli_process, scan_files, fmt):
    with holecli_process("detect", scan_files["ply"], "--format", fmt, start=True) as process:
        process.stdout.close()  # the only reader goes away before holecli writes: its write fails with EPIPE
        stderr = process.stderr.read()
        process.wait(timeout=120)
    _assert_quiet_broken_pipe(process.returncode, stderr)


def test_detect_into_a_pipe_whose_reader_read_everything_exits_0(holecli_process, scan_files):
    result = holecli_process("detect", scan_files["ply"], "--format", "csv")
    assert result.returncode == 0 and result.stderr == ""


def _consumer(lines):
    """A ``head -n LINES``: coreutils' head when there is one, else the same in Python."""
    head = shutil.which("head")
    if head:
        return [head, "-n", str(lines)]
    return [sys.executable, "-c", f"import sys\nfor _ in range({lines}): sys.stdout.write(sys.stdin.readline())"]


def _batch_into(holecli_process, consumer, *args, **popen_options):
    """``holecli batch ARGS | consumer``: (holecli's exit code, its stderr, the consumer's stdout)."""
    with holecli_process("batch", *args, start=True, **popen_options) as batch:
        with subprocess.Popen(consumer, stdin=batch.stdout, stdout=subprocess.PIPE, text=True) as reader:
            batch.stdout.close()  # the consumer holds the only read end
            consumed, _ = reader.communicate(timeout=120)
        stderr = batch.stderr.read() if batch.stderr else None
        batch.wait(timeout=120)
    return batch.returncode, stderr, consumed


@pytest.mark.parametrize("fmt", ["jsonl", "csv"])
def test_batch_into_head_exits_141_and_stops(holecli_process, quick_folder, fmt):
    # head reads the first line and exits; the batch measures on (-j 1, six files) and its next
    # write fails.
    code, stderr, consumed = _batch_into(holecli_process, _consumer(1), quick_folder, "--format", fmt, "-j", "1")
    _assert_quiet_broken_pipe(code, stderr)
    assert "holecli batch stopped after" in stderr and "of 6 files" in stderr
    assert len(consumed.splitlines()) == 1
    if fmt == "jsonl":
        assert json.loads(consumed)["holes"]


def test_batch_into_head_with_stderr_on_the_same_pipe_says_nothing_more(holecli_process, quick_folder):
    code, stderr, consumed = _batch_into(holecli_process, _consumer(1), quick_folder, "-j", "1",
                                         stderr=subprocess.STDOUT)
    assert code == cli.EXIT_BROKEN_PIPE
    assert stderr is None or stderr == ""
    assert not any(problem in consumed for problem in PROBLEMS_AT_EXIT)
    assert json.loads(consumed)["holes"]


def test_batch_stopped_by_a_broken_pipe_is_resumable(holecli_process, quick_folder, tmp_path):
    # `holecli batch | head -2 > kept.jsonl`, then `--resume -o kept.jsonl` measures the rest.
    code, stderr, consumed = _batch_into(holecli_process, _consumer(2), quick_folder, "-j", "1")
    _assert_quiet_broken_pipe(code, stderr)
    kept = tmp_path / "kept.jsonl"
    kept.write_text(consumed)
    assert len(consumed.splitlines()) == 2
    resumed = holecli_process("batch", quick_folder, "-j", "2", "-o", kept, "--resume")
    assert resumed.returncode == 0, resumed.stderr
    files = [json.loads(line)["file"] for line in kept.read_text().splitlines()]
    assert sorted(files) == sorted(str(quick_folder / f"scan{seed}.ply") for seed in range(6))


def test_batch_output_fifo_whose_reader_goes_away_exits_141(holecli_process, quick_folder, tmp_path):
    fifo = tmp_path / "records"
    os.mkfifo(fifo)
    # the read end is open before batch starts (a FIFO without a reader is refused, not waited for),
    # and a writer of the test's own holds it until batch writes (a FIFO without a writer reads as ended)
    descriptor = os.open(fifo, os.O_RDONLY | os.O_NONBLOCK)
    holder = os.open(fifo, os.O_WRONLY)
    os.set_blocking(descriptor, True)
    batch = holecli_process("batch", quick_folder, "-j", "1", "-o", fifo, start=True)
    with os.fdopen(descriptor) as reader:
        first = reader.readline()
        os.close(holder)
    stdout, stderr = batch.communicate(timeout=120)
    assert json.loads(first)["holes"]
    assert stdout == ""
    _assert_quiet_broken_pipe(batch.returncode, stderr, name=str(fifo))
    assert os.listdir(tmp_path) == ["records"]


def test_batch_output_fifo_without_a_reader_is_refused_not_waited_for(holecli_process, quick_folder, tmp_path):
    fifo = tmp_path / "records"
    os.mkfifo(fifo)
    # without the non-blocking open this never ends: the timeout fails the test
    batch = holecli_process("batch", quick_folder, "-j", "1", "-o", fifo, timeout=90)
    assert batch.returncode == 3, batch.stderr
    assert batch.stderr.startswith("Error: ") and len(batch.stderr.strip().splitlines()) == 1, batch.stderr
    assert str(fifo) in batch.stderr and "no process reads" in batch.stderr
    assert batch.stdout == ""


# --- the copy of stdin leaves nothing behind, even when killed (issue 23, item 7) ------------------


def _copies(folder):
    return [name for name in os.listdir(folder) if name.startswith("holecli-stdin-")]


def test_detect_stdin_killed_mid_copy_leaves_no_temporary(holecli_process, repo_root, tmp_path):
    import signal

    env = dict(os.environ, PYTHONPATH=str(repo_root), TMPDIR=str(tmp_path))
    env.pop("PYTHONWARNINGS", None)
    process = holecli_process("detect", "-", "--input-format", "xyz", start=True, stdin=subprocess.PIPE, env=env,
                               text=False)
    try:
        chunk = b"0 0 0\n" * (1 << 18)  # 1.5 MB: written only as fast as holecli copies it
        for _ in range(4):
            process.stdin.write(chunk)
            process.stdin.flush()
        # holecli has copied most of it now (a pipe holds 64 KiB): the copy is being written
        assert process.poll() is None
        assert _copies(tmp_path) == []  # it has no name to leave behind
    finally:
        process.send_signal(signal.SIGKILL)
        process.wait(30)
        process.stdin.close()
        process.stdout.close()
        process.stderr.close()
    assert process.returncode == -signal.SIGKILL
    assert os.listdir(tmp_path) == []


def test_read_stream_removes_the_copies_that_killed_processes_left(tmp_path, monkeypatch):
    import io
    import time

    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    left = tmp_path / f"holecli-stdin-{dead.pid}-k2j4h5g3.ply"  # a killed holecli's
    running = tmp_path / f"holecli-stdin-{os.getppid()}-a1b2c3d4.ply"  # a holecli still copying
    legacy_old = tmp_path / "holecli-stdin-x8y7z6w5.csv"  # holecli before 0.2: no pid, an hour old
    legacy_new = tmp_path / "holecli-stdin-q1w2e3r4.csv"  # ... and one being written now
    other = tmp_path / "holecli-stdin-notes.txt"
    for path in (left, running, legacy_old, legacy_new, other):
        path.write_bytes(b"ply\n")
    two_hours_ago = time.time() - 7200
    os.utime(legacy_old, (two_hours_ago, two_hours_ago))
    cloud = read_stream(io.BytesIO(b"0 0 0\n1 0 0\n0 1 0\n"), "xyz")
    assert cloud.points.shape == (3, 3)
    assert sorted(_copies(tmp_path)) == sorted(path.name for path in (running, legacy_new, other))


def test_read_stream_without_proc_names_its_copy_by_pid_and_removes_it(tmp_path, monkeypatch):
    import io

    import holecli.io.stream as holecli_io

    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    monkeypatch.setattr(holecli_io, "_FD_FOLDER", str(tmp_path / "no-proc-{pid}"))
    seen = []
    real_read = holecli_io._read_checked

    def read_checked(path, *args, **kwargs):
        seen.append((os.path.basename(path), _copies(tmp_path)))
        return real_read(path, *args, **kwargs)

    monkeypatch.setattr(holecli_io, "_read_checked", read_checked)
    cloud = read_stream(io.BytesIO(b"x,y,z\n0,0,0\n1,0,0\n0,1,0\n"), "csv")
    assert cloud.points.shape == (3, 3)
    [(name, copies)] = seen
    assert name.startswith(f"holecli-stdin-{os.getpid()}-") and name.endswith(".csv") and copies == [name]
    assert os.listdir(tmp_path) == []
