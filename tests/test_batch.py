"""Tests of holecli.batch: file discovery, measuring in worker processes, writing, resuming, counting."""

import json
import os
import signal
from pathlib import Path

import pytest

from holecli import batch
from holecli.batch import output, pool
from holecli.batch import FileSummary, RecordWriter, ResumeError, Tally
from holecli.errors import LoadError
from holecli.io import save_points
from holecli.report import BATCH_CSV_COLUMNS
from holecli.simulation import synth
from holecli.tolerance import nominal_spec

OPTIONS = {"method": "robust"}


def small_scan(seed, diameter=2.5):
    """About 3,000 points on a 0.1 mm grid with one hole: quick to measure."""
    scene = synth.SceneSpec(holes=(synth.HoleSpec(center=(0.0, 0.0), diameter=diameter),),
                            extent=(-2.8, 2.8, -2.8, 2.8), spacing=0.1, rotation_deg=(10.0, 5.0, 7.0 * seed),
                            translation=(seed, 2.0, 3.0))
    return synth.make_scan(scene, seed)


@pytest.fixture(scope="module")
def scans(tmp_path_factory):
    """Three good PLY scans: [path], with their ground-truth diameter 2.5."""
    folder = tmp_path_factory.mktemp("good")
    paths = []
    for seed in range(3):
        path = folder / f"scan{seed}.ply"
        save_points(path, small_scan(seed).points)
        paths.append(str(path))
    return paths


def _touch(path, text="x"):
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    return path


# --- find_scans --------------------------------------------------------------------------------------


@pytest.fixture
def tree(tmp_path):
    for name in ("b.ply", "a.PCD", "c.csv", "d.TXT", "e.xyz", "notes.md", "scan.obj", ".hidden.ply",
                 "sub/f.ply", "sub/deeper/g.csv", "sub/part7_h.ply", ".git/i.ply", "part7_j.ply"):
        _touch(tmp_path / name)
    (tmp_path / "folder.ply").mkdir()  # a folder with a cloud's extension is not a file
    return tmp_path


def _names(paths, root):
    return [os.path.relpath(path, root) for path in paths]


def test_find_scans_takes_the_clouds_directly_in_a_folder_sorted(tree):
    found = batch.find_scans([str(tree)])
    assert _names(found, tree) == ["a.PCD", "b.ply", "c.csv", "d.TXT", "e.xyz", "part7_j.ply"]
    assert all(path.startswith(str(tree)) for path in found)


def test_find_scans_recursive_walk(tree):
    found = batch.find_scans([str(tree)], recursive=True)
    assert _names(found, tree) == ["a.PCD", "b.ply", "c.csv", "d.TXT", "e.xyz", "part7_j.ply",
                                   os.path.join("sub", "deeper", "g.csv"), os.path.join("sub", "f.ply"),
                                   os.path.join("sub", "part7_h.ply")]


@pytest.mark.parametrize(
    "pattern, recursive, expected",
    [
        ("part7_*", False, ["part7_j.ply"]),
        ("PART7_*", True, ["part7_j.ply", "sub/part7_h.ply"]),  # case-insensitive
        ("*.ply", True, ["b.ply", "part7_j.ply", "sub/f.ply", "sub/part7_h.ply"]),
        ("sub/*", True, ["sub/deeper/g.csv", "sub/f.ply", "sub/part7_h.ply"]),  # with a /: the path below
        ("*.md", True, []),  # the pattern narrows the clouds, it does not add other files
    ],
)
def test_find_scans_pattern(tree, pattern, recursive, expected):
    found = batch.find_scans([str(tree)], recursive=recursive, pattern=pattern)
    assert [name.replace(os.sep, "/") for name in _names(found, tree)] == expected


def test_find_scans_files_given_are_taken_as_they_are(tree):
    found = batch.find_scans([str(tree / "notes.md"), str(tree / "b.ply")], pattern="zzz")
    assert _names(found, tree) == ["b.ply", "notes.md"]


def test_find_scans_a_file_reached_twice_is_listed_once(tree):
    spelled_apart = os.path.join(str(tree), "sub", "..", "b.ply")
    found = batch.find_scans([str(tree / "b.ply"), str(tree), str(tree / "b.ply"), spelled_apart])
    assert _names(found, tree).count("b.ply") == 1
    assert len(found) == len(set(map(os.path.realpath, found))) == 6


