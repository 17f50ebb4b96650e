"""``holecli serve`` under stop signals, ``kill -9``, its limits and the failures that stop it starting
(issue 27, "Reliability and security"): a real server in a process of its own (tests/serve/conftest.py)."""

from __future__ import annotations

import json
import os
import signal
import socket
import sqlite3
import subprocess
import sys
import threading
import time

import httpx
import pytest

from holecli.store import open_store
from tests.serve.conftest import descendants, wait_gone

MEASURE_TIMEOUT = 120


def measure(client, url, path, **body):
    """POST a measure-by-path request; the response."""
    return client.post(url + "/v1/measure", json={"path": path, **body}, timeout=MEASURE_TIMEOUT)


def wait_for(condition, seconds, step=0.02):
    """Poll ``condition()`` until it is true (then True) or ``seconds`` have passed (then False)."""
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        if condition():
            return True
        time.sleep(step)
    return False


def health(url):
    with httpx.Client() as client:
        return client.get(url + "/v1/health", timeout=10).json()


def integrity(path):
    connection = sqlite3.connect(path)
    try:
        return connection.execute("PRAGMA integrity_check").fetchall()
    finally:
        connection.close()


def assert_no_traceback(text):
    assert "Traceback" not in text, text


@pytest.mark.slow
def test_sigterm_answers_the_requests_in_flight_then_exits_0(serve, scans, tmp_path):
    served = serve("--allow-dir", scans, "--workers", "2")
    answers, errors = {}, []

    def post(number):
        try:
            with httpx.Client() as client:
                answers[number] = measure(client, served.http, "s1e5.ply", meta={"serial": f"S{number}"})
        except Exception as error:  # noqa: BLE001 - reported by the assertion below
            errors.append(error)

    threads = [threading.Thread(target=post, args=(number,)) for number in range(6)]
    for thread in threads:
        thread.start()
    # Every request is in flight (measured, or waiting for one of the 2 workers) before the signal.
    assert wait_for(lambda: health(served.http)["queue"] == 6, 30), health(served.http)
    served.signal(signal.SIGTERM)
    time.sleep(0.2)
    try:
        with httpx.Client() as client:
            late = measure(client, served.http, "table1.ply")
        assert late.status_code == 503, late.text
        assert late.json()["error"]["code"] == "unavailable"
    except (httpx.ConnectError, httpx.RemoteProtocolError):
        pass  # the listening socket is already closed: refused
    for thread in threads:
        thread.join(MEASURE_TIMEOUT)
    assert not errors
    assert sorted(answers) == list(range(6))
    assert all(response.status_code == 200 for response in answers.values()), \
        [response.text for response in answers.values()]
    assert served.wait(30) == 0
    assert_no_traceback(served.stderr)
    assert served.leftovers() == []
    with open_store(served.store) as store:
        for number, response in answers.items():
            stored = store.get(response.json()["id"])
            assert stored is not None and stored["meta"]["serial"] == f"S{number}"


@pytest.fixture(params=["sqlite", "postgresql"])
def store_location(request, tmp_path):
    """An empty store: an SQLite file, or a database of the test suite's PostgreSQL server (skipped
    when this checkout has no PostgreSQL fixture, or this machine no PostgreSQL)."""
    if request.param == "sqlite":
        return str(tmp_path / "store.sqlite")
    try:
        return request.getfixturevalue("postgres_store_url")
    except pytest.FixtureLookupError:
        pytest.skip("no postgres_store_url fixture in tests/conftest.py")


@pytest.mark.slow
def test_a_second_sigterm_cuts_the_requests_in_flight_and_exits_130(serve, scans):
    served = serve("--allow-dir", scans, "--workers", "1")
    answer = {}

    def post():
        with httpx.Client() as client:
            try:
                answer["status"] = measure(client, served.http, "s1e6.ply").status_code
            except httpx.HTTPError as error:  # the connection closed without an answer
                answer["status"] = error

    thread = threading.Thread(target=post)
    thread.start()
    assert wait_for(lambda: health(served.http)["queue"] == 1, 30)
    served.signal(signal.SIGTERM)
    time.sleep(0.3)
    served.signal(signal.SIGTERM)
    assert served.wait(30) == 130
    thread.join(MEASURE_TIMEOUT)
    assert answer["status"] != 200
    assert served.stderr.splitlines()[-1] == "Error: interrupted", served.stderr
    assert served.leftovers() == []
    assert integrity(served.store) == [("ok",)]


