"""Malformed requests to ``holecli serve`` get a 4xx, never a 5xx, a hang or a dead server, and nothing
in a request makes the service write outside its store (issue 27, "Reliability and security").

One server for the module (``--max-upload-mb 1``, an allowed folder with a link out of it, a spec
folder), in a folder of its own whose files are listed before it starts and after it stopped: the
last test checks that only the store changed.
"""

from __future__ import annotations

import os
import shutil
import signal

import httpx
import pytest

TABLE1_SPEC = """\
[[hole]]
name = "H1"
center = [3.6496, 5.1389, 5.5299]
diameter = 3.0
tolerance = 0.05
position_tolerance = 0.1
"""


def listing(root):
    """``{relative path: (size, mtime)}`` of every file and link under ``root``."""
    found = {}
    for folder, folders, files in os.walk(root):
        for name in files + [entry for entry in folders if os.path.islink(os.path.join(folder, entry))]:
            path = os.path.join(folder, name)
            status = os.lstat(path)
            found[os.path.relpath(path, root)] = (status.st_size, status.st_mtime_ns)
    return found


@pytest.fixture(scope="module")
def site(tmp_path_factory, repo_root, start_serve):
    """The module's server and its folder: ``root`` (everything), ``scans`` (--allow-dir), ``outside``
    (a folder it may not read), ``before`` (the listing before it started)."""
    root = tmp_path_factory.mktemp("fuzz")
    scans, outside, specs = root / "scans", root / "outside", root / "specs"
    for folder in (scans, outside, specs, root / "cwd", root / "tmp"):
        folder.mkdir()
    shutil.copy(repo_root / "sample_clouds" / "table1.ply", scans / "table1.ply")
    shutil.copy(repo_root / "sample_clouds" / "table1.ply", outside / "secret.ply")
    os.symlink(outside / "secret.ply", scans / "link.ply")
    (specs / "table1.toml").write_text(TABLE1_SPEC)
    (specs / "broken.toml").write_text("[[hole]]\nname = 3\n")
    before = listing(root)
    env = dict(os.environ, PYTHONPATH=str(repo_root), TMPDIR=str(root / "tmp"))
    env.pop("PYTHONWARNINGS", None)
    served = start_serve(["--allow-dir", scans, "--spec-dir", specs, "--max-upload-mb", "1", "--workers", "2"],
                          env=env, cwd=root / "cwd", store=root / "store.sqlite")
    yield {"served": served, "root": root, "scans": scans, "outside": outside, "before": before}
    served.stop()
    assert served.leftovers() == []


@pytest.fixture
def client(site):
    with httpx.Client(base_url=site["served"].http, timeout=60) as client:
        yield client


JSON = {"content-type": "application/json"}
SCAN = b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n"


def chunks(size, piece=65536):
    """A body of ``size`` bytes sent chunked (no Content-Length)."""
    for start in range(0, size, piece):
        yield b"0" * min(piece, size - start)


