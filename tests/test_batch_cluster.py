"""holecli.batch.cluster: a batch's files measured in tasks on a real LocalCluster of 2 worker processes."""

import os
import shutil
import signal
import time

import pytest

pytest.importorskip("distributed")

from holecli.batch import measure_all  # noqa: E402
from holecli.batch.cluster import (ClusterError, cluster_client, files_per_task, group_files,  # noqa: E402
                                   measure_on_cluster, parse_address)
from holecli.batch.manifest import file_fingerprint  # noqa: E402

OPTIONS = {"method": "robust"}
CLOUDS = ("table1.ply", "panel.ply", "panel_curved.ply", "no_hole.csv", "countersunk_outliers.xyz")


@pytest.fixture(scope="module")
def client():
    with cluster_client("local:2") as opened:
        yield opened


@pytest.fixture(scope="module")
def scans(tmp_path_factory, repo_root):
    """Sample clouds, three copies of each (15 files), and one file that is no cloud."""
    folder = tmp_path_factory.mktemp("scans")
    for copy in range(3):
        for name in CLOUDS:
            shutil.copy(repo_root / "sample_clouds" / name, folder / f"{copy}_{name}")
    (folder / "broken.ply").write_text("ply\nnot a header\n")
    return sorted(str(path) for path in folder.iterdir())


def without_timing(records):
    return sorted(({key: value for key, value in record.items() if key != "timing"} for record in records),
                  key=lambda record: record["file"])


def test_addresses_and_task_sizes():
    assert parse_address("local:3") == 3
    assert parse_address(" tcp://10.0.0.5:8786 ") == "tcp://10.0.0.5:8786"
    for wrong in ("local:0", "local:two", "local", ""):
        with pytest.raises(ClusterError):
            parse_address(wrong)
    # four tasks per worker at least, at most 256 files a task, never an empty task
    assert files_per_task(60, 2) == 8 and files_per_task(10**7, 100) == 256 and files_per_task(3, 8) == 1
    assert group_files(list("abcde"), 2) == [["a", "b"], ["c", "d"], ["e"]]


def test_records_are_a_local_batchs_and_fingerprints_the_files(client, scans):
    fingerprints = {}
    on_cluster = list(measure_on_cluster(scans, OPTIONS, client=client, task_size=4, fingerprints=fingerprints))
    local = list(measure_all(scans, OPTIONS, jobs=1))
    assert without_timing(on_cluster) == without_timing(local)
    assert len(on_cluster) == len(scans) == 16
    assert sum("error" in record for record in on_cluster) == 1  # broken.ply: its error record, as locally
    assert fingerprints == {path: file_fingerprint(path) for path in scans}


def test_a_lost_worker_costs_only_its_task(client, scans):
    pids = client.run(os.getpid)  # {worker address: its process id}
    records, killed = [], None
    for record in measure_on_cluster(scans, OPTIONS, client=client, task_size=1):
        records.append(record)
        if killed is None:
            busy = [worker for worker, tasks in client.processing().items() if tasks]
            killed = pids[busy[0]]
            os.kill(killed, signal.SIGKILL)
    assert killed is not None
    files = [record["file"] for record in records]
    assert sorted(files) == scans  # each file once: the lost task ran again elsewhere, its records came once
    # none lost either: only broken.ply has an error record
    assert [record["file"] for record in records if "error" in record] == [path for path in scans
                                                                             if path.endswith("broken.ply")]
    deadline = time.monotonic() + 30
    while len(client.scheduler_info()["workers"]) < 2 and time.monotonic() < deadline:
        time.sleep(0.2)  # the nanny starts the lost worker again (for the next tests)
    assert killed not in client.run(os.getpid).values()


def test_a_stop_cancels_the_tasks_not_finished(client, scans):
    records = list(measure_on_cluster(scans, OPTIONS, client=client, task_size=1, should_stop=lambda: True))
    assert 1 <= len(records) < len(scans)
    deadline = time.monotonic() + 10
    while any(client.processing().values()) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not any(client.processing().values())  # nothing left running on the cluster
