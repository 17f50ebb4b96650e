"""``holecli serve``'s request latency, throughput, soak and store insert rate, beside in-process measuring.

All in one run, against the in-process ``holecli.measure_scan`` and a one-shot ``holecli detect`` of the
same files.

The scans are written by ``holecli simulate scene`` into a temporary folder (the Table I scene at the
spacings that give about 10^4 and 10^5 points, height noise a tenth of the spacing), beside
``sample_clouds/table1.ply`` (7,062 points). Servers are ``python -m holecli serve`` processes of this
tree on 127.0.0.1 with ``--port 0`` (their ready line read with a deadline), a SQLite store in the
temporary folder, stopped with SIGTERM (their exit status is checked: 0).

1. Baselines. ``holecli.measure_scan(path)`` in this process, BLAS on one thread as in the workers
   (p50/p99 wall, p50 CPU with ``time.process_time``); a one-shot ``python -m holecli detect FILE``
   subprocess (p50 wall and CPU of a few runs).
2. Latency. One client, sequential, against a server with ``--workers 1`` (one measurement at a
   time, as in the in-process run, so the comparison is fair). Per scan, after warm-up requests,
   rounds that each run the in-process measurement and then every channel once: HTTP by path (a JSON
   body), HTTP by upload (the PLY as the raw body, ``?format=ply``), the TCP line protocol
   (``MEASURE <path>``) and OPC UA's ``Measure`` method (when asyncua, the extra ``opcua``, is
   installed). Interleaving puts the machine's other load on every row alike. Per row: p50/p99 wall,
   the p50 difference to the in-process p50 (goal <= 10 ms), the CPU time of the server's process
   tree per request (from /proc) less the in-process CPU, and for HTTP where the time went: the
   worker's measuring time (the record's ``timing.elapsed_ms``), the service's (``processing_ms``:
   receipt to stored) and the rest (the front end, the connection, the client).
3. Throughput over HTTP by path on the 10^4 scan, 4 concurrent clients, with ``--workers 1`` and
   ``--workers 2``: scans/s, the ratio (goal >= 1.7 on 2 cores), the server tree's CPU per scan and the
   clients'. Beside it the machine's own ratio: 1 and 2 warm processes measuring the scan in a loop,
   started together, no service. The best of 2 alternating runs of each (the machine's other load
   varies), as ``benchmarks/batch_speed.py`` does.
4. Soak: ``--requests`` (10,000) requests from 8 concurrent clients over HTTP by path on
   ``table1.ply``, against the ``--workers 2`` server: errors (goal 0), the rate, and the resident
   memory of the server's process tree (VmRSS of the parent, its workers and multiprocessing's
   resource tracker) after warm-up, at its peak and at the end (goal: growth < 50 MB).
5. The store's insert rate: ``benchmarks/store.py``'s ``insert_rate`` of its real records on a SQLite
   file, and on PostgreSQL when ``tests/pgserver.py`` can start a throwaway server.

``--quick`` (the test's mode) uses scans of about 10^3 and 10^4 points, a few rounds and a short soak.
``--json`` prints one JSON object with every figure instead of the tables.

Run:  python benchmarks/serve.py [--requests 10000] [--rounds 80] [--quick] [--json] [--docs]

``--docs`` writes the tables into the block ``serve`` of docs/validation/speed.md (``--docs-page PATH``: another page).
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import importlib.util
import json
import os
import platform
import resource
import selectors
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from benchmarks._docs_table import VALIDATION, add_docs_options, docs_target, recording  # noqa: E402

GOAL_OVERHEAD_MS = 10.0
GOAL_RATIO = 1.7
GOAL_GROWTH_MB = 50.0
TABLE1 = ROOT / "sample_clouds" / "table1.ply"
# ``holecli simulate scene``'s default patch ([-3, 5]^2 less a 3 mm hole) at these spacings: ~10^3, 10^4, 10^5 points.
SPACINGS = {"sim 10^3": 0.24, "sim 10^4": 0.0763, "sim 10^5": 0.0241}
READY_SECONDS = 180.0
STOP_SECONDS = 90.0
CLOCK_TICKS = os.sysconf("SC_CLK_TCK")


def _environment():
    """The environment of the child processes: this tree's holecli, BLAS as a user's shell leaves it."""
    environment = dict(os.environ, PYTHONPATH=str(ROOT))
    for name in ("OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "OMP_NUM_THREADS"):
        environment.pop(name, None)
    return environment


def _has(module):
    try:
        return importlib.util.find_spec(module) is not None
    except ImportError:
        return False


def available_channels():
    """The front ends measured: HTTP and TCP always; OPC UA when its extra (asyncua) is installed."""
    return {"tcp": True, "opcua": _has("asyncua")}


# -- the scans ------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Scan:
    name: str
    path: str
    points: int
    data: bytes


def write_scans(folder, names):
    """The simulated scans ``names`` (keys of :data:`SPACINGS`) in ``folder``, then table1.ply (copied
    there: every file a request names lies in the server's --allow-dir)."""
    from holecli import read_cloud

    scans = []
    for name in names:
        spacing = SPACINGS[name]
        path = os.path.join(folder, name.replace(" ", "_").replace("^", "e") + ".ply")
        subprocess.run([sys.executable, "-m", "holecli", "simulate", "scene", path, "--spacing", str(spacing),
                        "--noise-z", f"{0.1 * spacing:.6g}", "-q"], check=True, capture_output=True,
                       env=_environment())
        scans.append(path)
    table1 = os.path.join(folder, "table1.ply")
    with open(TABLE1, "rb") as source, open(table1, "wb") as copy:
        copy.write(source.read())
    result = []
    for name, path in zip([*names, "table1"], [*scans, table1]):
        with open(path, "rb") as stream:
            data = stream.read()
        result.append(Scan(name, path, len(read_cloud(path).points), data))
    return result


# -- the server -----------------------------------------------------------------------------------


def _stat_cpu(pid):
    """User + system CPU seconds of process ``pid`` (its own, not its children's), from /proc."""
    with open(f"/proc/{pid}/stat", encoding="ascii") as stream:
        fields = stream.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / CLOCK_TICKS


def _rss_mb(pid):
    with open(f"/proc/{pid}/status", encoding="ascii") as stream:
        for line in stream:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024.0
    return 0.0


def process_tree(pid):
    """``pid`` and its descendants (from the parent ids of /proc/*/stat)."""
    parents = {}
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                with open(f"/proc/{entry}/stat", encoding="ascii") as stream:
                    parents[int(entry)] = int(stream.read().rsplit(")", 1)[1].split()[1])
            except (OSError, ValueError, IndexError):
                pass
    tree, frontier = [pid], [pid]
    while frontier:
        frontier = [child for child, parent in parents.items() if parent in frontier]
        tree.extend(frontier)
    return tree


class Server:
    """A ``python -m holecli serve`` process on 127.0.0.1, port 0, ready when its JSON line came."""

    def __init__(self, folder, store, workers, tcp=False, opcua=False):
        command = [sys.executable, "-m", "holecli", "serve", "--host", "127.0.0.1", "--port", "0",
                   "--allow-dir", folder, "--store", store, "--workers", str(workers), "-q"]
        if tcp:
            command += ["--tcp-port", "0"]
        if opcua:
            command += ["--opcua-port", "0"]
        self.workers = workers
        self.errors = tempfile.TemporaryFile()
        self.process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=self.errors, env=_environment(),
                                        cwd=ROOT)
        try:
            self.ready = json.loads(self._ready_line(READY_SECONDS))
        except BaseException:
            self.process.kill()
            self.process.wait()
            raise
        self.http = self.ready["http"]
        self.tcp = self.ready.get("tcp")
        self.opcua = self.ready.get("opcua")
        self.pids = process_tree(self.process.pid)

    def _stderr(self):
        self.errors.seek(0)
        return self.errors.read().decode(errors="replace").strip()[-2000:]

    def _ready_line(self, seconds):
        deadline = time.monotonic() + seconds
        line = b""
        with selectors.DefaultSelector() as selector:
            selector.register(self.process.stdout, selectors.EVENT_READ)
            while not line.endswith(b"\n"):
                left = deadline - time.monotonic()
                if left <= 0:
                    raise RuntimeError(f"holecli serve said nothing within {seconds:g} s: {self._stderr()}")
                if selector.select(left):
                    chunk = os.read(self.process.stdout.fileno(), 4096)
                    if not chunk:
                        self.process.wait()
                        raise RuntimeError(f"holecli serve exited ({self.process.returncode}) before it was ready: "
                                           f"{self._stderr()}")
                    line += chunk
        return line.decode()

    def refresh(self):
        """Find the process tree again (a worker replaced after a crash has a new id)."""
        self.pids = process_tree(self.process.pid)

    def cpu_seconds(self):
        total = 0.0
        for pid in self.pids:
            try:
                total += _stat_cpu(pid)
            except OSError:
                pass
        return total

    def rss_mb(self):
        """Resident memory of the whole tree (VmRSS of each process), MB."""
        self.refresh()
        total = 0.0
        for pid in self.pids:
            try:
                total += _rss_mb(pid)
            except OSError:
                pass
        return total

    def stop(self):
        """SIGTERM, then the exit status (0 expected)."""
        if self.process.returncode is not None:
            return self.process.returncode
        self.process.send_signal(signal.SIGTERM)
        try:
            status = self.process.wait(STOP_SECONDS)
        except subprocess.TimeoutExpired:
            self.process.kill()
            status = self.process.wait()
        self.process.stdout.close()
        if status != 0:
            print(f"holecli serve exited {status} on SIGTERM: {self._stderr()}", file=sys.stderr)
        self.errors.close()
        return status