def test_find_scans_leaves_out_the_excluded_file(tree):
    found = batch.find_scans([str(tree)], exclude=[str(tree / "c.csv")])
    assert "c.csv" not in _names(found, tree)


def test_find_scans_leaves_out_the_excluded_folders_files_even_given_by_name(tree):
    plots = tree / "plots"
    plots.mkdir()
    (plots / "a.ply").write_text("ply\n")
    found = batch.find_scans([str(tree), str(plots / "a.ply")], recursive=True, exclude_folders=[str(plots)])
    assert not any(name.startswith("plots") for name in _names(found, tree))
    assert "b.ply" in _names(found, tree)


def test_scan_stem():
    assert batch.scan_stem("scans/A1.ply") == "A1"
    assert batch.scan_stem("A1.tar.ply") == "A1.tar"
    assert batch.scan_stem("scans/.ply") == ".ply"  # a hidden name has no extension


def test_find_scans_missing_path(tree):
    with pytest.raises(LoadError, match="no such file or folder"):
        batch.find_scans([str(tree), str(tree / "missing")])


def test_default_jobs_is_at_least_one():
    assert batch.default_jobs() >= 1


# --- measure_record ----------------------------------------------------------------------------------


def test_measure_record_is_the_detect_record(scans):
    from holecli import detect, load_points

    record = batch.measure_record(scans[0], OPTIONS)
    expected = detect(load_points(scans[0]), **OPTIONS).to_dict()
    assert record["file"] == scans[0]
    assert record["path"] == os.path.realpath(scans[0])
    assert set(record) == set(expected) | {"path"}
    assert record["holes"] == expected["holes"]
    assert record["holes"][0]["diameter"] == pytest.approx(2.5, abs=0.05)


def test_measure_record_with_a_spec_has_the_verdicts(scans):
    record = batch.measure_record(scans[0], OPTIONS, nominal_spec(diameter=2.5, tolerance=0.05))
    assert record["verdict"]["in_tolerance"] is True
    assert record["holes"][0]["in_tolerance"] is True


def test_measure_record_of_a_bad_file_is_an_error_record(tmp_path):
    path = _touch(tmp_path / "empty.csv", "")
    record = batch.measure_record(str(path), OPTIONS)
    assert set(record) == {"schema_version", "holecli_version", "file", "path", "error"}
    assert record["file"] == str(path)
    assert record["path"] == os.path.realpath(path)
    assert record["error"].startswith(f"{path}: ")


def test_measure_record_of_a_bug_is_an_error_record(scans, monkeypatch):
    def broken(points, **options):
        raise IndexError("index 7 is out of bounds\nsecond line")

    monkeypatch.setattr("holecli.pipeline.detect", broken)
    record = batch.measure_record(scans[0], OPTIONS)
    assert "internal error (a bug: please report it" in record["error"]
    assert "IndexError: index 7 is out of bounds second line" in record["error"]
    assert "\n" not in record["error"]


# --- measure_all -------------------------------------------------------------------------------------


@pytest.mark.parametrize("jobs", [1, 2])
def test_measure_all_yields_one_record_per_file(scans, tmp_path, jobs):
    bad = str(_touch(tmp_path / "bad.csv", "x,y,z\n"))
    records = list(batch.measure_all([*scans, bad], OPTIONS, jobs=jobs))
    assert sorted(record["file"] for record in records) == sorted([*scans, bad])
    by_file = {record["file"]: record for record in records}
    assert "error" in by_file[bad]
    assert all(len(by_file[path]["holes"]) == 1 for path in scans)


def test_measure_all_of_nothing():
    assert list(batch.measure_all([], OPTIONS, jobs=2)) == []


def test_measure_all_stops_when_asked(scans):
    calls = []

    def should_stop():
        calls.append(1)
        return True

    # A poll long enough that should_stop is asked only once a file has finished, not because the
    # first file took longer than a poll on a loaded machine (then nothing would have been yielded).
    records = list(batch.measure_all(scans * 4, OPTIONS, jobs=1, should_stop=should_stop, poll_seconds=60.0))
    assert 1 <= len(records) < 12
    assert calls == [1]