MALFORMED = [
    # (name, method, url, keyword arguments of httpx, expected status)
    ("not JSON", "POST", "/v1/measure", {"content": b"{nope", "headers": JSON}, 400),
    ("a JSON array", "POST", "/v1/measure", {"json": [1, 2, 3]}, 400),
    ("a JSON string", "POST", "/v1/measure", {"json": "table1.ply"}, 400),
    ("JSON null", "POST", "/v1/measure", {"content": b"null", "headers": JSON}, 400),
    ("an empty JSON body", "POST", "/v1/measure", {"content": b"", "headers": JSON}, 400),
    ("huge JSON", "POST", "/v1/measure", {"json": {"path": "x" * 900_000}}, 400),
    ("deep JSON", "POST", "/v1/measure", {"content": b"[" * 100_000 + b"]" * 100_000, "headers": JSON}, 400),
    ("deep JSON in options", "POST", "/v1/measure",
     {"content": b'{"path": "table1.ply", "options": {"x": ' + b"[" * 5000 + b"]" * 5000 + b"}}",
      "headers": JSON}, 400),
    ("not UTF-8", "POST", "/v1/measure", {"content": b'{"path": "t\xe9.ply"}', "headers": JSON}, 400),
    ("a lone surrogate", "POST", "/v1/measure", {"content": b'{"path": "\\ud800.ply"}', "headers": JSON}, 400),
    ("path a number", "POST", "/v1/measure", {"json": {"path": 5}}, 400),
    ("no path", "POST", "/v1/measure", {"json": {"options": {}}}, 400),
    ("an unknown key", "POST", "/v1/measure", {"json": {"path": "table1.ply", "output": "/tmp/x"}}, 400),
    ("options a list", "POST", "/v1/measure", {"json": {"path": "table1.ply", "options": []}}, 400),
    ("an unknown option", "POST", "/v1/measure", {"json": {"path": "table1.ply", "options": {"output": "/tmp/x"}}},
     400),
    ("min_diameter a string", "POST", "/v1/measure", {"json": {"path": "table1.ply", "options": {"min_diameter": "1"}}},
     400),
    ("min_diameter NaN", "POST", "/v1/measure",
     {"content": b'{"path": "table1.ply", "options": {"min_diameter": NaN}}', "headers": JSON}, 400),
    ("min_diameter infinite", "POST", "/v1/measure",
     {"content": b'{"path": "table1.ply", "options": {"min_diameter": 1e999}}', "headers": JSON}, 400),
    ("max_holes a float", "POST", "/v1/measure", {"json": {"path": "table1.ply", "options": {"max_holes": 1.5}}}, 400),
    ("max_holes huge", "POST", "/v1/measure", {"json": {"path": "table1.ply", "options": {"max_holes": 10**40}}}, 400),
    ("view_dir zero", "POST", "/v1/measure", {"json": {"path": "table1.ply", "options": {"view_dir": [0, 0, 0]}}}, 400),
    ("view_dir two numbers", "POST", "/v1/measure", {"json": {"path": "table1.ply", "options": {"view_dir": [0, 1]}}},
     400),
    ("paper with max_holes", "POST", "/v1/measure",
     {"json": {"path": "table1.ply", "options": {"method": "paper", "max_holes": 2}}}, 400),
    ("meta a number", "POST", "/v1/measure", {"json": {"path": "table1.ply", "meta": {"part": 5}}}, 400),
    ("meta with a NUL", "POST", "/v1/measure", {"json": {"path": "table1.ply", "meta": {"part": "a\x00b"}}}, 400),
    ("meta too long", "POST", "/v1/measure", {"json": {"path": "table1.ply", "meta": {"part": "p" * 201}}}, 400),
    ("meta key not a word", "POST", "/v1/measure", {"json": {"path": "table1.ply", "meta": {"a b": "x"}}}, 400),
    ("format not one", "POST", "/v1/measure", {"json": {"path": "table1.ply", "format": "docx"}}, 400),
    ("upload format not one", "POST", "/v1/measure?format=docx", {"content": SCAN}, 400),
    ("upload without a format", "POST", "/v1/measure", {"content": SCAN}, 400),
    ("upload with max_holes not a number", "POST", "/v1/measure?format=ply&max_holes=abc", {"content": SCAN}, 400),
    ("an empty upload", "POST", "/v1/measure?format=ply", {"content": b""}, 422),
    ("a garbage upload", "POST", "/v1/measure?format=ply", {"content": os.urandom(4096)}, 422),
    ("a garbage PCD", "POST", "/v1/measure?format=pcd",
     {"content": b"VERSION .7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 99999999\nHEIGHT 1\n"
                 b"POINTS 99999999\nDATA binary\n"}, 422),
    ("a garbage E57", "POST", "/v1/measure?format=e57", {"content": b"ASTM-E57" + os.urandom(2000)}, 422),
    ("a garbage LAS", "POST", "/v1/measure?format=las", {"content": b"LASF" + os.urandom(2000)}, 422),
    ("a binary text table", "POST", "/v1/measure?format=xyz", {"content": b"\x00\xff" * 500}, 422),
    ("a one-point scan", "POST", "/v1/measure?format=ply", {"content": SCAN + b"1 2 3\n"}, 422),
    ("over --max-upload-mb (Content-Length)", "POST", "/v1/measure?format=ply", {"content": b"0" * (2**20 + 1)}, 413),
    ("over --max-upload-mb (chunked)", "POST", "/v1/measure?format=ply", {"content": chunks(3 * 2**20)}, 413),
    ("JSON over --max-upload-mb", "POST", "/v1/measure", {"content": chunks(2 * 2**20), "headers": JSON}, 413),
    ("a path with ..", "POST", "/v1/measure", {"json": {"path": "../outside/secret.ply"}}, 400),
    ("a path with .. inside", "POST", "/v1/measure", {"json": {"path": "sub/../table1.ply"}}, 400),
    ("an absolute path outside", "POST", "/v1/measure", {"json": {"path": "/etc/passwd"}}, 403),
    ("a link out of the folder", "POST", "/v1/measure", {"json": {"path": "link.ply"}}, 403),
    ("a missing file", "POST", "/v1/measure", {"json": {"path": "missing.ply"}}, 404),
    ("a folder", "POST", "/v1/measure", {"json": {"path": "."}}, 404),
    ("a path with NUL", "POST", "/v1/measure", {"json": {"path": "table1.ply\x00.txt"}}, 400),
    ("a spec name with /", "POST", "/v1/measure", {"json": {"path": "table1.ply", "spec": "a/b"}}, 400),
    ("a spec name ..", "POST", "/v1/measure", {"json": {"path": "table1.ply", "spec": ".."}}, 400),
    ("a spec path", "POST", "/v1/measure", {"json": {"path": "table1.ply", "spec": "/etc/passwd"}}, 400),
    ("a spec name with / in the query", "POST", "/v1/measure?format=ply&spec=../specs/table1", {"content": SCAN}, 400),
    ("an unknown spec", "POST", "/v1/measure", {"json": {"path": "table1.ply", "spec": "nope"}}, 404),
    ("a broken spec", "POST", "/v1/measure", {"json": {"path": "table1.ply", "spec": "broken"}}, 422),
    ("a registration without a spec", "POST", "/v1/measure", {"json": {"path": "table1.ply", "registration": "r"}},
     400),
    ("an unknown registration", "POST", "/v1/measure",
     {"json": {"path": "table1.ply", "spec": "table1", "registration": "nope"}}, 404),
    ("a result id that is not one", "GET", "/v1/results/not-an-id", {}, 400),
    ("an unknown result", "GET", "/v1/results/0123456789abcdef", {}, 404),
    ("since not a date", "GET", "/v1/results?since=yesterday", {}, 400),
    ("until out of range", "GET", "/v1/results?until=99999-01-01", {}, 400),
    ("a verdict that is not one", "GET", "/v1/results?verdict=maybe", {}, 400),
    ("limit 0", "GET", "/v1/results?limit=0", {}, 400),
    ("a method not allowed", "DELETE", "/v1/results", {}, 405),
    ("an unknown route", "GET", "/v1/nothing", {}, 404),
]