# -- the clients ----------------------------------------------------------------------------------


class RequestFailed(RuntimeError):
    """A request that did not get a stored measurement."""


def http_client(server):
    import httpx

    return httpx.Client(base_url=server.http, timeout=300.0)


def http_by_path(client, scan):
    """POST /v1/measure with a JSON body naming the file: the answer."""
    response = client.post("/v1/measure", json={"path": scan.path})
    return _checked_http(response, scan)


def http_by_upload(client, scan):
    """POST /v1/measure?format=ply with the PLY as the raw body: the answer."""
    response = client.post("/v1/measure", params={"format": "ply"}, content=scan.data,
                           headers={"Content-Type": "application/octet-stream"})
    return _checked_http(response, scan)


def _checked_http(response, scan):
    if response.status_code != 200:
        raise RequestFailed(f"{scan.name}: HTTP {response.status_code}: {response.text[:300]}")
    answer = response.json()
    if not answer.get("stored") or answer.get("points") != scan.points:
        raise RequestFailed(f"{scan.name}: unexpected answer {str(answer)[:300]}")
    return answer


class LineClient:
    """The TCP line protocol, one kept connection: ``MEASURE <path>`` answered by one ``OK,...`` line."""

    def __init__(self, address):
        host, port = address.rsplit(":", 1)
        self.sock = socket.create_connection((host, int(port)), timeout=300.0)
        self.sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self.reader = self.sock.makefile("rb")

    def measure(self, scan):
        path = f'"{scan.path}"' if " " in scan.path else scan.path
        self.sock.sendall(f"MEASURE {path}\n".encode())
        line = self.reader.readline().decode(errors="replace").strip()
        if not line.startswith("OK,"):
            raise RequestFailed(f"{scan.name}: TCP answered {line[:300]!r}")
        return None

    def close(self):
        self.reader.close()
        self.sock.close()


