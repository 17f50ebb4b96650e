"""Who may ask ``holecli serve`` for what over HTTP (issue 27, "Reliability and security"): loopback by
default, a bearer token (``--token-file``, mode 600) beyond it, files confined to ``--allow-dir``."""

from __future__ import annotations

import os
import secrets

import httpx
import pytest

TOKEN = secrets.token_hex(16)


@pytest.fixture
def token_file(tmp_path):
    path = tmp_path / "token"
    path.write_text(TOKEN + "\n")
    path.chmod(0o600)
    return path


def local(url):
    """``url`` with the wildcard address replaced by the loopback one (where a test can connect)."""
    return url.replace("0.0.0.0", "127.0.0.1")


def test_binding_beyond_the_loopback_without_a_token_is_a_usage_error(run_serve, tmp_path):
    result = run_serve("--host", "0.0.0.0", "--port", 0, "--store", tmp_path / "store.sqlite")
    assert result.returncode == 2, result.stderr
    errors = [line for line in result.stderr.splitlines() if line.startswith("Error:")]
    assert len(errors) == 1 and "--token-file" in errors[0], result.stderr
    assert "Traceback" not in result.stderr
    assert not (tmp_path / "store.sqlite").exists()  # refused before the store is opened


@pytest.mark.parametrize("mode", [0o644, 0o640, 0o604])
def test_a_token_file_others_may_read_is_refused_exit_3(run_serve, tmp_path, token_file, mode):
    token_file.chmod(mode)
    result = run_serve("--host", "0.0.0.0", "--port", 0, "--store", tmp_path / "store.sqlite",
                       "--token-file", token_file)
    assert result.returncode == 3, result.stderr
    assert result.stderr.startswith("Error: ") and len(result.stderr.strip().splitlines()) == 1, result.stderr
    assert "chmod 600" in result.stderr
    assert TOKEN not in result.stderr


def test_a_short_token_is_refused_exit_3(run_serve, tmp_path, token_file):
    token_file.write_text("short\n")
    result = run_serve("--port", 0, "--store", tmp_path / "store.sqlite", "--token-file", token_file)
    assert result.returncode == 3, result.stderr
    assert result.stderr.startswith("Error: ") and "16 characters" in result.stderr


def test_with_a_token_every_route_but_health_asks_for_it(serve, scans, token_file):
    served = serve("--host", "0.0.0.0", "--allow-dir", scans, "--workers", "1", "--token-file", token_file)
    url = local(served.http)
    right = {"Authorization": f"Bearer {TOKEN}"}
    wrong_ones = [{}, {"Authorization": f"Bearer {TOKEN[:-1]}x"}, {"Authorization": TOKEN},
                  {"Authorization": f"Basic {TOKEN}"}, {"Authorization": "Bearer"},
                  {"Authorization": f"Bearer {TOKEN}0"}]
    with httpx.Client(base_url=url, timeout=60) as client:
        assert client.get("/v1/health").status_code == 200
        for headers in wrong_ones:
            for method, route, body in (("POST", "/v1/measure", {"path": "table1.ply"}), ("GET", "/v1/results", None),
                                        ("GET", "/v1/results/0123abcd", None), ("GET", "/metrics", None),
                                        ("GET", "/openapi.json", None)):
                response = client.request(method, route, json=body, headers=headers)
                assert response.status_code == 401, (headers, route, response.text)
                assert response.json()["error"]["code"] == "unauthorized"
                assert TOKEN not in response.text
        answer = client.post("/v1/measure", json={"path": "table1.ply"}, headers=right)
        assert answer.status_code == 200, answer.text
        identifier = answer.json()["id"]
        assert client.get(f"/v1/results/{identifier}", headers=right).status_code == 200
        assert client.get("/v1/results", headers=right).json()[0]["id"] == identifier
        assert client.get("/metrics", headers=right).status_code == 200
    assert TOKEN not in served.stderr


def test_without_a_token_file_the_loopback_service_asks_for_none(serve, scans):
    served = serve("--allow-dir", scans, "--workers", "1")
    with httpx.Client(base_url=served.http, timeout=60) as client:
        assert client.post("/v1/measure", json={"path": "table1.ply"}).status_code == 200
        assert client.get("/v1/results", headers={"Authorization": "Bearer whatever"}).status_code == 200


def test_files_are_confined_to_the_allowed_folders(serve, scans, tmp_path):
    allowed = tmp_path / "allowed"
    (allowed / "sub").mkdir(parents=True)
    outside = tmp_path / "outside"
    outside.mkdir()
    table1 = (scans / "table1.ply").read_bytes()
    (allowed / "sub" / "in.ply").write_bytes(table1)
    (outside / "secret.ply").write_bytes(table1)
    os.symlink(outside / "secret.ply", allowed / "link.ply")
    os.symlink(outside, allowed / "linked_folder")
    os.symlink(allowed / "sub" / "in.ply", allowed / "inner_link.ply")
    served = serve("--allow-dir", allowed, "--workers", "1")
    cases = {
        "sub/in.ply": 200,
        str(allowed / "sub" / "in.ply"): 200,
        "inner_link.ply": 200,  # a link that stays inside
        "../outside/secret.ply": 400,
        "sub/../sub/in.ply": 400,  # '..' is refused as written
        str(allowed / ".." / "outside" / "secret.ply"): 400,
        str(outside / "secret.ply"): 403,
        "/etc/passwd": 403,
        "link.ply": 403,
        "linked_folder/secret.ply": 403,
        "missing.ply": 404,
        "sub": 404,  # a folder is not a scan
    }
    with httpx.Client(base_url=served.http, timeout=60) as client:
        for path, status in cases.items():
            response = client.post("/v1/measure", json={"path": path})
            assert response.status_code == status, (path, response.text)
            if status != 200:
                assert str(outside) not in response.text or path.startswith(str(outside)), response.text
            else:
                assert response.json()["file"] == path  # as named, not resolved