def _report_worker_signals(path, options, spec=None, explain=False):
    return {"file": path, "sigint_ignored": signal.getsignal(signal.SIGINT) == signal.SIG_IGN,
            "pid": os.getpid(), "pipeline_imported": "holecli.pipeline" in __import__("sys").modules}


def test_workers_ignore_sigint_and_have_the_pipeline_imported(scans, monkeypatch):
    # The workers are forked from this process, so they see the replaced function. The parent has
    # SIGINT's default handler, as an interactive run does (a suite started in the background by a
    # shell without job control inherits SIGINT ignored, which would make the check vacuous).
    monkeypatch.setattr(pool, "measure_record", _report_worker_signals)
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        records = list(batch.measure_all(scans * 3, OPTIONS, jobs=2))
        assert signal.getsignal(signal.SIGINT) is signal.default_int_handler  # the parent's is untouched
    finally:
        signal.signal(signal.SIGINT, previous)
    assert len(records) == 9
    assert all(record["sigint_ignored"] and record["pipeline_imported"] for record in records)
    assert os.getpid() not in {record["pid"] for record in records}
    assert len({record["pid"] for record in records}) <= 2  # the workers live for the whole batch


def test_a_file_that_kills_its_worker_gets_an_error_record(scans, tmp_path, monkeypatch):
    crash = str(_touch(tmp_path / "crash.ply"))
    measure = batch.measure_record

    def dying(path, options, spec=None, explain=False):
        if path == crash:
            os._exit(9)
        return measure(path, options, spec, explain)

    monkeypatch.setattr(pool, "measure_record", dying)
    records = list(batch.measure_all([scans[0], crash, scans[1], scans[2]], OPTIONS, jobs=2))
    by_file = {record["file"]: record for record in records}
    assert sorted(by_file) == sorted([*scans, crash])
    assert len(records) == 4
    assert "worker process measuring this file died" in by_file[crash]["error"]
    assert all("holes" in by_file[path] for path in scans)


def test_compressed_pcd_is_recognized_from_its_header(tmp_path):
    header = "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 1\nHEIGHT 1\n"
    compressed = _touch(tmp_path / "c.pcd", header + "POINTS 1\nDATA binary_compressed\n")
    plain = _touch(tmp_path / "p.pcd", header + "POINTS 1\nDATA binary\n")
    assert pool._is_compressed_pcd(str(compressed))
    assert not pool._is_compressed_pcd(str(plain))
    assert not pool._is_compressed_pcd(str(tmp_path / "missing.pcd"))
    assert not pool._is_compressed_pcd(str(_touch(tmp_path / "c.ply", "DATA binary_compressed\n")))


# --- writing and resuming ----------------------------------------------------------------------------


def _records():
    good = {"file": "a.ply", "points": 10, "holes": [{"index": 0, "center": [0.0, 0.0, 0.0], "diameter": 3.0,
                                                      "normal": [0.0, 0.0, 1.0], "rim_points": 20}]}
    return [good, {"file": "b.csv", "error": "b.csv: empty file"}, {"file": "c.ply", "points": 10, "holes": []}]


def test_record_writer_writes_each_record_in_one_call():
    calls = []
    writer = RecordWriter(calls.append, "jsonl")
    for record in _records():
        writer.write(record)
    assert len(calls) == 3
    assert all(call.endswith("\n") and call.count("\n") == 1 for call in calls)
    assert [json.loads(call) for call in calls] == _records()


def test_record_writer_csv_header_once_and_one_call_per_file():
    calls = []
    writer = RecordWriter(calls.append, "csv")
    two_holes = dict(_records()[0], holes=_records()[0]["holes"] * 2)
    writer.write(two_holes)
    writer.write(_records()[1])
    assert calls[0] == ",".join(BATCH_CSV_COLUMNS) + "\n"
    assert calls[1].count("\n") == 2 and calls[2].count("\n") == 1
    assert calls[2].rstrip("\n").endswith("b.csv: empty file,")  # then the empty path
    assert RecordWriter(calls.append, "csv", header=False) and len(calls) == 3
    with pytest.raises(ValueError, match="fmt must be one of"):
        RecordWriter(calls.append, "json")