class OpcUaClient:
    """An asyncua client on a loop of its own thread, calling ``Holecli/Measure(path, spec, meta)``."""

    def __init__(self, url):
        from holecli.serve.opcua import NAMESPACE_URI

        self.loop = asyncio.new_event_loop()
        self.thread = threading.Thread(target=self.loop.run_forever, daemon=True)
        self.thread.start()
        self.namespace_uri = NAMESPACE_URI
        self._run(self._connect(url))

    def _run(self, coroutine):
        return asyncio.run_coroutine_threadsafe(coroutine, self.loop).result()

    async def _connect(self, url):
        from asyncua import Client, ua

        self.ua = ua
        self.client = Client(url, timeout=300.0)
        self.client.session_timeout = 600_000  # what asyncua servers grant at most (asking more logs a warning)
        await self.client.connect()
        self.namespace = await self.client.get_namespace_index(self.namespace_uri)
        self.holecli = self.client.get_node(ua.NodeId("Holecli", self.namespace))

    def measure(self, scan):
        async def call():
            return await self.holecli.call_method(self.ua.QualifiedName("Measure", self.namespace), scan.path, "", "")

        result_id, *_ = self._run(call())
        if not result_id:
            raise RequestFailed(f"{scan.name}: OPC UA Measure returned no result id")
        return None

    def close(self):
        try:
            self._run(self.client.disconnect())
        finally:
            self.loop.call_soon_threadsafe(self.loop.stop)
            self.thread.join()
            self.loop.close()


# -- 1 and 2: baselines and latency ---------------------------------------------------------------


def in_process(scan):
    """``holecli.measure_scan`` of the scan in this process (BLAS on one thread, as in a worker)."""
    from holecli import measure_scan
    from holecli.threads import single_blas_thread

    with single_blas_thread():
        record = measure_scan(scan.path).record
    if record["points"] != scan.points:
        raise RequestFailed(f"{scan.name}: measured {record['points']} points, expected {scan.points}")


def one_shot(scan, runs):
    """Wall and CPU seconds (medians) of ``runs`` whole ``python -m holecli detect FILE`` processes."""
    walls, cpus = [], []
    for _ in range(runs):
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        started = time.perf_counter()
        subprocess.run([sys.executable, "-m", "holecli", "detect", scan.path], check=True, capture_output=True,
                       env=_environment())
        walls.append(time.perf_counter() - started)
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpus.append(after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime)
    return {"runs": runs, "p50_ms": float(np.median(walls)) * 1e3, "cpu_p50_ms": float(np.median(cpus)) * 1e3}


def _ms(values, q):
    return float(np.percentile(values, q)) * 1e3 if len(values) else None


