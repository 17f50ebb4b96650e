"""The SQLite results store: its settings, the files it refuses (and leaves alone), a killed writer,
two writers at once."""

import os
import sqlite3
import sys
from contextlib import closing

import pytest

from holecli.store import SQLiteStore, StoreError, open_store

from tests.store.durability import added_until_killed, concurrent_adds


def test_wal_synchronous_full_and_foreign_keys(tmp_path):
    with open_store(tmp_path / "results.sqlite") as store:
        assert isinstance(store, SQLiteStore) and store.location == str(tmp_path / "results.sqlite")
        pragmas = [store._select(f"PRAGMA {name}", {})[0][name] for name in ("journal_mode", "synchronous",
                                                                             "foreign_keys")]
    assert pragmas == ["wal", 2, 1]  # synchronous 2 = FULL


def test_deleting_a_measurement_deletes_its_rows(tmp_path, panel_record):
    path = tmp_path / "results.sqlite"
    with open_store(path) as store:
        id = store.add(panel_record)
    with closing(sqlite3.connect(path)) as connection:
        connection.execute("PRAGMA foreign_keys = ON")
        connection.execute("DELETE FROM measurement WHERE id = ?", (id,))
        connection.commit()
        assert connection.execute("SELECT (SELECT count(*) FROM hole), (SELECT count(*) FROM characteristic)"
                                  ).fetchone() == (0, 0)


def _foreign_database(path):
    with closing(sqlite3.connect(path)) as connection:
        connection.execute("CREATE TABLE invoices (number INTEGER, amount REAL)")
        connection.execute("INSERT INTO invoices VALUES (1, 9.5)")
        connection.commit()


def _newer_store(path):
    with open_store(path):
        pass
    with closing(sqlite3.connect(path)) as connection:
        connection.execute("UPDATE store_info SET value = '2' WHERE key = 'schema_version'")
        connection.commit()


@pytest.mark.parametrize("make, match", [
    (_foreign_database, r"not a holecli results store \(an SQLite database with other tables: invoices\)"),
    (lambda path: path.write_text("part,serial\nP7,S1\n"), r"not a holecli results store \(not an SQLite database\)"),
    (lambda path: path.write_bytes(b"\x00" * 100), "not an SQLite database"),
    (_newer_store, "schema version 2, newer than this holecli's"),
])
def test_a_file_that_is_not_a_store_is_refused_and_left_alone(tmp_path, make, match):
    path = tmp_path / "results.sqlite"
    make(path)
    before = path.read_bytes(), os.stat(path).st_mtime_ns
    with pytest.raises(StoreError, match=match) as caught:
        open_store(path)
    assert str(path) in str(caught.value) and "\n" not in str(caught.value)
    assert (path.read_bytes(), os.stat(path).st_mtime_ns) == before
    assert sorted(os.listdir(tmp_path)) == ["results.sqlite"]  # no -wal or -shm either


def test_an_empty_file_becomes_a_store(tmp_path, table1_record):
    path = tmp_path / "results.sqlite"
    path.touch()
    with open_store(path) as store:
        store.add(table1_record)
        assert store.count() == 1


@pytest.mark.parametrize("where", ["missing folder", "under a file", "a folder"])
def test_a_place_that_cannot_hold_a_store_is_refused(tmp_path, where):
    (tmp_path / "plain").write_text("x")
    (tmp_path / "folder").mkdir()
    path = {"missing folder": tmp_path / "nowhere" / "results.sqlite",
            "under a file": tmp_path / "plain" / "results.sqlite", "a folder": tmp_path / "folder"}[where]
    with pytest.raises(StoreError, match="results store|folder") as caught:
        open_store(path)
    assert str(path) in str(caught.value)
    assert sorted(os.listdir(tmp_path)) == ["folder", "plain"]


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into any folder")
def test_a_folder_without_write_permission_is_refused(tmp_path):
    folder = tmp_path / "locked"
    folder.mkdir(mode=0o500)
    try:
        with pytest.raises(StoreError, match="its folder .* cannot be written"):
            open_store(folder / "results.sqlite")
    finally:
        folder.chmod(0o700)


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into any file")
def test_a_store_file_without_write_permission_is_refused_at_once(tmp_path):
    path = tmp_path / "results.sqlite"
    with open_store(path):
        pass
    path.chmod(0o400)
    try:
        with pytest.raises(StoreError, match="the file cannot be written"):
            open_store(path)
    finally:
        path.chmod(0o600)


@pytest.mark.slow
def test_every_acknowledged_measurement_survives_a_killed_writer(tmp_path, panel_record, repo_root):
    path = str(tmp_path / "results.sqlite")
    acknowledged = added_until_killed(path, panel_record, tmp_path, repo_root)
    assert len(acknowledged) >= 20
    with closing(sqlite3.connect(path)) as connection:
        assert connection.execute("PRAGMA integrity_check").fetchone() == ("ok",)
    with open_store(path) as store:
        missing = [id for id in acknowledged if store.get(id) is None]
        assert missing == []
        assert store.count() >= len(acknowledged)
        assert store.get(acknowledged[-1])["holes"] == panel_record["holes"]


@pytest.mark.slow
def test_two_processes_adding_at_once_lose_nothing(tmp_path, table1_record, repo_root):
    path = str(tmp_path / "results.sqlite")
    with open_store(path):
        pass  # created first: both writers find the tables
    written = concurrent_adds(path, table1_record, tmp_path, repo_root, processes=2, count=60)
    with open_store(path) as store:
        assert store.count() == 120
        assert sorted(summary["id"] for summary in store.find(limit=None)) == sorted(written)
    with closing(sqlite3.connect(path)) as connection:
        assert connection.execute("SELECT count(*) FROM hole").fetchone() == (120,)
        assert connection.execute("PRAGMA integrity_check").fetchone() == ("ok",)


def test_the_store_does_not_import_psycopg(repo_root, tmp_path):
    import subprocess

    code = ("import sys, holecli.store as s\n"
            f"s.open_store({str(tmp_path / 'x.sqlite')!r}).close()\n"
            "print('psycopg' in sys.modules)")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60,
                            env=dict(os.environ, PYTHONPATH=str(repo_root)))
    assert result.stdout.strip() == "False", result.stderr
