"""The PostgreSQL results store against a real server (tests/pgserver.py): what it refuses, a password
never shown, a lost connection, a killed writer, two writers at once."""

import json

import psycopg
import pytest

from holecli.store import StoreError, open_store
from holecli.store.postgres import PostgresStore, redacted

from tests.store.durability import added_until_killed, concurrent_adds


def test_a_postgres_url_opens_a_postgres_store(postgres_store_url):
    with open_store(postgres_store_url) as store:
        assert isinstance(store, PostgresStore) and store.location == postgres_store_url
    with psycopg.connect(postgres_store_url) as connection:
        types = dict(connection.execute("SELECT column_name, data_type FROM information_schema.columns "
                                        "WHERE table_name = 'measurement'").fetchall())
    assert (types["received"], types["record"], types["processing_ms"]) == (
        "timestamp with time zone", "json", "double precision")


def test_the_postgres_scheme_is_accepted_too(postgres_store_url):
    with open_store("postgres://" + postgres_store_url.split("://", 1)[1]) as store:
        assert store.count() == 0


def test_a_database_with_other_tables_is_refused_and_left_alone(postgres_store_url):
    with psycopg.connect(postgres_store_url, autocommit=True) as connection:
        connection.execute("CREATE TABLE invoices (number integer)")
    with pytest.raises(StoreError, match=r"not a holecli results store \(a database with other tables: invoices\)"):
        open_store(postgres_store_url)
    with psycopg.connect(postgres_store_url) as connection:
        tables = connection.execute("SELECT table_name FROM information_schema.tables "
                                    "WHERE table_schema = 'public'").fetchall()
    assert tables == [("invoices",)]


def test_a_newer_schema_is_refused(postgres_store_url):
    with open_store(postgres_store_url):
        pass
    with psycopg.connect(postgres_store_url, autocommit=True) as connection:
        connection.execute("UPDATE store_info SET value = '7' WHERE key = 'schema_version'")
    with pytest.raises(StoreError, match="schema version 7, newer than this holecli's"):
        open_store(postgres_store_url)


def test_an_unreachable_server_is_a_store_error_without_the_password(postgres_url):
    import socket

    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        port = sock.getsockname()[1]  # nothing listens there once closed
    url = f"postgresql://cell:s3cret@127.0.0.1:{port}/results"
    with pytest.raises(StoreError) as caught:
        open_store(url)
    message = str(caught.value)
    assert message.startswith(f"postgresql://cell:***@127.0.0.1:{port}/results: cannot open the results store: ")
    assert "s3cret" not in message and "\n" not in message


@pytest.mark.parametrize("url, shown", [
    ("postgresql://u:p@h/db", "postgresql://u:***@h/db"),
    ("postgresql://u@h/db?password=p&sslmode=require", "postgresql://u@h/db?password=***&sslmode=require"),
    ("postgresql://h/db", "postgresql://h/db"),
])
def test_the_password_is_redacted(url, shown):
    assert redacted(url) == shown


def test_a_lost_connection_is_opened_again(postgres_store_url, table1_record):
    with open_store(postgres_store_url) as store:
        first = store.add(table1_record)
        with psycopg.connect(postgres_store_url, autocommit=True) as admin:
            admin.execute("SELECT pg_terminate_backend(pid) FROM pg_stat_activity "
                          "WHERE datname = current_database() AND pid <> pg_backend_pid()")
        with pytest.raises(StoreError, match="cannot read the results store"):
            store.count()  # the call that finds the connection gone fails, and says so
        second = store.add(table1_record)  # the next opens it again
        assert {summary["id"] for summary in store.find()} == {first, second}


def test_floats_and_text_come_back_exactly(postgres_store_url, tmp_path):
    # json, not jsonb: jsonb would reorder the keys and rewrite 1e-300 as a long decimal
    record = {"zeta": 0.1, "alpha": [1e-300, 5e-324, 1.7976931348623157e308, -0.0, 12345678901234567890],
              "file": "pièce «7».ply", "holes": [], "nested": {"b": 1, "a": 2}}
    for location in (postgres_store_url, str(tmp_path / "results.sqlite")):
        with open_store(location) as store:
            answer = store.get(store.add(record))
        kept = {key: answer[key] for key in record}
        assert json.dumps(kept) == json.dumps(record)
        assert list(answer)[:len(record)] == list(record)


@pytest.mark.slow
def test_every_acknowledged_measurement_survives_a_killed_writer(postgres_store_url, panel_record, tmp_path,
                                                                 repo_root):
    acknowledged = added_until_killed(postgres_store_url, panel_record, tmp_path, repo_root)
    assert len(acknowledged) >= 20
    with open_store(postgres_store_url) as store:
        assert [id for id in acknowledged if store.get(id) is None] == []
        assert store.count() >= len(acknowledged)
        assert len(store.find(limit=None)) == store.count()
    with psycopg.connect(postgres_store_url) as connection:
        holes, measurements = connection.execute(
            "SELECT (SELECT count(*) FROM hole), (SELECT count(*) FROM measurement)").fetchone()
    assert holes == 4 * measurements  # no measurement without its holes


@pytest.mark.slow
def test_two_processes_adding_at_once_lose_nothing(postgres_store_url, table1_record, tmp_path, repo_root):
    written = concurrent_adds(postgres_store_url, table1_record, tmp_path, repo_root, processes=2, count=40)
    with open_store(postgres_store_url) as store:
        assert sorted(summary["id"] for summary in store.find(limit=None)) == sorted(written)


def test_without_psycopg_a_postgres_store_is_a_store_error(repo_root):
    import os
    import subprocess
    import sys

    code = ("import sys\n"
            "sys.modules['psycopg'] = None  # as if the extra were not installed\n"
            "from holecli.store import StoreError, open_store\n"
            "try:\n"
            "    open_store('postgresql://cell:s3cret@127.0.0.1/results')\n"
            "except StoreError as error:\n"
            "    print(error)\n")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60,
                            env=dict(os.environ, PYTHONPATH=str(repo_root)))
    assert result.stdout.startswith("postgresql://cell:***@127.0.0.1/results: a PostgreSQL store needs psycopg 3: "
                                    "pip install 'holecli[postgres]'"), result.stderr