def latency(server, scans, rounds_of, warmup, channels):
    """Per scan: rounds of the in-process measurement and one request per channel, interleaved.

    Returns
    -------
    baseline : dict
        Scan name -> in-process p50/p99/cpu.
    rows : list of dict
        Per scan and channel: p50/p99 wall ms, server processing_ms p50, server CPU ms per request.
    """
    clients = {"HTTP path": http_client(server)}
    clients["HTTP upload"] = clients["HTTP path"]
    calls = {"HTTP path": http_by_path, "HTTP upload": http_by_upload}
    opened = [clients["HTTP path"]]
    try:
        if channels["tcp"]:
            clients["TCP path"] = LineClient(server.tcp)
            calls["TCP path"] = LineClient.measure
            opened.append(clients["TCP path"])
        if channels["opcua"]:
            clients["OPC UA path"] = OpcUaClient(server.opcua)
            calls["OPC UA path"] = OpcUaClient.measure
            opened.append(clients["OPC UA path"])
        baseline, rows = {}, []
        for scan in scans:
            for _ in range(warmup):
                in_process(scan)
                for name, call in calls.items():
                    call(clients[name], scan)
            server.refresh()
            walls = {name: [] for name in ["in-process", *calls]}
            cpus = {name: [] for name in walls}
            processing = {name: [] for name in calls}
            outside = {name: [] for name in calls}
            measuring = {name: [] for name in calls}
            for _ in range(rounds_of(scan)):
                started, started_cpu = time.perf_counter(), time.process_time()
                in_process(scan)
                walls["in-process"].append(time.perf_counter() - started)
                cpus["in-process"].append(time.process_time() - started_cpu)
                for name, call in calls.items():
                    server_cpu = server.cpu_seconds()
                    started = time.perf_counter()
                    answer = call(clients[name], scan)
                    walls[name].append(time.perf_counter() - started)
                    cpus[name].append(server.cpu_seconds() - server_cpu)
                    if answer is not None:  # HTTP: where the time went
                        processing[name].append(answer["processing_ms"] / 1e3)
                        outside[name].append(walls[name][-1] - answer["processing_ms"] / 1e3)
                        measuring[name].append(answer["timing"]["elapsed_ms"] / 1e3)
            base = {"points": scan.points, "rounds": len(walls["in-process"]), "p50_ms": _ms(walls["in-process"], 50),
                    "p99_ms": _ms(walls["in-process"], 99), "cpu_p50_ms": _ms(cpus["in-process"], 50),
                    "cpu_mean_ms": float(np.mean(cpus["in-process"])) * 1e3}
            baseline[scan.name] = base
            for name in calls:
                p50 = _ms(walls[name], 50)
                rows.append({"scan": scan.name, "points": scan.points, "channel": name, "requests": len(walls[name]),
                             "p50_ms": p50, "p99_ms": _ms(walls[name], 99), "in_process_p50_ms": base["p50_ms"],
                             "over_in_process_ms": p50 - base["p50_ms"],
                             "server_processing_p50_ms": _ms(processing[name], 50),
                             "outside_service_p50_ms": _ms(outside[name], 50),
                             "worker_measuring_p50_ms": _ms(measuring[name], 50),
                             "server_cpu_ms_per_request": float(np.mean(cpus[name])) * 1e3,
                             "cpu_over_in_process_ms": float(np.mean(cpus[name]) - np.mean(cpus["in-process"])) * 1e3,
                             "pass": p50 - base["p50_ms"] <= GOAL_OVERHEAD_MS})
        return baseline, rows
    finally:
        for client in opened:
            client.close()


# -- 3 and 4: concurrent clients ------------------------------------------------------------------


def drive(server, scan, clients, requests, on_tick=None):
    """``requests`` HTTP-by-path requests from a thread per client of ``clients`` (made beforehand, so
    that their start is not counted).

    Returns
    -------
    dict
        seconds, requests, errors (with the first few messages), the server tree's CPU seconds and this
        process's (the clients').
    """
    lock = threading.Lock()
    state = {"left": requests, "errors": 0, "messages": []}

    def work(client):
        while True:
            with lock:
                if state["left"] <= 0:
                    return
                state["left"] -= 1
            try:
                http_by_path(client, scan)
            except Exception as error:  # noqa: BLE001 - counted: the soak's goal is none
                with lock:
                    state["errors"] += 1
                    if len(state["messages"]) < 3:
                        state["messages"].append(f"{type(error).__name__}: {error}"[:300])

    server.refresh()
    cpu, client_cpu = server.cpu_seconds(), time.process_time()
    started = time.perf_counter()
    threads = [threading.Thread(target=work, args=(client,)) for client in clients]
    for thread in threads:
        thread.start()
    while any(thread.is_alive() for thread in threads):
        threads[0].join(0.5)
        if on_tick is not None:
            on_tick()
    for thread in threads:
        thread.join()
    seconds = time.perf_counter() - started
    return {"seconds": seconds, "requests": requests, "errors": state["errors"], "messages": state["messages"],
            "server_cpu_s": server.cpu_seconds() - cpu, "client_cpu_s": time.process_time() - client_cpu}