def test_output_appends_on_resume_or_empties(tmp_path):
    path = tmp_path / "out.jsonl"
    path.write_text('{"file": "old.ply"}\n')
    with batch.BatchOutput(str(path), "jsonl", resume=True) as output:
        assert [summary.file for summary in output.earlier] == ["old.ply"]
        output.write('{"file": "new.ply"}\n')
    assert path.read_text() == '{"file": "old.ply"}\n{"file": "new.ply"}\n'
    with batch.BatchOutput(str(path), "jsonl", overwrite=True) as output:
        assert output.earlier == [] and output.needs_header
        output.write("fresh ü\n")
    assert path.read_text(encoding="utf-8") == "fresh ü\n"


def test_an_output_that_holds_records_is_neither_replaced_nor_touched_without_resume_or_overwrite(tmp_path):
    """Issue 25, item 4: yesterday's 30 records were replaced by today's 1."""
    path = tmp_path / "out.jsonl"
    path.write_text('{"file": "old.ply"}\n')
    with pytest.raises(batch.OutputNotEmptyError, match=r"holds 20 bytes.*--resume.*--overwrite"):
        batch.BatchOutput(str(path), "jsonl")
    assert path.read_text() == '{"file": "old.ply"}\n'
    path.write_text("")  # an empty file is written as a new one
    with batch.BatchOutput(str(path), "jsonl") as output:
        output.write("new\n")
    assert path.read_text() == "new\n"


def test_resume_of_a_missing_file(tmp_path):
    with batch.BatchOutput(str(tmp_path / "none.jsonl"), "jsonl", resume=True) as output:
        assert (output.earlier, output.needs_header) == ([], False)
    with batch.BatchOutput(str(tmp_path / "none.csv"), "csv", resume=True) as output:
        assert (output.earlier, output.needs_header) == ([], True)


def test_resume_jsonl_cuts_a_partial_last_line(tmp_path):
    path = tmp_path / "out.jsonl"
    lines = [json.dumps(record) + "\n" for record in _records()]
    path.write_text("".join(lines) + '{"file": "d.ply", "poi')
    with batch.BatchOutput(str(path), "jsonl", resume=True) as output:
        summaries, header = output.earlier, output.needs_header
    assert path.read_text() == "".join(lines)
    assert [summary.file for summary in summaries] == ["a.ply", "b.csv", "c.ply"]
    assert [summary.failed for summary in summaries] == [False, True, False]
    assert [summary.holes for summary in summaries] == [1, 0, 0]
    assert header is False


def test_resume_csv(tmp_path):
    path = tmp_path / "out.csv"
    calls = []
    writer = RecordWriter(calls.append, "csv")
    for record in _records():
        writer.write(record)
    path.write_text("".join(calls) + "d.ply,0,1.0")
    with batch.BatchOutput(str(path), "csv", resume=True) as output:
        summaries, header = output.earlier, output.needs_header
    assert path.read_text() == "".join(calls)
    assert [(summary.file, summary.failed, summary.holes) for summary in summaries] == [
        ("a.ply", False, 1), ("b.csv", True, 0), ("c.ply", False, 0)]
    assert header is False
    path.write_text(",".join(BATCH_CSV_COLUMNS)[:20])  # cut inside the header: start again
    with batch.BatchOutput(str(path), "csv", resume=True) as output:
        assert (output.earlier, output.needs_header) == ([], True)
    assert path.read_text() == ""


