"""The HTTP front end of a real ``holecli serve`` process (holecli.serve.http), over 127.0.0.1."""

import json
import os
import shutil
import signal
import subprocess
import sys
import threading
from pathlib import Path

import pytest

httpx = pytest.importorskip("httpx")

REPO = Path(__file__).resolve().parents[2]
SAMPLES = REPO / "sample_clouds"
TOKEN = "0123456789abcdef-token"


def start(tmp, *options, timeout=60):
    """``holecli serve --port 0 OPTIONS`` started; returns (process, the ready line's addresses)."""
    process = subprocess.Popen([sys.executable, "-m", "holecli", "serve", "--port", "0", "-q", *map(str, options)],
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=tmp,
                               env=dict(os.environ, PYTHONPATH=str(REPO)))
    line = []
    reader = threading.Thread(target=lambda: line.append(process.stdout.readline()), daemon=True)
    reader.start()
    reader.join(timeout)
    if not line or not line[0]:
        process.kill()
        _, err = process.communicate(timeout=10)
        pytest.fail(f"holecli serve did not say it was ready: {err}")
    return process, json.loads(line[0])


def stop(process):
    process.send_signal(signal.SIGTERM)
    try:
        _, err = process.communicate(timeout=30)
    except subprocess.TimeoutExpired:
        process.kill()
        process.communicate()
        pytest.fail("holecli serve did not stop within 30 s of SIGTERM")
    return process.returncode, err


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    folder = tmp_path_factory.mktemp("http")
    (folder / "scans").mkdir()
    (folder / "specs").mkdir()
    for name in ("table1.ply", "panel.ply"):
        shutil.copy(SAMPLES / name, folder / "scans" / name)
    shutil.copy(SAMPLES / "panel_tolerances.toml", folder / "specs" / "panel.toml")
    process, addresses = start(folder, "--allow-dir", folder / "scans", "--spec-dir", folder / "specs",
                               "--store", folder / "results.sqlite", "--workers", 1, "--max-upload-mb", 1)
    with httpx.Client(base_url=addresses["http"], timeout=60) as client:
        yield client, folder, addresses
    code, err = stop(process)
    assert code == 0 and "Traceback" not in err, err


def test_the_ready_line_gives_the_addresses(server):
    _, folder, addresses = server
    assert addresses["http"].startswith("http://127.0.0.1:") and addresses["tcp"] is None
    assert addresses["store"] == str(folder / "results.sqlite") and addresses["workers"] == 1


def test_measure_by_path_answers_the_stored_record(server):
    client, _, _ = server
    answer = client.post("/v1/measure", json={"path": "table1.ply", "meta": {"part": "P1", "serial": "7"}})
    assert answer.status_code == 200, answer.text
    record = answer.json()
    assert record["file"] == "table1.ply" and record["stored"] is True and len(record["holes"]) == 1
    assert client.get(f"/v1/results/{record['id']}").json() == record
    jsonschema = pytest.importorskip("jsonschema")
    from holecli.schema import record_schema

    jsonschema.Draft202012Validator(record_schema("served_record")).validate(record)
    listed = client.get("/v1/results", params={"part": "P1", "serial": "7"}).json()
    assert [summary["id"] for summary in listed] == [record["id"]]


def test_measure_an_upload_with_its_format_and_meta_in_the_query(server):
    client, _, _ = server
    data = (SAMPLES / "table1.ply").read_bytes()
    answer = client.post("/v1/measure", params={"format": "ply", "part": "P2", "max_holes": 1}, content=data,
                         headers={"content-type": "application/octet-stream"})
    assert answer.status_code == 200, answer.text
    record = answer.json()
    assert record["file"] == "upload.ply" and record["meta"]["part"] == "P2"
    assert record["options"]["max_holes"] == 1