CEILING = r"""
import json, sys, time
sys.path.insert(0, sys.argv[1])
from holecli import measure_scan
from holecli.threads import single_blas_thread
path, count = sys.argv[2], int(sys.argv[3])
with single_blas_thread():
    for _ in range(3):
        measure_scan(path)
    print("ready", flush=True)
    sys.stdin.readline()  # every process starts when all are ready
    started, cpu = time.perf_counter(), time.process_time()
    for _ in range(count):
        measure_scan(path)
    print(json.dumps({"seconds": time.perf_counter() - started, "cpu": time.process_time() - cpu}), flush=True)
"""


def in_process_throughput(scan, processes, count):
    """The machine's own rate without the service: ``processes`` warm processes each measuring the scan
    ``count`` times in a loop, started together (scans/s summed; CPU ms per scan)."""
    children = [subprocess.Popen([sys.executable, "-c", CEILING, str(ROOT), scan.path, str(count)], stdin=subprocess.PIPE,
                                 stdout=subprocess.PIPE, text=True, env=_environment()) for _ in range(processes)]
    try:
        for child in children:
            if child.stdout.readline().strip() != "ready":
                raise RuntimeError("an in-process throughput child failed to start")
        for child in children:
            child.stdin.write("\n")
            child.stdin.flush()
        results = [json.loads(child.stdout.readline()) for child in children]
    finally:
        for child in children:
            child.stdin.close()
            child.stdout.close()
            child.wait()
    return {"processes": processes, "scans": processes * count,
            "scans_per_s": sum(count / result["seconds"] for result in results),
            "cpu_ms_per_scan": sum(result["cpu"] for result in results) / (processes * count) * 1e3,
            "load_1min": os.getloadavg()[0]}


def throughput_runs(one, two, scan, requests, repeats, count):
    """The best of ``repeats`` alternating runs of: the in-process rate with 1 and 2 processes, the
    service with ``one`` (--workers 1) and ``two`` (--workers 2)."""
    runs = {"in-process 1": [], "in-process 2": [], "serve 1": [], "serve 2": []}
    for _ in range(repeats):
        runs["in-process 1"].append(in_process_throughput(scan, 1, count))
        runs["in-process 2"].append(in_process_throughput(scan, 2, count))
        runs["serve 1"].append(throughput(one, scan, 4, requests))
        runs["serve 2"].append(throughput(two, scan, 4, requests))
    best = {name: max(values, key=lambda run: run["scans_per_s"]) for name, values in runs.items()}
    ratio = best["serve 2"]["scans_per_s"] / best["serve 1"]["scans_per_s"]
    return {"scan": scan.name, "points": scan.points, "repeats": repeats, "runs": [best["serve 1"], best["serve 2"]],
            "in_process": [best["in-process 1"], best["in-process 2"]],
            "all_scans_per_s": {name: [run["scans_per_s"] for run in values] for name, values in runs.items()},
            "ratio": ratio, "in_process_ratio": best["in-process 2"]["scans_per_s"] / best["in-process 1"]["scans_per_s"],
            "pass": ratio >= GOAL_RATIO}


def _clients(server, count):
    import contextlib

    stack = contextlib.ExitStack()
    return stack, [stack.enter_context(http_client(server)) for _ in range(count)]


def throughput(server, scan, count, requests):
    stack, clients = _clients(server, count)
    with stack:
        drive(server, scan, clients, 2 * count)  # warm-up: every connection and worker busy once
        run = drive(server, scan, clients, requests)
    if run["errors"]:
        raise RequestFailed(f"throughput --workers {server.workers}: {run['errors']} errors: {run['messages']}")
    return {"workers": server.workers, "clients": count, "requests": requests, "seconds": run["seconds"],
            "scans_per_s": requests / run["seconds"], "server_cpu_ms_per_scan": run["server_cpu_s"] / requests * 1e3,
            "server_cpu_cores": run["server_cpu_s"] / run["seconds"],
            "client_cpu_ms_per_scan": run["client_cpu_s"] / requests * 1e3, "load_1min": os.getloadavg()[0]}


