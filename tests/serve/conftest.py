"""Fixtures of the service's tests: a real ``holecli serve`` in a process of its own, on port 0.

``serve(*options)`` starts ``python -m holecli serve --port 0 ...``, reads the one JSON line it writes
on stdout when ready (with a deadline: a server that never gets ready fails the test, it does not
hang it) and returns a :class:`Served`. At teardown every server still running gets SIGTERM (then
SIGKILL after 20 s), and no process it started (its workers, multiprocessing's resource tracker) may
outlive it: the workers die with the service, even after ``kill -9`` (the parent-death signal).
"""

from __future__ import annotations

import json
import os
import queue
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

READY_SECONDS = 90
"""How long a server may take to say it is ready (workers warm up by measuring a scan; the machine's
two cores are shared with other test runs)."""


def descendants(pid):
    """The processes below ``pid`` (children, their children, ...), as ``(pid, start time)`` pairs so
    that a reused process id is not taken for a survivor."""
    try:
        import psutil
    except ImportError:
        psutil = None
    if psutil is not None:
        try:
            return [(child.pid, child.create_time()) for child in psutil.Process(pid).children(recursive=True)]
        except psutil.NoSuchProcess:
            return []
    parents = {}
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            stat = _proc_stat(int(entry))
            if stat is not None:
                parents.setdefault(stat[0], []).append((int(entry), stat[1]))
    found, frontier = [], [pid]
    while frontier:
        children = parents.get(frontier.pop(), [])
        found.extend(children)
        frontier.extend(child for child, _ in children)
    return found


def _proc_stat(pid):
    """``(parent pid, start time, state)`` of ``pid`` from /proc/PID/stat; None when it is gone."""
    try:
        with open(f"/proc/{pid}/stat", encoding="ascii", errors="replace") as stream:
            fields = stream.read().rpartition(")")[2].split()
    except OSError:
        return None
    return int(fields[1]), float(fields[19]), fields[0]


def alive(process):
    """Whether ``process`` (a pair of :func:`descendants`) still runs (a zombie does not)."""
    pid, started = process
    try:
        import psutil
    except ImportError:
        stat = _proc_stat(pid)
        return stat is not None and stat[2] != "Z"
    try:
        found = psutil.Process(pid)
        return found.create_time() == started and found.status() != psutil.STATUS_ZOMBIE
    except psutil.NoSuchProcess:
        return False


def wait_gone(processes, seconds):
    """The processes among ``processes`` still running after waiting up to ``seconds``."""
    deadline = time.monotonic() + seconds
    left = [process for process in processes if alive(process)]
    while left and time.monotonic() < deadline:
        time.sleep(0.05)
        left = [process for process in left if alive(process)]
    return left


class Served:
    """A running ``holecli serve``.

    Attributes
    ----------
    process : subprocess.Popen
    http : str
        Its HTTP address (``http://127.0.0.1:PORT``).
    ready : dict
        The JSON line it wrote when ready.
    store : str
        Its ``--store``.
    """

    def __init__(self, process, ready, store, stderr_lines):
        self.process = process
        self.ready = ready
        self.http = ready["http"]
        self.store = store
        self._stderr_lines = stderr_lines
        self._seen = set()

    @property
    def stderr(self) -> str:
        """What it wrote on stderr so far."""
        return "".join(self._stderr_lines)

    def children(self):
        """Its processes now (workers, resource tracker), remembered for the check that none outlives it."""
        found = descendants(self.process.pid)
        self._seen.update(found)
        return found

    def workers(self):
        """The pids of its worker processes now."""
        pids = []
        for pid, _ in self.children():
            try:
                with open(f"/proc/{pid}/cmdline", "rb") as stream:
                    if b"spawn_main" in stream.read():
                        pids.append(pid)
            except OSError:
                pass
        return pids

    def signal(self, number):
        """Send ``number`` to the server (its processes remembered first)."""
        self.children()
        self.process.send_signal(number)

    def wait(self, seconds):
        """Its exit status, waiting up to ``seconds`` (then :class:`subprocess.TimeoutExpired`)."""
        return self.process.wait(seconds)

    def leftovers(self, seconds=10):
        """Its processes still running ``seconds`` after it exited (there should be none)."""
        return wait_gone(sorted(self._seen), seconds)

    def stop(self, seconds=20):
        """SIGTERM, wait up to ``seconds``, SIGKILL when it did not stop; its exit status."""
        if self.process.poll() is None:
            self.signal(signal.SIGTERM)
            try:
                self.process.wait(seconds)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait(30)
        return self.process.returncode


