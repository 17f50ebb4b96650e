"""``holecli batch --store LOCATION --meta KEY=VALUE``: every record of the batch also in the results store."""

import json
import shutil

import pytest

from holecli.store import open_store


@pytest.fixture
def scans(tmp_path, repo_root):
    """A folder of two good scans and one that cannot be read."""
    folder = tmp_path / "scans"
    folder.mkdir()
    for name in ("panel.ply", "table1.ply"):
        shutil.copy(repo_root / "sample_clouds" / name, folder / name)
    (folder / "broken.ply").write_text("ply\nnot a header\n")
    return folder


def stored_records(location):
    """{file: (record as stored, the stored answer)} of every measurement of a store."""
    with open_store(location) as store:
        answers = [store.get(summary["id"]) for summary in store.find(limit=None)]
    added = ("id", "received", "processing_ms", "stored", "meta")
    return {answer["file"]: ({k: v for k, v in answer.items() if k not in added}, answer) for answer in answers}


def output_records(path):
    return {record["file"]: record for record in map(json.loads, path.read_text().splitlines())}


def test_every_record_written_is_stored_as_written(holecli_process, scans, tmp_path, repo_root):
    output, store = tmp_path / "out.jsonl", tmp_path / "results.sqlite"
    result = holecli_process("batch", scans, "--spec", repo_root / "sample_clouds" / "panel_tolerances.toml",
                             "-o", output, "--store", store, "--meta", "part=P7", "--meta", "serial=S-001",
                             "--meta", "fixture=F2", "-j", "2", cwd=tmp_path)
    assert result.returncode == 5, result.stderr  # table1.ply lacks the spec's holes (5 before 6: broken.ply)
    written, stored = output_records(output), stored_records(store)
    assert set(stored) == set(written) and len(written) == 3
    for file, record in written.items():
        assert stored[file][0] == record  # exactly the record of the output, error record too
        answer = stored[file][1]
        assert answer["meta"] == {"part": "P7", "serial": "S-001", "cell": None, "operator": None, "fixture": "F2"}
    assert stored[str(scans / "broken.ply")][0]["error"]
    with open_store(store) as opened:
        verdicts = {summary["file"]: summary["verdict"] for summary in opened.find(part="P7")}
        assert opened.find(verdict="error")[0]["holes"] is None
    assert verdicts[str(scans / "broken.ply")] == "error"
    assert verdicts[str(scans / "panel.ply")] == "pass"
    assert verdicts[str(scans / "table1.ply")] == "fail"  # no hole of the spec's in Table I's scene
    # the batch's own output is the same as without --store
    plain = holecli_process("batch", scans, "--spec", repo_root / "sample_clouds" / "panel_tolerances.toml",
                            "-j", "2", cwd=tmp_path)
    without = {record["file"]: record for record in map(json.loads, plain.stdout.splitlines())}
    for record in (*without.values(), *written.values()):
        record.pop("timing", None)
    assert without == written


def test_resume_does_not_store_the_earlier_records_again(run, scans, tmp_path):
    output, store = tmp_path / "out.jsonl", tmp_path / "results.sqlite"
    (scans / "broken.ply").unlink()
    later = scans / "table1.ply"
    kept = tmp_path / "table1.ply"
    later.rename(kept)
    first = run("batch", scans, "-o", output, "--store", store, "-j", "1")
    assert first.exit_code == 0, first.stderr
    kept.rename(later)
    second = run("batch", scans, "-o", output, "--store", store, "--resume", "-j", "1")
    assert second.exit_code == 0, second.stderr
    written, stored = output_records(output), stored_records(store)
    assert sorted(stored) == sorted(written) == [str(scans / "panel.ply"), str(scans / "table1.ply")]
    with open_store(store) as opened:
        assert opened.count() == 2


def test_a_store_that_cannot_be_opened_stops_the_batch_before_anything(run, scans, tmp_path):
    output = tmp_path / "out.jsonl"
    output.write_text("kept\n")
    store = tmp_path / "notes.txt"
    store.write_text("not a database\n")
    result = run("batch", scans, "-o", output, "--overwrite", "--store", store)
    assert result.exit_code == 3
    assert result.stderr.splitlines() == [f"Error: {store}: not a holecli results store (not an SQLite database); "
                                          f"it was left as it is"]
    assert output.read_text() == "kept\n" and store.read_text() == "not a database\n"