def soak(server, scan, count, requests, warmup):
    stack, clients = _clients(server, count)
    with stack:
        drive(server, scan, clients, warmup)
        before = server.rss_mb()
        peak = [before]
        last = [time.monotonic()]

        def sample():
            if time.monotonic() - last[0] >= 2.0:
                last[0] = time.monotonic()
                peak[0] = max(peak[0], server.rss_mb())

        run = drive(server, scan, clients, requests, on_tick=sample)
        after = server.rss_mb()
    peak[0] = max(peak[0], after)
    return {"scan": scan.name, "points": scan.points, "workers": server.workers, "clients": count,
            "requests": requests, "seconds": run["seconds"], "rate_per_s": requests / run["seconds"],
            "errors": run["errors"], "error_messages": run["messages"], "rss_before_mb": before,
            "rss_peak_mb": peak[0], "rss_after_mb": after, "rss_growth_mb": after - before,
            "pass": run["errors"] == 0 and after - before < GOAL_GROWTH_MB}


# -- 5: the store ---------------------------------------------------------------------------------


def store_rates(folder, seconds):
    """Inserts per second (benchmarks/store.py's ``insert_rate`` of its real records) on a SQLite file in
    ``folder`` and on a throwaway PostgreSQL server (tests/pgserver.py) when one starts."""
    from benchmarks.store import insert_rate, real_records

    records = real_records()
    rows = [dict({"engine": "SQLite (WAL, synchronous FULL)"},
                 **_rate(insert_rate(os.path.join(folder, "insert-rate.sqlite"), records, seconds)))]
    if not _has("psycopg"):
        return rows + [{"engine": "PostgreSQL", "inserts_per_s": None, "skipped": "psycopg is not installed"}]
    from tests.pgserver import NoPostgres, fresh_database, postgres_server

    try:
        with postgres_server() as url, fresh_database(url) as database:
            rows.append(dict({"engine": "PostgreSQL (fsync on, local)"}, **_rate(insert_rate(database, records, seconds))))
    except (NoPostgres, RuntimeError) as error:
        rows.append({"engine": "PostgreSQL", "inserts_per_s": None, "skipped": str(error)[:200]})
    return rows


def _rate(result):
    """The figures of an ``insert_rate`` result."""
    return {"inserts_per_s": float(result["per_second"]), "add_p50_ms": result["p50_ms"], "add_p99_ms": result["p99_ms"]}


# -- the run --------------------------------------------------------------------------------------


def _number(value, spec):
    return format(value, spec) if value is not None else "-"


def _print_baselines(figures, out):
    print("1. Baselines: holecli.measure_scan in this process (BLAS on one thread, as in a worker; measured in "
          "the latency rounds below), and whole `python -m holecli detect FILE` processes", file=out)
    print(f"{'scan':<9} {'points':>7} {'rounds':>6} {'p50 ms':>7} {'p99 ms':>7} {'cpu p50 ms':>10}   "
          f"{'detect runs':>11} {'p50 ms':>7} {'cpu p50 ms':>10}", file=out)
    for name, base in figures["baseline"].items():
        shot = figures["one_shot"][name]
        print(f"{name:<9} {base['points']:>7,} {base['rounds']:>6} {base['p50_ms']:>7.1f} {base['p99_ms']:>7.1f} "
              f"{base['cpu_p50_ms']:>10.1f}   {shot['runs']:>11} {shot['p50_ms']:>7.0f} {shot['cpu_p50_ms']:>10.0f}",
              file=out)


def _print_latency(figures, out):
    missing = [name for name, present in figures["channels"].items() if not present]
    print(f"\n2. Latency: one client, sequential, a server with --workers 1, after {figures['settings']['warmup']} "
          f"warm-up requests per channel; goal p50 <= in-process p50 + {GOAL_OVERHEAD_MS:g} ms"
          + (" (OPC UA not measured: asyncua, the extra opcua, is not installed)" if missing else ""), file=out)
    print(f"{'scan':<9} {'channel':<12} {'n':>4} {'p50 ms':>7} {'p99 ms':>7} {'in-proc':>7} {'+ ms':>6} "
          f"{'worker ms':>9} {'server ms':>9} {'front ms':>8} {'srv cpu ms':>10} {'cpu + ms':>8}  goal", file=out)
    for row in figures["latency"]:
        print(f"{row['scan']:<9} {row['channel']:<12} {row['requests']:>4} {row['p50_ms']:>7.1f} {row['p99_ms']:>7.1f} "
              f"{row['in_process_p50_ms']:>7.1f} {row['over_in_process_ms']:>+6.1f} "
              f"{_number(row['worker_measuring_p50_ms'], '9.1f'):>9} "
              f"{_number(row['server_processing_p50_ms'], '9.1f'):>9} {_number(row['outside_service_p50_ms'], '8.1f'):>8} "
              f"{row['server_cpu_ms_per_request']:>10.1f} "
              f"{row['cpu_over_in_process_ms']:>+8.1f}  "
              f"{'PASS' if row['pass'] else 'FAIL'}", file=out)
    print("(+ ms: p50 - in-process p50; worker ms: the record's timing.elapsed_ms (measure_scan in the worker), p50; "
          "server ms: the answer's processing_ms (the service: receipt to stored), p50; "
          "front ms: the request's wall time less its processing_ms (HTTP, JSON, the client), p50; srv cpu ms: CPU of "
          "the server's process tree per request, mean, from /proc in 10 ms ticks; cpu + ms: that less the in-process "
          "CPU mean: the service's own work, which the machine's other load does not inflate)", file=out)