def _drain(stream, sink):
    for line in iter(stream.readline, ""):
        sink(line)
    stream.close()


@pytest.fixture
def serve_env(tmp_path, repo_root):
    """The environment of the server processes: this checkout's holecli, temporary files (the uploads'
    folder) under ``tmp_path/tmp`` so that a test can see what the service writes."""
    temporary = tmp_path / "tmp"
    temporary.mkdir(exist_ok=True)
    env = dict(os.environ, PYTHONPATH=str(repo_root), TMPDIR=str(temporary))
    env.pop("PYTHONWARNINGS", None)
    return env


def start_server(options, *, env, cwd, store, ready_seconds=READY_SECONDS):
    """Start ``holecli serve --port 0 --store store *options`` and wait for its ready line.

    Returns
    -------
    Served
    """
    command = [sys.executable, "-m", "holecli", "serve", "--port", "0", "--store", str(store), *map(str, options)]
    process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env,
                               cwd=cwd)
    lines, stderr_lines = queue.Queue(), []
    threading.Thread(target=_drain, args=(process.stdout, lines.put), daemon=True).start()
    threading.Thread(target=_drain, args=(process.stderr, stderr_lines.append), daemon=True).start()
    try:
        line = lines.get(timeout=ready_seconds)
    except queue.Empty:
        process.kill()
        process.wait(30)
        raise AssertionError(f"holecli serve not ready within {ready_seconds} s; stderr: {''.join(stderr_lines)}")
    served = Served(process, json.loads(line), store, stderr_lines)
    served.children()
    return served


@pytest.fixture(scope="session")
def start_serve():
    """:func:`start_server`, for fixtures of a wider scope than ``serve``'s (they stop what they start)."""
    return start_server


@pytest.fixture
def serve(tmp_path, serve_env):
    """``serve(*options, store=PATH, cwd=PATH)``: a ready ``holecli serve`` (:class:`Served`), run in
    ``cwd`` (default ``tmp_path/cwd``), its store ``tmp_path/store.sqlite`` by default. Stopped at
    teardown; none of its processes may outlive it."""
    started = []
    workdir = tmp_path / "cwd"
    workdir.mkdir(exist_ok=True)

    def start(*options, store=None, cwd=None):
        served = start_server(options, env=serve_env, cwd=cwd or workdir, store=store or tmp_path / "store.sqlite")
        started.append(served)
        return served

    yield start
    for served in started:
        served.stop()
    for served in started:
        left = served.leftovers()
        assert not left, f"processes of holecli serve left running after it stopped: {left}"


@pytest.fixture
def run_serve(tmp_path, serve_env):
    """``run_serve(*options)``: run ``holecli serve ...`` expected to stop on its own (a refusal to
    start), in ``tmp_path/cwd``; the finished :class:`subprocess.CompletedProcess` (60 s at most)."""
    workdir = tmp_path / "cwd"
    workdir.mkdir(exist_ok=True)

    def run(*options, timeout=60):
        return subprocess.run([sys.executable, "-m", "holecli", "serve", *map(str, options)], capture_output=True,
                              text=True, env=serve_env, cwd=workdir, timeout=timeout)

    return run


@pytest.fixture(scope="session")
def scans(tmp_path_factory, repo_root):
    """A folder of scans (the service's --allow-dir): ``table1.ply`` (7,062 points), ``s1e5.ply``
    (about 10^5 points, measured in about 0.5 s) and ``s1e6.ply`` (about 10^6 points, several
    seconds and a few hundred MB), written by ``holecli simulate scene``."""
    folder = tmp_path_factory.mktemp("scans")
    env = dict(os.environ, PYTHONPATH=str(repo_root))
    env.pop("PYTHONWARNINGS", None)
    (folder / "table1.ply").write_bytes((repo_root / "sample_clouds" / "table1.ply").read_bytes())
    for name, spacing in (("s1e5.ply", "0.0253"), ("s1e6.ply", "0.008")):
        subprocess.run([sys.executable, "-m", "holecli", "simulate", "scene", str(folder / name), "--spacing",
                        spacing, "--truth", str(folder.parent / (name + ".truth.json")), "-q"],
                       check=True, env=env, timeout=120)
    return Path(folder)