@pytest.mark.parametrize(
    "fmt, text, match",
    [
        ("jsonl", '{"file": "a.ply"}\nnot json\n', "line 2 is not a holecli batch record"),
        ("jsonl", '[1, 2]\n', "line 1 is not a holecli batch record"),
        ("jsonl", '{"points": 3}\n', "line 1 is not a holecli batch record"),
        ("csv", "file,hole,center_x\na.ply,0,1\n", "its header is not the header of holecli batch"),
        ("csv", ",".join(output._SCHEMA_1_COLUMNS[:-1]) + "\na.ply,0\n", "written by holecli 0.1, without the path"),
        ("csv", ",".join(output._SCHEMA_1_COLUMNS) + "\na.ply,0\n", "before schema 2.0, without the provenance"),
        ("csv", ",".join(BATCH_CSV_COLUMNS) + "\na.ply,0\n", "a row has 2 columns"),
        ("jsonl", b"\xff\xfe\n", "not a UTF-8 text file"),
    ],
)
def test_resume_refuses_other_files_and_leaves_them_untouched(tmp_path, fmt, text, match):
    path = tmp_path / f"out.{fmt}"
    data = text if isinstance(text, bytes) else text.encode()
    path.write_bytes(data + b"partial last line")
    with pytest.raises(ResumeError, match=match):
        batch.BatchOutput(str(path), fmt, resume=True)
    assert path.read_bytes() == data + b"partial last line"


# --- counting ----------------------------------------------------------------------------------------


def test_tally_of_records_and_csv_rows():
    tally = Tally()
    for record in _records():
        tally.add(record)
    verdict_record = {"file": "e.ply", "holes": [{}, {}], "verdict": {"checked": 2, "out_of_tolerance": 1,
                                                                      "missing": ["A3"], "in_tolerance": False}}
    tally.add(verdict_record)
    rows = [dict.fromkeys(BATCH_CSV_COLUMNS, "") for _ in range(3)]
    rows[0].update(file="f.ply", hole="0", in_tolerance="false")
    rows[1].update(file="f.ply", hole="1", in_tolerance="true")
    rows[2].update(file="f.ply", name="A2", in_tolerance="false")
    tally.add(FileSummary.of_csv_rows("f.ply", rows))
    assert (tally.files, tally.failed, tally.measured) == (5, 1, 4)
    assert (tally.holes, tally.without_hole, tally.out_of_tolerance, tally.missing) == (5, 1, 2, 2)


def test_csv_summary_of_a_record_written_by_the_writer_matches_the_record():
    calls = []
    writer = RecordWriter(calls.append, "csv", header=False)
    record = {"file": "g.ply", "holes": [{"index": 0, "center": [0, 0, 0], "diameter": 3.0, "normal": [0, 0, 1],
                                          "in_tolerance": False}],
              "verdict": {"checked": 1, "out_of_tolerance": 1, "missing": ["B"], "in_tolerance": False}}
    writer.write(record)
    import csv
    import io

    rows = [dict(zip(BATCH_CSV_COLUMNS, row)) for row in csv.reader(io.StringIO(calls[0]))]
    assert FileSummary.of_csv_rows("g.ply", rows) == FileSummary.of_record(record)


def test_module_does_not_import_click():
    modules = sorted(Path(batch.__file__).parent.glob("*.py"))
    assert len(modules) > 1  # the package and its modules
    for module in modules:
        source = module.read_text()
        assert "import click" not in source and "from click" not in source, module


def test_open3d_is_imported_by_the_pool_initializer_when_a_compressed_pcd_is_in_the_batch(scans, tmp_path,
                                                                                          monkeypatch):
    header = "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 30\nHEIGHT 1\nPOINTS 30\n"
    compressed = str(_touch(tmp_path / "c.pcd", header + "DATA binary_compressed\n"))
    log = tmp_path / "initializer.log"
    start = pool._start_worker

    def logged(options, spec, preload, parent, *rest):
        start(options, spec, preload, parent, *rest)
        with open(log, "a") as stream:
            stream.write(f"{','.join(preload)}\n")

    monkeypatch.setattr(pool, "_start_worker", logged)
    records = list(batch.measure_all([*scans, compressed] * 2, OPTIONS, jobs=2))
    assert len(records) == 8
    assert log.read_text().splitlines() == ["open3d", "open3d"]  # once per worker, not per file
    log.unlink()
    list(batch.measure_all(scans, OPTIONS, jobs=1))
    assert log.read_text().splitlines() == [""]  # no compressed PCD: not paid at all


# --- faults (issue 8, items 6, 9, 10, 11, 13) ----------------------------------------------------------