def _print_throughput(figures, out):
    figure = figures["throughput"]
    runs = figure["runs"]
    print(f"\n3. Throughput on {figure['scan']} ({figure['points']:,} points), the best of {figure['repeats']} "
          f"alternating runs: the service with {runs[0]['clients']} concurrent clients over HTTP by path "
          f"({runs[0]['requests']} requests), and beside it the machine's own rate: warm processes measuring "
          "the scan in a loop, no service", file=out)
    print(f"{'run':<22} {'scans/s':>8} {'cpu ms/scan':>11} {'srv cores busy':>14} {'client cpu ms/scan':>18} "
          f"{'load 1 min':>10}", file=out)
    for run in figure["in_process"]:
        print(f"{'in-process, ' + str(run['processes']) + ' process' + 'es' * (run['processes'] > 1):<22} "
              f"{run['scans_per_s']:>8.2f} {run['cpu_ms_per_scan']:>11.1f} {'':>14} {'':>18} {run['load_1min']:>10.2f}",
              file=out)
    for run in runs:
        print(f"{'serve --workers ' + str(run['workers']):<22} {run['scans_per_s']:>8.2f} {run['server_cpu_ms_per_scan']:>11.1f} "
              f"{run['server_cpu_cores']:>14.2f} {run['client_cpu_ms_per_scan']:>18.1f} {run['load_1min']:>10.2f}", file=out)
    ratio = figure["ratio"]
    print(f"ratio --workers 2 / --workers 1: {ratio:.2f} (goal >= {GOAL_RATIO}): {'PASS' if ratio >= GOAL_RATIO else 'FAIL'}; "
          f"the machine's own, 2 processes / 1: {figure['in_process_ratio']:.2f}", file=out)
    print("(cpu ms/scan: the server tree's CPU per scan for serve; srv cores busy: its CPU seconds per second, 2.00 = "
          "both cores; client cpu: this process's, the 4 clients', on the same cores; load 1 min: the machine's load "
          "average after the run; all runs: " + "; ".join(f"{name} " + ", ".join(f"{rate:.1f}" for rate in rates)
                                                            for name, rates in figure["all_scans_per_s"].items()) + ")",
          file=out)


def _print_soak(figures, out):
    soaked = figures["soak"]
    print(f"\n4. Soak: {soaked['requests']:,} requests from {soaked['clients']} concurrent clients over HTTP by path on "
          f"{soaked['scan']} ({soaked['points']:,} points), --workers {soaked['workers']}", file=out)
    print(f"{soaked['seconds']:.1f} s, {soaked['rate_per_s']:.1f} requests/s, errors {soaked['errors']} (goal 0)"
          + (f": {soaked['error_messages']}" if soaked["errors"] else ""), file=out)
    print(f"server RSS (parent + workers + resource tracker): {soaked['rss_before_mb']:.1f} MB after warm-up, peak "
          f"{soaked['rss_peak_mb']:.1f}, after {soaked['rss_after_mb']:.1f}: growth {soaked['rss_growth_mb']:+.1f} MB "
          f"(goal < {GOAL_GROWTH_MB:g}): {'PASS' if soaked['pass'] else 'FAIL'}", file=out)


def _print_store(figures, out):
    print(f"\n5. The store's insert rate (benchmarks/store.py's insert_rate): one add (a measurement, its holes and "
          f"characteristics) per transaction, committed; panel.ply checked against its tolerances and table1.ply in "
          f"turn, {figures['settings']['store_seconds']:g} s each", file=out)
    for row in figures["store"]:
        rate = f"{row['inserts_per_s']:6.0f} inserts/s, one add p50 {_number(row.get('add_p50_ms'), '.2f')} ms, " \
               f"p99 {_number(row.get('add_p99_ms'), '.2f')} ms" if row["inserts_per_s"] is not None else \
            f"not measured ({row.get('skipped')})"
        print(f"{row['engine']:<32} {rate}", file=out)


def _print_stops(figures, out):
    stops = ", ".join(f"--workers {workers}: exit {status}" for workers, status in figures["stops"])
    print(f"\nservers stopped with SIGTERM: {stops}", file=out)


