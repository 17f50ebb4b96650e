"""Writers of a results store in processes of their own, for the tests of a killed writer and of two
writers at once (either engine)."""

import json
import os
import signal
import subprocess
import sys
import time

# A writer: adds the record of argv[2] to the store argv[1], argv[3] times (0: until killed), printing
# each id once add has returned; with argv[4], waits for that file to appear first (a start gate).
WRITER = """
import json, os, sys, time
from holecli.store import open_store
record = json.load(open(sys.argv[2], encoding="utf-8"))
count = int(sys.argv[3])
with open_store(sys.argv[1]) as store:
    if len(sys.argv) > 4:
        print("ready", flush=True)
        while not os.path.exists(sys.argv[4]):
            time.sleep(0.002)
    number = 0
    while count == 0 or number < count:
        print(store.add(record, meta={"serial": f"S{number}"}, source="test"), flush=True)
        number += 1
"""


def _start(location, record, folder, repo_root, count, gate=None):
    record_file = os.path.join(folder, "record.json")
    if not os.path.exists(record_file):
        with open(record_file, "w", encoding="utf-8") as file:
            json.dump(record, file)
    return subprocess.Popen([sys.executable, "-c", WRITER, location, record_file, str(count),
                             *([gate] if gate else [])], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env=dict(os.environ, PYTHONPATH=str(repo_root)))


def added_until_killed(location, record, folder, repo_root, before_kill=30):
    """Run a writer until it has acknowledged ``before_kill`` adds, SIGKILL it mid-run, and return every
    id it printed (those whose add had returned) before it died."""
    process = _start(location, record, str(folder), repo_root, 0)
    ids = []
    try:
        while len(ids) < before_kill:
            line = process.stdout.readline()
            assert line.endswith("\n"), f"the writer stopped: {process.stderr.read()}"
            ids.append(line.strip())
        time.sleep(0.05)  # mid-run: it goes on adding until the kill
        process.send_signal(signal.SIGKILL)
        rest = process.stdout.read()
    finally:
        process.kill()
        process.wait(30)
        process.stdout.close()
        process.stderr.close()
    assert process.returncode == -signal.SIGKILL
    ids += [line for line in rest.split("\n")[:-1]]  # only whole lines: a cut last line was never said
    return ids


def concurrent_adds(location, record, folder, repo_root, processes=2, count=50):
    """Run ``processes`` writers of ``count`` adds each, started together; return every id printed."""
    gate = os.path.join(str(folder), "go")
    writers = [_start(location, record, str(folder), repo_root, count, gate) for _ in range(processes)]
    ids = []
    try:
        for writer in writers:
            assert writer.stdout.readline() == "ready\n", writer.stderr.read()
        open(gate, "w").close()
        for writer in writers:
            out, err = writer.communicate(timeout=120)
            assert writer.returncode == 0, err
            ids += out.split()
    finally:
        for writer in writers:
            writer.kill()
            writer.wait(30)
            writer.stdout.close()
            writer.stderr.close()
    assert len(ids) == processes * count
    return ids