def test_sigterm_while_starting_exits_130_and_leaves_nothing(serve_env, tmp_path):
    process = subprocess.Popen([sys.executable, "-m", "holecli", "serve", "--port", "0", "--workers", "1", "--store",
                                tmp_path / "store.sqlite"], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                               text=True, env=serve_env, cwd=tmp_path)
    try:
        # its workers are being started (spawned, warming up): no ready line yet
        assert wait_for(lambda: any(b"spawn_main" in _cmdline(pid) for pid, _ in descendants(process.pid)), 60)
        children = descendants(process.pid)
        process.send_signal(signal.SIGTERM)
        out, err = process.communicate(timeout=30)
    finally:
        if process.poll() is None:
            process.kill()
            process.communicate(timeout=30)
    assert process.returncode == 130, err
    assert out == "" and err.strip() == "Error: interrupted", err
    assert wait_gone(children, 10) == []
    assert os.listdir(serve_env["TMPDIR"]) == []  # no uploads' folder left


def _cmdline(pid):
    try:
        with open(f"/proc/{pid}/cmdline", "rb") as stream:
            return stream.read()
    except OSError:
        return b""


@pytest.mark.slow
def test_kill_9_during_a_burst_loses_no_acknowledged_result(serve, scans, store_location):
    served = serve("--allow-dir", scans, "--workers", "2", store=store_location)
    acknowledged, lock, stop = [], threading.Lock(), threading.Event()

    def client_loop(number):
        with httpx.Client() as client:
            while not stop.is_set():
                try:
                    response = measure(client, served.http, "table1.ply", meta={"cell": f"C{number}"})
                except httpx.HTTPError:
                    return  # the server is gone
                if response.status_code == 200:
                    with lock:
                        acknowledged.append(response.json()["id"])

    threads = [threading.Thread(target=client_loop, args=(number,)) for number in range(4)]
    for thread in threads:
        thread.start()
    assert wait_for(lambda: len(acknowledged) >= 12, 60)
    workers = served.workers()
    assert len(workers) == 2
    served.signal(signal.SIGKILL)
    assert served.wait(10) == -signal.SIGKILL
    with lock:
        before_the_kill = list(acknowledged)
    stop.set()
    for thread in threads:
        thread.join(MEASURE_TIMEOUT)
    # Answers read after the kill were sent before it: all of them count.
    assert set(before_the_kill) <= set(acknowledged)
    # The workers die with the service (the parent-death signal), and so does the resource tracker.
    assert served.leftovers(seconds=5) == []
    if store_location.endswith(".sqlite"):
        assert integrity(served.store) == [("ok",)]
    with open_store(served.store) as store:
        missing = [identifier for identifier in acknowledged if store.get(identifier) is None]
        assert not missing, f"{len(missing)} of {len(acknowledged)} acknowledged results are not in the store"
        assert store.count() >= len(acknowledged)
    again = serve("--allow-dir", scans, "--workers", "1", store=served.store)
    with httpx.Client() as client:
        response = measure(client, again.http, "table1.ply")
        assert response.status_code == 200, response.text
        assert client.get(again.http + "/v1/results/" + acknowledged[0], timeout=10).status_code == 200


@pytest.mark.slow
def test_a_scan_over_the_request_timeout_gets_408_and_the_next_is_measured(serve, scans):
    served = serve("--allow-dir", scans, "--workers", "1", "--request-timeout", "0.5")
    with httpx.Client() as client:
        started = time.monotonic()
        response = measure(client, served.http, "s1e6.ply")
        assert response.status_code == 408, response.text
        assert response.json()["error"]["code"] == "timeout"
        assert time.monotonic() - started < 30
        assert measure(client, served.http, "table1.ply").status_code == 200