def run(args, progress):
    """Every figure, printed section by section to ``progress`` (None: silent) as they come."""
    channels = available_channels()
    names = ["sim 10^3", "sim 10^4"] if args.quick else ["sim 10^4", "sim 10^5"]
    figures = {"machine": {"cores": len(os.sched_getaffinity(0)), "python": platform.python_version(),
                           "load_average": os.getloadavg()},
               "channels": dict({"http": True}, **channels),
               "settings": {"quick": args.quick, "rounds": args.rounds, "large_rounds": args.large_rounds,
                            "warmup": args.warmup, "one_shot_runs": args.one_shot_runs,
                            "throughput_requests": args.throughput_requests,
                            "throughput_repeats": args.throughput_repeats, "soak_requests": args.requests,
                            "store_seconds": args.store_seconds}}
    import holecli

    figures["holecli_version"] = holecli.__version__
    with tempfile.TemporaryDirectory(prefix="holecli-bench-serve-") as folder:
        scans = write_scans(folder, names)
        by_name = {scan.name: scan for scan in scans}
        small = by_name["sim 10^4"]
        if progress:
            print(f"The benchmark of holecli serve: {figures['machine']['cores']} cores, Python {figures['machine']['python']}, "
                  f"holecli {figures['holecli_version']}, load average {figures['machine']['load_average'][0]:.2f}; scans: "
                  + ", ".join(f"{scan.name} {scan.points:,} points" for scan in scans), file=progress)
        figures["one_shot"] = {scan.name: one_shot(scan, args.one_shot_runs) for scan in scans}
        stops = []
        with contextlib.ExitStack() as servers:
            def started(workers, store, **fronts):
                server = Server(folder, os.path.join(folder, store), workers, **fronts)
                servers.callback(lambda: stops.append((workers, server.stop())))
                return server

            one = started(1, "latency.sqlite", tcp=channels["tcp"], opcua=channels["opcua"])
            largest = max(scan.points for scan in scans if scan.name != "table1")

            def rounds_of(scan):
                return args.large_rounds if scan.points == largest and not args.quick else args.rounds

            figures["baseline"], figures["latency"] = latency(one, scans, rounds_of, args.warmup, channels)
            if progress:
                _print_baselines(figures, progress)
                _print_latency(figures, progress)
            two = started(2, "soak.sqlite")
            figures["throughput"] = throughput_runs(one, two, small, args.throughput_requests, args.throughput_repeats,
                                                    args.throughput_requests // 4)
            if progress:
                _print_throughput(figures, progress)
            one.stop()
            figures["soak"] = soak(two, by_name["table1"], 8, args.requests, warmup=min(200, args.requests))
            if progress:
                _print_soak(figures, progress)
        figures["stops"] = sorted(stops)
        figures["store"] = store_rates(folder, args.store_seconds)
        if progress:
            _print_store(figures, progress)
            _print_stops(figures, progress)
    figures["goals"] = {"latency": all(row["pass"] for row in figures["latency"]),
                        "throughput": figures["throughput"]["pass"], "soak": figures["soak"]["pass"],
                        "clean_stops": all(status == 0 for _, status in stops)}
    if progress:
        print("goals: " + ", ".join(f"{name} {'PASS' if ok else 'FAIL'}" for name, ok in figures["goals"].items()),
              file=progress)
    return figures


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--requests", type=int, default=None, help="soak requests (default 10000; --quick 40)")
    parser.add_argument("--rounds", type=int, default=None, help="latency rounds per scan (default 80; --quick 3)")
    parser.add_argument("--large-rounds", type=int, default=25, help="latency rounds of the 10^5 scan (default 25)")
    parser.add_argument("--quick", action="store_true", help="small scans, few rounds, a short soak (for the test)")
    parser.add_argument("--json", action="store_true", help="print one JSON object with every figure instead of tables")
    add_docs_options(parser, VALIDATION / "speed.md")
    args = parser.parse_args(argv)
    args.requests = args.requests if args.requests is not None else (40 if args.quick else 10_000)
    args.rounds = args.rounds if args.rounds is not None else (3 if args.quick else 80)
    args.warmup = 2 if args.quick else 5
    args.one_shot_runs = 1 if args.quick else 5
    args.throughput_requests = 16 if args.quick else 160
    args.throughput_repeats = 1 if args.quick else 2
    args.store_seconds = 0.5 if args.quick else 2.0
    if min(args.requests, args.rounds, args.large_rounds) < 1:
        parser.error("--requests, --rounds and --large-rounds must be at least 1")
    docs = docs_target(parser, args, argv, "serve.py", ["serve"])
    if args.json:
        figures = run(args, progress=None)
        print(json.dumps(figures, indent=1))
    else:
        with recording() as printed:
            figures = run(args, progress=sys.stdout)
        if docs:
            docs.write("serve", printed.text)
    return 0 if figures["goals"]["clean_stops"] else 1


if __name__ == "__main__":
    sys.exit(main())