@pytest.mark.parametrize("name, method, url, arguments, status", MALFORMED, ids=[case[0] for case in MALFORMED])
def test_a_malformed_request_gets_its_4xx(client, name, method, url, arguments, status):
    response = client.request(method, url, **arguments)
    assert response.status_code == status, response.text
    error = response.json()["error"]
    assert error["status"] == status and "\n" not in error["message"]


@pytest.mark.parametrize("url", ["/v1/measure?format=ply", "/v1/measure?format=ply&explain=true"])
def test_an_upload_error_names_the_upload_not_the_services_copy(client, url):
    response = client.post(url, content=b"")
    assert response.status_code == 422
    message = response.json()["error"]["message"]
    assert message.startswith("upload.ply: "), message
    assert "holecli-serve-uploads" not in message


def test_an_error_names_the_file_as_the_request_did_not_its_real_path(client, site):
    response = client.post("/v1/measure", json={"path": "table1.ply", "format": "csv"})
    assert response.status_code == 422
    message = response.json()["error"]["message"]
    assert message.startswith("table1.ply: "), message
    assert str(site["root"]) not in message


def test_good_requests_are_measured_and_checked(client, site):
    for arguments in ({"json": {"path": "table1.ply", "spec": "table1", "meta": {"part": "P1", "serial": "S1"}}},
                      {"content": (site["scans"] / "table1.ply").read_bytes(), "params": {"format": "ply",
                                                                                         "spec": "table1"}}):
        response = client.post("/v1/measure", **arguments)
        assert response.status_code == 200, response.text
        assert response.json()["verdict"]["in_tolerance"] is True, response.json()["verdict"]