@pytest.mark.slow
def test_a_scan_over_the_worker_memory_gets_413_and_the_service_goes_on(serve, scans):
    served = serve("--allow-dir", scans, "--workers", "1", "--worker-memory-mb", "50")
    with httpx.Client() as client:
        response = measure(client, served.http, "s1e6.ply")
        assert response.status_code == 413, response.text
        assert response.json()["error"]["code"] == "too_large"
        assert measure(client, served.http, "table1.ply").status_code == 200
    assert served.stop() == 0
    assert_no_traceback(served.stderr)


@pytest.mark.slow
def test_a_worker_killed_while_measuring_gets_503_and_the_pool_is_replaced(serve, scans):
    served = serve("--allow-dir", scans, "--workers", "1")
    [worker] = served.workers()
    answer = {}

    def post():
        with httpx.Client() as client:
            answer["response"] = measure(client, served.http, "s1e6.ply")

    thread = threading.Thread(target=post)
    thread.start()
    assert wait_for(lambda: health(served.http)["queue"] == 1, 30)
    time.sleep(0.3)  # the worker is reading the 21 MB file
    os.kill(worker, signal.SIGKILL)
    thread.join(MEASURE_TIMEOUT)
    response = answer["response"]
    assert response.status_code == 503, response.text
    assert response.json()["error"]["code"] == "unavailable"
    with httpx.Client() as client:
        assert measure(client, served.http, "table1.ply").status_code == 200
        assert client.get(served.http + "/v1/health", timeout=10).json()["worker_restarts"] == 1
    assert worker not in served.workers()
    assert served.stop() == 0
    assert_no_traceback(served.stderr)


@pytest.mark.slow
def test_the_event_loop_answers_while_large_requests_are_handled(serve, scans):
    """Health answers within 2 s while a 10^6-point scan is measured by path and uploaded, and while
    JSON bodies far larger than a request needs are refused (413, not parsed on the loop)."""
    served = serve("--allow-dir", scans, "--workers", "1")
    latencies, stop = [], threading.Event()

    def poll():
        with httpx.Client() as client:
            while not stop.is_set():
                started = time.perf_counter()
                client.get(served.http + "/v1/health", timeout=30)
                latencies.append(time.perf_counter() - started)
                time.sleep(0.02)

    poller = threading.Thread(target=poll)
    poller.start()
    try:
        with httpx.Client(timeout=MEASURE_TIMEOUT) as client:
            huge = b'{"options": {"x": [' + b"1," * 25_000_000 + b'1]}, "path": "table1.ply"}'
            for content in (huge, (huge[start:start + 2**20] for start in range(0, len(huge), 2**20))):
                response = client.post(served.http + "/v1/measure", content=content,
                                       headers={"content-type": "application/json"})
                assert response.status_code == 413, response.text
            assert measure(client, served.http, "s1e6.ply").status_code == 200
            response = client.post(served.http + "/v1/measure", params={"format": "ply"},
                                   content=(scans / "s1e6.ply").read_bytes())
            assert response.status_code == 200, response.text
    finally:
        stop.set()
        poller.join(60)
    assert len(latencies) > 20 and max(latencies) < 2.0, sorted(latencies)[-5:]