def test_a_fifo_is_an_error_record_and_never_opened(scans, tmp_path):
    fifo = tmp_path / "stream.pcd"
    os.mkfifo(fifo)  # opening it would block until a writer came
    records = []
    import threading

    worker = threading.Thread(target=lambda: records.extend(batch.measure_all([str(fifo), scans[0]], OPTIONS,
                                                                                  jobs=1)), daemon=True)
    worker.start()
    worker.join(60)
    assert not worker.is_alive(), "the batch hangs on a FIFO"
    by_file = {record["file"]: record for record in records}
    assert "not a regular file" in by_file[str(fifo)]["error"]
    assert by_file[scans[0]]["holes"]


def test_a_folder_holding_a_fifo_skips_it(tmp_path):
    _touch(tmp_path / "a.ply")
    os.mkfifo(tmp_path / "b.ply")
    assert _names(batch.find_scans([str(tmp_path)]), tmp_path) == ["a.ply"]


def test_a_worker_killed_with_the_only_file_in_flight_is_retried_alone(scans, tmp_path, monkeypatch):
    marker = tmp_path / "killed-once"
    measure = batch.measure_record

    def killed_the_first_time(path, options, spec=None, explain=False):
        if not marker.exists():
            marker.write_text("")
            os.kill(os.getpid(), signal.SIGKILL)  # as the out-of-memory killer would
        return measure(path, options, spec, explain)

    monkeypatch.setattr(pool, "measure_record", killed_the_first_time)
    (record,) = batch.measure_all([scans[0]], OPTIONS, jobs=1)
    assert "error" not in record and record["holes"]


def test_a_file_that_kills_its_worker_alone_too_gets_an_error_record(scans, monkeypatch):
    measure = batch.measure_record

    def always_killed(path, options, spec=None, explain=False):
        if path == scans[1]:
            os.kill(os.getpid(), signal.SIGKILL)
        return measure(path, options, spec, explain)

    monkeypatch.setattr(pool, "measure_record", always_killed)
    records = {record["file"]: record for record in batch.measure_all(scans, OPTIONS, jobs=2)}
    assert sorted(records) == sorted(scans)
    assert "died twice" in records[scans[1]]["error"]
    assert records[scans[0]]["holes"] and records[scans[2]]["holes"]


def test_workers_end_when_the_batch_process_is_killed(repo_root, scans, tmp_path):
    import subprocess
    import sys
    import time

    # A parent that starts a pool of two workers on slow files, then is killed with SIGKILL.
    code = (
        "import sys, time\n"
        "from holecli import batch\n"
        "from holecli.batch import pool\n"
        "def slow(path, options, spec=None, explain=False):\n"
        "    time.sleep(300)\n"
        "pool.measure_record = slow\n"
        "for record in batch.measure_all(sys.argv[1:], {'method': 'robust'}, jobs=2):\n"
        "    pass\n"
    )
    env = dict(os.environ, PYTHONPATH=str(repo_root))
    parent = subprocess.Popen([sys.executable, "-c", code, *scans], env=env)
    deadline = time.monotonic() + 30
    workers = []
    while time.monotonic() < deadline and len(workers) < 2:
        time.sleep(0.1)
        children = f"/proc/{parent.pid}/task/{parent.pid}/children"
        workers = [int(pid) for pid in Path(children).read_text().split()] if os.path.exists(children) else []
    assert len(workers) == 2, "the pool did not start"
    parent.kill()
    parent.wait()
    deadline = time.monotonic() + 10
    while time.monotonic() < deadline and any(_alive(pid) for pid in workers):
        time.sleep(0.05)
    alive = [pid for pid in workers if _alive(pid)]
    for pid in alive:
        os.kill(pid, signal.SIGKILL)
    assert not alive, "workers outlived their batch"


def _alive(pid):
    try:
        with open(f"/proc/{pid}/stat") as stream:
            return stream.read().split(")")[-1].split()[0] != "Z"  # a zombie has ended
    except FileNotFoundError:
        return False