def naming_table1(case):
    """``case`` with its JSON body's path (when it has one) replaced by the allowed scan's."""
    if isinstance(case.body, dict) and isinstance(case.body.get("path"), str):
        case.body["path"] = "table1.ply"
    return case


@pytest.mark.slow
def test_schemathesis_finds_no_server_error(site):
    """A fuzz of the OpenAPI document: positive and negative cases of every operation; no 5xx."""
    import requests
    import schemathesis
    from hypothesis import HealthCheck, given, settings
    from hypothesis.errors import Unsatisfiable
    from schemathesis import GenerationMode

    served = site["served"]
    schema = schemathesis.openapi.from_url(served.http + "/openapi.json", timeout=30)
    failures, calls, no_negative = [], [], []
    with requests.Session() as session:
        operations = [result.ok() for result in schema.get_all_operations()]
        runs = [(operation, mode, operation.as_strategy(generation_mode=mode), 150)
                for operation in operations for mode in (GenerationMode.POSITIVE, GenerationMode.NEGATIVE)]
        # and measure requests that name a scan the service has, so that fuzzed options, specs and
        # metadata reach the workers and the store
        measure = schema["/v1/measure"]["POST"]
        runs += [(measure, mode, measure.as_strategy(generation_mode=mode).map(naming_table1), 60)
                 for mode in (GenerationMode.POSITIVE, GenerationMode.NEGATIVE)]
        for operation, mode, strategy, examples in runs:

            @settings(max_examples=examples, database=None, deadline=None, derandomize=True,
                      suppress_health_check=list(HealthCheck))
            @given(case=strategy)
            def fuzz(case):
                response = case.call(base_url=served.http, session=session, timeout=60)
                calls.append(operation.label)
                if response.status_code >= 500:
                    failures.append((response.status_code, case.as_curl_command(), response.text[:300]))

            try:
                fuzz()
            except Unsatisfiable:  # an operation without parameters has no negative case
                if mode is GenerationMode.POSITIVE:
                    raise
                no_negative.append(operation.label)
    assert not failures, failures
    assert "POST /v1/measure" not in no_negative and "GET /v1/results" not in no_negative, no_negative
    assert calls.count("POST /v1/measure") >= 40, sorted(set(calls))
    with httpx.Client() as client:
        assert client.get(served.http + "/v1/health", timeout=10).json()["status"] == "ok"
    assert "Traceback" not in served.stderr, served.stderr


def test_no_request_made_the_service_write_outside_its_store(site):
    """Last in this module: stop the server; only its store (and SQLite's -wal and -shm) changed."""
    served = site["served"]
    with httpx.Client() as client:
        assert client.get(served.http + "/v1/health", timeout=10).status_code == 200
    served.signal(signal.SIGTERM)
    assert served.wait(60) == 0
    assert "Traceback" not in served.stderr, served.stderr
    after = listing(site["root"])
    changed = {path for path in set(after) | set(site["before"]) if after.get(path) != site["before"].get(path)}
    assert changed <= {"store.sqlite", "store.sqlite-wal", "store.sqlite-shm"}, sorted(changed)
    assert "store.sqlite" in changed
    assert os.listdir(site["root"] / "tmp") == []  # the uploads' folder is removed
