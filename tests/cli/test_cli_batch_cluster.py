"""``holecli batch --cluster local:2``: the real command on a local Dask cluster of 2 worker processes."""

import json
import shutil
import signal
import sys
import time

import pytest

from holecli.store import open_store

pytest.importorskip("distributed")

CLOUDS = ("table1.ply", "panel.ply", "panel_curved.ply", "no_hole.csv", "countersunk_outliers.xyz")


@pytest.fixture
def scans(tmp_path, repo_root):
    """The sample clouds and a file that is no cloud."""
    folder = tmp_path / "scans"
    folder.mkdir()
    for name in CLOUDS:
        shutil.copy(repo_root / "sample_clouds" / name, folder / name)
    (folder / "broken.ply").write_text("ply\nnot a header\n")
    return folder


def records(path):
    return [json.loads(line) for line in path.read_text().splitlines()]


def without_timing(records):
    return sorted(({key: value for key, value in record.items() if key != "timing"} for record in records),
                  key=lambda record: record["file"])


def test_records_store_and_manifest_as_a_local_run(holecli_process, scans, tmp_path, repo_root):
    spec = repo_root / "sample_clouds" / "panel_tolerances.toml"
    output, store = tmp_path / "out.jsonl", tmp_path / "results.sqlite"
    result = holecli_process("batch", scans, "--spec", spec, "--cluster", "local:2", "-o", output, "--store", store,
                             "--meta", "part=P7", cwd=tmp_path)
    local = holecli_process("batch", scans, "--spec", spec, "-j", "2", "-o", tmp_path / "local.jsonl", cwd=tmp_path)
    assert result.returncode == local.returncode == 5, result.stderr  # rejected parts (5 before 6: broken.ply)
    written = records(output)
    assert without_timing(written) == without_timing(records(tmp_path / "local.jsonl"))
    # stderr: holecli's own lines only (the failed file, the summary), none of Dask's
    assert all(line.startswith("holecli") for line in result.stderr.splitlines()), result.stderr
    summary, local_summary = (text.splitlines()[-1].rsplit(";", 1)[0] for text in (result.stderr, local.stderr))
    assert summary == local_summary  # the same summary, but its time
    with open_store(store) as opened:
        stored = [opened.get(summary["id"]) for summary in opened.find(part="P7", limit=None)]
    assert sorted(answer["file"] for answer in stored) == sorted(record["file"] for record in written)
    manifest = records(tmp_path / "out.jsonl.manifest")
    assert [entry["path"] for entry in manifest] == [record["path"] for record in written]


def test_resume_measures_again_a_file_changed_since(holecli_process, scans, tmp_path, repo_root):
    output = tmp_path / "out.jsonl"
    first = [scans / "panel.ply", scans / "table1.ply"]
    assert holecli_process("batch", *first, "--cluster", "local:2", "-o", output).returncode == 0
    shutil.copy(repo_root / "sample_clouds" / "panel_curved.ply", scans / "table1.ply")  # table1.ply changes
    result = holecli_process("batch", scans, "--cluster", "local:2", "-o", output, "--resume")
    assert result.returncode == 6, result.stderr
    files = [record["file"] for record in records(output)]
    # panel.ply kept; table1.ply measured again (its new record after the old); the others once
    assert sorted(files[:2]) == sorted(str(path) for path in first)
    assert sorted(files[2:]) == sorted(str(path) for path in scans.iterdir() if path.name != "panel.ply")
    old, new = [record for record in records(output) if record["file"] == str(scans / "table1.ply")]
    assert old["points"] != new["points"]
    # the manifest says what is done now: a third run has nothing left
    again = holecli_process("batch", scans, "--cluster", "local:2", "-o", output, "--resume")
    assert again.returncode == 6, again.stderr
    assert [record["file"] for record in records(output)] == files


def test_an_interrupt_keeps_the_finished_records(holecli_process, tmp_path, repo_root):
    folder = tmp_path / "many"
    folder.mkdir()
    for copy in range(30):
        shutil.copy(repo_root / "sample_clouds" / "panel.ply", folder / f"panel_{copy:02d}.ply")
    output = tmp_path / "out.jsonl"
    process = holecli_process("batch", folder, "--cluster", "local:2", "--files-per-task", "1", "-o", output,
                              start=True)
    deadline = time.monotonic() + 60
    while (not output.exists() or not output.read_text()) and time.monotonic() < deadline:
        time.sleep(0.05)
    process.send_signal(signal.SIGINT)
    _, stderr = process.communicate(timeout=60)
    assert process.returncode == 130, stderr
    assert "interrupted after" in stderr and "Traceback" not in stderr
    written = records(output)  # whole lines, each file once
    assert 1 <= len(written) < 30 and len({record["file"] for record in written}) == len(written)
    assert len(records(tmp_path / "out.jsonl.manifest")) == len(written)


def test_without_dask_one_error_line_and_exit_3(run, scans, monkeypatch):
    monkeypatch.setitem(sys.modules, "distributed", None)  # import distributed raises ImportError
    result = run("batch", scans, "--cluster", "local:2")
    assert result.exit_code == 3
    assert result.stderr == "Error: --cluster needs dask: pip install 'holecli[cluster]'\n"


@pytest.mark.parametrize("args", [("--cluster", "local:2", "--jobs", "2"), ("--cluster", "local:0"),
                                  ("--files-per-task", "4")])
def test_wrong_cluster_options_are_usage_errors(run, scans, args):
    result = run("batch", scans, *args)
    assert result.exit_code == 2, result.stderr
    assert result.stderr.startswith("Usage:")


def test_plain_batch_does_not_import_dask(modules_imported_by, repo_root, tmp_path):
    commands = (["--help"], ["batch", "--help"], ["batch", repo_root / "sample_clouds" / "panel.ply", "-j", "1",
                                                  "-o", tmp_path / "out.jsonl"])
    assert modules_imported_by(commands, ("dask", "distributed")) == "[]"