def test_a_store_in_a_missing_folder_is_an_input_error(run, scans, tmp_path):
    result = run("batch", scans, "--store", tmp_path / "nowhere" / "results.sqlite")
    assert result.exit_code == 3 and result.stdout == ""
    assert result.stderr.startswith(f"Error: {tmp_path / 'nowhere' / 'results.sqlite'}: cannot open the results store")


@pytest.mark.parametrize("meta, message", [
    (["--meta", "part"], "'part' is not KEY=VALUE"),
    (["--meta", "part number=7"], "is not KEY=VALUE"),
    (["--meta", "part=" + "x" * 201], "longer than 200 characters"),
    (["--meta", "part=a", "--meta", "part=b"], "part is given twice"),
])
def test_a_malformed_meta_is_a_usage_error(run, scans, tmp_path, meta, message):
    result = run("batch", scans, "--store", tmp_path / "results.sqlite", *meta)
    assert result.exit_code == 2
    assert f"Error: Invalid value for '--meta': " in result.stderr and message in result.stderr
    assert not (tmp_path / "results.sqlite").exists()


def test_meta_without_a_store_is_a_usage_error(run, scans):
    result = run("batch", scans, "--meta", "part=P7")
    assert result.exit_code == 2 and "Error: --meta needs --store" in result.stderr


def test_the_store_is_not_the_output(run, scans, tmp_path):
    result = run("batch", scans, "-o", tmp_path / "same", "--store", tmp_path / "same")
    assert result.exit_code == 2 and "are the same file (each output needs a file of its own)" in result.stderr


def test_the_store_in_the_folder_measured_is_not_measured(run, scans, tmp_path):
    store = scans / "results.sqlite"
    result = run("batch", scans, "--input-format", "ply", "--store", store, "-j", "1")
    files = {json.loads(line)["file"] for line in result.stdout.splitlines()}
    assert files == {str(scans / name) for name in ("panel.ply", "table1.ply", "broken.ply")}


def test_batch_stores_into_postgres(holecli_process, scans, tmp_path, postgres_store_url):
    output = tmp_path / "out.jsonl"
    result = holecli_process("batch", scans, "-o", output, "--store", postgres_store_url, "--meta", "cell=C2",
                             "-j", "2")
    assert result.returncode == 6, result.stderr
    written, stored = output_records(output), stored_records(postgres_store_url)
    assert {file: record for file, (record, _) in stored.items()} == written
    assert {answer["meta"]["cell"] for _, answer in stored.values()} == {"C2"}


@pytest.mark.slow
def test_a_killed_batch_has_every_record_written_in_the_store(holecli_process, tmp_path, repo_root):
    import os
    import signal
    import time

    folder = tmp_path / "many"
    folder.mkdir()
    for number in range(40):
        os.link(repo_root / "sample_clouds" / "table1.ply", folder / f"scan{number:02d}.ply")
    output, store = tmp_path / "out.jsonl", tmp_path / "results.sqlite"
    process = holecli_process("batch", folder, "-o", output, "--store", store, "-j", "1", "-q", start=True)
    try:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and (not output.exists() or output.read_text().count("\n") < 3):
            time.sleep(0.02)
        process.send_signal(signal.SIGKILL)
        process.wait(30)
    finally:
        process.kill()
        process.wait(30)
        process.stdout.close()
        process.stderr.close()
    written = output_records(output)
    assert 3 <= len(written) < 40
    stored = stored_records(store)
    assert all(stored[file][0] == record for file, record in written.items())
    assert len(stored) - len(written) in (0, 1)  # at most the record committed but not yet written
    resumed = holecli_process("batch", folder, "-o", output, "--store", store, "-j", "2", "-q", "--resume")
    assert resumed.returncode == 0, resumed.stderr
    assert len(output_records(output)) == 40
    with open_store(store) as opened:
        assert opened.count() in (40, 41)


def test_a_batch_without_store_imports_no_store(modules_imported_by, repo_root):
    imported = modules_imported_by([["batch", repo_root / "sample_clouds" / "table1.ply", "-q"]],
                                   ["holecli.store", "sqlite3", "psycopg"])
    assert imported == "[]"