def test_a_second_writer_of_the_same_output_is_refused_and_changes_nothing(tmp_path):
    path = tmp_path / "out.jsonl"
    path.write_text('{"file": "a.ply"}\n')
    with batch.BatchOutput(str(path), "jsonl", resume=True) as first:
        for resume in (False, True):
            with pytest.raises(batch.OutputBusyError, match="another holecli batch is writing this file"):
                batch.BatchOutput(str(path), "jsonl", resume=resume)
        assert path.read_text() == '{"file": "a.ply"}\n'
        first.write('{"file": "b.ply"}\n')
    with batch.BatchOutput(str(path), "jsonl", resume=True) as again:  # the lock went with the first
        assert [summary.file for summary in again.earlier] == ["a.ply", "b.ply"]


def test_the_output_lock_is_not_held_by_the_workers(scans, tmp_path):
    path = tmp_path / "out.jsonl"
    with batch.BatchOutput(str(path), "jsonl") as output:
        records = batch.measure_all(scans, OPTIONS, jobs=2)
        output.write(json.dumps(next(records)) + "\n")  # the workers are running now
        output.close()
        # the parent let go: the lock is free although the workers live on
        with batch.BatchOutput(str(path), "jsonl", resume=True) as second:
            assert len(second.earlier) == 1
        records.close()


@pytest.mark.parametrize("device", ["/dev/zero", "/dev/null"])
def test_resume_refuses_a_device(device):
    if not os.path.exists(device):
        pytest.skip(f"no {device}")
    with pytest.raises(ResumeError, match="not a regular file"):
        batch.BatchOutput(device, "jsonl", resume=True)


def test_output_to_a_device_is_written_directly(tmp_path):
    if not os.path.exists("/dev/null"):
        pytest.skip("no /dev/null")
    import stat

    with batch.BatchOutput("/dev/null", "jsonl") as output:
        output.write('{"file": "a.ply"}\n')
    assert stat.S_ISCHR(os.stat("/dev/null").st_mode)


def test_files_to_do_match_by_resolved_path(tmp_path, monkeypatch):
    scan = _touch(tmp_path / "scans" / "a.ply")
    _touch(tmp_path / "scans" / "b.ply")
    monkeypatch.chdir(tmp_path)
    record = {"file": "scans/a.ply", "path": batch.resolved_path("scans/a.ply"), "holes": []}
    monkeypatch.chdir(tmp_path / "scans")
    earlier = [FileSummary.of_record(record)]
    assert batch.files_to_do(["a.ply", "b.ply"], earlier) == ["b.ply"]
    assert batch.files_to_do([str(scan)], earlier) == []
    # a record of holecli 0.1 (no path) is resolved from the current folder
    assert batch.files_to_do(["a.ply"], [FileSummary.of_record({"file": "a.ply", "holes": []})]) == []


# --- issue 23: a file that kills or hangs a worker costs that file only ---------------------------------

PDAL_DATA = Path(__file__).parent / "data" / "pdal_cli"


def test_a_library_panic_in_a_worker_is_that_files_error_record(scans):
    # lazrs panics on a LAZ of LASzip 1.x (PDAL's file): pyo3's PanicException derives from
    # BaseException and cannot be pickled; it escaped the worker and ended the batch with no record
    # for that file or any after it.
    pytest.importorskip("laspy")
    pytest.importorskip("lazrs")
    laz = str(PDAL_DATA / "simple-laszip-compressor-version-1.2r0.laz")
    records = list(batch.measure_all([laz, *scans], OPTIONS, jobs=1))
    by_file = {record["file"]: record for record in records}
    assert sorted(by_file) == sorted([laz, *scans])
    assert by_file[laz]["error"].startswith(f"{laz}: ")
    assert all("holes" in by_file[path] for path in scans)


def _panic_of_lazrs():
    """Make lazrs (Rust, through pyo3) panic for real on PDAL's LASzip 1.x file, as its reader did."""
    import laspy

    with laspy.open(PDAL_DATA / "simple-laszip-compressor-version-1.2r0.laz") as reader:
        reader.read_points(10)