@pytest.mark.slow
def test_past_the_queue_a_request_gets_503_at_once_and_the_others_are_measured(serve, scans):
    """One worker and 16 waiting places: of 30 requests sent at once, those beyond get 503 without
    waiting, every other one is measured and stored."""
    served = serve("--allow-dir", scans, "--workers", "1")
    barrier, answers = threading.Barrier(30), []

    def post():
        with httpx.Client() as client:
            client.get(served.http + "/v1/health", timeout=30)  # connected before the barrier
            barrier.wait(30)
            started = time.monotonic()
            response = measure(client, served.http, "s1e5.ply")
            answers.append((response, time.monotonic() - started))

    threads = [threading.Thread(target=post) for _ in range(30)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(MEASURE_TIMEOUT)
    refused = [seconds for response, seconds in answers if response.status_code == 503]
    measured = [response.json()["id"] for response, _ in answers if response.status_code == 200]
    assert len(answers) == 30 and len(refused) + len(measured) == 30, [r.text for r, _ in answers]
    assert refused and len(measured) >= 17, (len(refused), len(measured))
    assert max(refused) < 2.0
    with open_store(served.store) as store:
        assert all(store.get(identifier) is not None for identifier in measured)
    assert health(served.http)["queue"] == 0


def test_a_port_in_use_is_said_in_one_line_exit_3(run_serve, tmp_path):
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen(1)
        port = taken.getsockname()[1]
        result = run_serve("--port", port, "--store", tmp_path / "store.sqlite")
    assert result.returncode == 3, result.stderr
    assert result.stderr.startswith(f"Error: 127.0.0.1:{port}: cannot listen there"), result.stderr
    assert len(result.stderr.strip().splitlines()) == 1, result.stderr
    assert result.stdout == ""


@pytest.mark.slow
def test_two_servers_started_on_one_port_one_serves_the_other_exits_3(serve_env, tmp_path):
    """Both bind the port while their workers warm up (address reuse lets a socket that does not
    listen yet share it); the one that listens second is refused: it says so, it does not crash."""
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    command = [sys.executable, "-m", "holecli", "serve", "--port", str(port), "--workers", "1"]
    processes = [subprocess.Popen(command + ["--store", tmp_path / f"{name}.sqlite"], stdout=subprocess.PIPE,
                                  stderr=subprocess.PIPE, text=True, env=serve_env, cwd=tmp_path)
                 for name in ("a", "b")]
    try:
        assert wait_for(lambda: any(process.poll() is not None for process in processes), 90, step=0.1)
        [loser] = [process for process in processes if process.poll() is not None]
        [winner] = [process for process in processes if process is not loser]
        out, err = loser.communicate(timeout=30)
        assert loser.returncode == 3, err
        assert err.startswith(f"Error: 127.0.0.1:{port}: cannot listen there (--port)"), err
        assert len(err.strip().splitlines()) == 1 and out == "", err
        children = descendants(winner.pid)
        with httpx.Client() as client:
            assert client.get(f"http://127.0.0.1:{port}/v1/health", timeout=30).status_code == 200
        winner.send_signal(signal.SIGTERM)
        out, err = winner.communicate(timeout=30)
        assert winner.returncode == 0, err
        assert json.loads(out.splitlines()[0])["http"] == f"http://127.0.0.1:{port}"
        assert wait_gone(children, 10) == []
    finally:
        for process in processes:
            if process.poll() is None:
                process.kill()
            process.communicate(timeout=30)


@pytest.mark.parametrize("store", ["a folder", "not sqlite"])
def test_a_store_that_is_not_a_store_is_said_in_one_line_exit_3(run_serve, tmp_path, store):
    location = tmp_path / "store"
    if store == "a folder":
        location.mkdir()
    else:
        location.write_bytes(b"these are not the droids you are looking for\n" * 100)
    before = sorted(path.name for path in tmp_path.iterdir())
    result = run_serve("--port", 0, "--store", location)
    assert result.returncode == 3, result.stderr
    assert result.stderr.startswith("Error: "), result.stderr
    assert len(result.stderr.strip().splitlines()) == 1, result.stderr
    assert str(location) in result.stderr
    assert result.stdout == ""
    if store == "not sqlite":
        assert location.read_bytes() == b"these are not the droids you are looking for\n" * 100
    assert sorted(path.name for path in tmp_path.iterdir()) == before


def test_the_ready_line_names_the_addresses_and_the_store(serve, tmp_path):
    served = serve("--workers", "1")
    assert served.ready["http"].startswith("http://127.0.0.1:")
    assert served.ready["store"] == str(tmp_path / "store.sqlite")
    assert served.ready["workers"] == 1 and served.ready["pid"] == served.process.pid
    assert json.loads(json.dumps(served.ready)) == served.ready
    assert health(served.http)["status"] == "ok"
