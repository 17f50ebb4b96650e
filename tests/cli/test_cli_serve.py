"""``holecli serve``'s command line: what it refuses before starting, and what it keeps out of the
other commands (the service's libraries are imported by ``serve`` only)."""

import re
import socket

import pytest

from holecli import cli

SERVICE_LIBRARIES = ("fastapi", "uvicorn", "starlette", "prometheus_client", "psycopg", "asyncua")


def test_help_names_every_front_end_and_limit(run):
    result = run("serve", "--help")
    assert result.exit_code == 0
    for option in ("--host", "--port", "--tcp-port", "--tcp-units", "--opcua-port", "--opcua-cert", "--opcua-key", "--store", "--spec-dir",
                   "--allow-dir", "--token-file", "--workers", "--max-upload-mb", "--request-timeout",
                   "--worker-memory-mb"):
        assert option in result.stdout
    assert "Exit codes:" in result.stdout


def test_a_bind_beyond_loopback_needs_a_token(holecli_process, tmp_path):
    result = holecli_process("serve", "--host", "0.0.0.0", "--store", tmp_path / "r.sqlite")
    assert result.returncode == cli.EXIT_USAGE
    assert re.fullmatch(r"Error: --host 0\.0\.0\.0 is beyond the loopback interface: give --token-file.*\n",
                        result.stderr.splitlines(keepends=True)[-1])
    assert not (tmp_path / "r.sqlite").exists()


def test_opcua_beyond_loopback_needs_a_certificate_and_a_token(holecli_process, tmp_path):
    token = tmp_path / "token"
    token.write_text("0123456789abcdef0123\n")
    token.chmod(0o600)
    result = holecli_process("serve", "--host", "0.0.0.0", "--token-file", token, "--opcua-port", 4840,
                             "--store", tmp_path / "r.sqlite")
    assert result.returncode == cli.EXIT_USAGE
    assert "needs a server certificate and key" in result.stderr.splitlines()[-1]
    result = holecli_process("serve", "--opcua-cert", token, "--store", tmp_path / "r.sqlite")
    assert result.returncode == cli.EXIT_USAGE and "--opcua-cert and --opcua-key are for --opcua-port" in result.stderr


def test_a_token_file_others_can_read_is_refused(holecli_process, tmp_path):
    token = tmp_path / "token"
    token.write_text("0123456789abcdef0123\n")
    token.chmod(0o644)
    result = holecli_process("serve", "--token-file", token, "--store", tmp_path / "r.sqlite")
    assert result.returncode == cli.EXIT_INPUT
    assert result.stderr == f"Error: {token}: the token file is readable by others (chmod 600 it)\n"


def test_a_port_in_use_is_one_error_line(holecli_process, tmp_path):
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen(1)
        port = taken.getsockname()[1]
        result = holecli_process("serve", "--port", port, "--store", tmp_path / "r.sqlite")
    assert result.returncode == cli.EXIT_INPUT
    assert result.stderr.startswith(f"Error: 127.0.0.1:{port}: cannot listen there (--port): ")
    assert len(result.stderr.splitlines()) == 1


def test_a_store_that_cannot_be_opened_is_one_error_line(holecli_process, tmp_path):
    not_sqlite = tmp_path / "notes.sqlite"
    not_sqlite.write_text("these are my notes, not a database\n" * 100)
    result = holecli_process("serve", "--port", 0, "--store", not_sqlite)
    assert result.returncode == cli.EXIT_INPUT
    assert result.stderr.startswith("Error: ") and str(not_sqlite) in result.stderr
    assert len(result.stderr.splitlines()) == 1 and "Traceback" not in result.stderr
    assert not_sqlite.read_text() == "these are my notes, not a database\n" * 100


@pytest.mark.parametrize("command", [["--help"], ["serve", "--help"], ["detect", "--help"], ["batch", "--help"]])
def test_the_service_libraries_stay_out_of_the_other_commands(modules_imported_by, command):
    assert modules_imported_by([command], SERVICE_LIBRARIES) == "[]"