def test_any_base_exception_in_a_worker_is_that_files_error_record(scans, tmp_path, monkeypatch):
    # The same real panic, whatever a reader does about that file (readers get fixed; the batch must
    # survive the next library that panics): raised inside measure_record's reading, in a worker.
    pytest.importorskip("lazrs")
    import holecli.pipeline

    with pytest.raises(BaseException) as raised:
        _panic_of_lazrs()
    if isinstance(raised.value, Exception):
        pytest.skip("this lazrs no longer panics on LASzip 1.x files")
    panic = str(_touch(tmp_path / "panic.ply"))
    real_detect_file = holecli.pipeline.detect_file

    def detect_file(path, **options):
        if path == panic:
            _panic_of_lazrs()
        return real_detect_file(path, **options)

    monkeypatch.setattr(holecli.pipeline, "detect_file", detect_file)
    records = list(batch.measure_all([panic, *scans], OPTIONS, jobs=2))
    by_file = {record["file"]: record for record in records}
    assert sorted(by_file) == sorted([panic, *scans])
    assert "internal error" in by_file[panic]["error"] and "PanicException" in by_file[panic]["error"]
    assert all("holes" in by_file[path] for path in scans)


def test_measure_record_lets_a_keyboard_interrupt_through(scans, monkeypatch):
    # Outside a worker, Ctrl-C during measure_record must still stop the caller.
    def interrupted(path, **options):
        raise KeyboardInterrupt

    monkeypatch.setattr("holecli.pipeline.detect_file", interrupted)
    with pytest.raises(KeyboardInterrupt):
        batch.measure_record(scans[0], OPTIONS)


@pytest.mark.slow
def test_a_file_that_hangs_its_reader_gets_an_error_record_and_the_batch_ends(scans, repo_root):
    # PDAL's garbage_nVariableLength.las made laspy loop forever, memory growing: the batch never
    # ended. With a time limit per file it gets an error record (a refusal, once its reader is fixed)
    # and the other files are measured.
    import subprocess
    import sys

    pytest.importorskip("laspy")
    las = str(PDAL_DATA / "garbage_nVariableLength.las")
    env = dict(os.environ, PYTHONPATH=str(repo_root))
    done = subprocess.run([sys.executable, "-m", "holecli", "batch", las, scans[0], "--jobs", "1",
                           "--file-timeout", "3", "-q"], capture_output=True, text=True, env=env, timeout=120)
    records = {record["file"]: record for record in map(json.loads, done.stdout.splitlines())}
    assert sorted(records) == sorted([las, scans[0]])
    assert records[las]["error"].startswith(f"{las}: ")
    assert "holes" in records[scans[0]]
    assert done.returncode == 6
    assert "Traceback" not in done.stderr


@pytest.mark.slow
def test_a_file_larger_than_the_time_limit_gets_the_time_limit_record(tmp_path):
    # A real measurement cut by the limit: a scan of 1.4 million points cannot be read and measured
    # in 10 ms (it takes seconds).
    scene = synth.SceneSpec(holes=(synth.HoleSpec(center=(0.0, 0.0), diameter=2.5),), extent=(-30, 30, -30, 30),
                            spacing=0.05)
    big = str(tmp_path / "big.ply")
    save_points(big, synth.make_scan(scene, 0).points)
    [record] = batch.measure_all([big], OPTIONS, jobs=1, file_timeout=0.01)
    assert record["error"] == batch.timeout_message(big, 0.01)
    assert "within the time limit of 0.01 s per file (--file-timeout)" in record["error"]


def _native_loop(path, options, spec=None, explain=False):
    """A loop in native code that never returns to Python (as one in lazrs or libE57 would): a
    SIGALRM handler never runs, only the CPU limit can end it."""
    import collections
    import itertools

    if path.endswith("native.ply"):
        collections.deque(itertools.repeat(None, 10 ** 14), maxlen=0)
    return {"file": path, "pid": os.getpid()}


@pytest.mark.slow
def test_a_loop_in_native_code_is_ended_by_the_cpu_limit(scans, tmp_path, monkeypatch):
    native = str(_touch(tmp_path / "native.ply"))
    monkeypatch.setattr(pool, "measure_record", _native_loop)
    records = list(batch.measure_all([native, *scans], OPTIONS, jobs=1, file_timeout=1))
    by_file = {record["file"]: record for record in records}
    assert sorted(by_file) == sorted([native, *scans])
    assert by_file[native]["error"] == batch.timeout_message(native, 1)
    assert all("error" not in by_file[path] for path in scans)