def test_a_named_spec_and_the_verdict_filter(server):
    client, _, _ = server
    record = client.post("/v1/measure", json={"path": "panel.ply", "spec": "panel"}).json()
    assert record["verdict"]["in_tolerance"] is True
    assert record["id"] in [summary["id"] for summary in client.get("/v1/results?verdict=pass").json()]
    assert record["id"] not in [summary["id"] for summary in client.get("/v1/results?verdict=fail").json()]


@pytest.mark.parametrize("send, status, code", [
    ({"json": {"path": "missing.ply"}}, 404, "not_found"),
    ({"json": {"path": "../x.ply"}}, 400, "bad_request"),
    ({"json": {"path": "/etc/hostname"}}, 403, "forbidden"),
    ({"json": {"path": "table1.ply", "speed": 1}}, 400, "bad_request"),
    ({"json": ["table1.ply"]}, 400, "bad_request"),
    ({"content": b"{not json", "headers": {"content-type": "application/json"}}, 400, "bad_request"),
    ({"content": b"ply\n"}, 400, "bad_request"),  # an upload without ?format=
    ({"content": b"garbage", "params": {"format": "ply"}}, 422, "unmeasurable"),
    ({"content": b"x" * (2**20 + 1), "params": {"format": "ply"}}, 413, "too_large"),
    ({"content": b"x", "params": {"format": "obj"}}, 400, "bad_request"),
    ({"content": b"x", "params": {"format": "ply", "max_holes": "many"}}, 400, "bad_request"),
])
def test_refusals_are_one_json_error_with_their_status(server, send, status, code):
    client, _, _ = server
    answer = client.post("/v1/measure", **send)
    assert answer.status_code == status, answer.text
    assert answer.json()["error"]["status"] == status and answer.json()["error"]["code"] == code
    assert "\n" not in answer.json()["error"]["message"]


def test_an_unknown_result_is_404(server):
    client, _, _ = server
    assert client.get("/v1/results/" + "0" * 32).status_code == 404
    assert client.get("/v1/results?since=yesterday").status_code == 400
    assert client.get("/v1/results?limit=0").status_code == 400


def test_health_metrics_and_the_openapi_document(server):
    client, _, _ = server
    health = client.get("/v1/health").json()
    assert health["status"] == "ok" and health["workers"] == 1
    metrics = client.get("/metrics")
    assert metrics.headers["content-type"].startswith("text/plain")
    assert 'holecli_requests_total{channel="http",outcome="ok"}' in metrics.text
    assert "holecli_request_seconds_bucket" in metrics.text and "holecli_queue_depth" in metrics.text
    document = client.get("/openapi.json").json()
    assert set(document["paths"]) == {"/v1/measure", "/v1/results/{result_id}", "/v1/results", "/v1/health",
                                      "/metrics"}
    body = document["paths"]["/v1/measure"]["post"]["requestBody"]["content"]
    assert set(body) == {"application/json", "application/octet-stream"}
    assert client.get("/docs").status_code == 404  # no page that loads scripts from a CDN


def test_a_token_is_asked_for_when_given(tmp_path):
    token_file = tmp_path / "token"
    token_file.write_text(TOKEN + "\n")
    token_file.chmod(0o600)
    shutil.copy(SAMPLES / "table1.ply", tmp_path / "table1.ply")
    process, addresses = start(tmp_path, "--allow-dir", tmp_path, "--token-file", token_file,
                               "--store", tmp_path / "r.sqlite", "--workers", 1)
    try:
        with httpx.Client(base_url=addresses["http"], timeout=60) as client:
            assert client.post("/v1/measure", json={"path": "table1.ply"}).status_code == 401
            wrong = client.post("/v1/measure", json={"path": "table1.ply"}, headers={"authorization": "Bearer nope"})
            assert wrong.status_code == 401 and wrong.json()["error"]["code"] == "unauthorized"
            assert client.get("/v1/results").status_code == 401
            assert client.get("/v1/health").status_code == 200
            right = client.post("/v1/measure", json={"path": "table1.ply"}, headers={"authorization": f"Bearer {TOKEN}"})
            assert right.status_code == 200
    finally:
        code, err = stop(process)
    assert code == 0, err
