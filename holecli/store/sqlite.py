"""The results store in an SQLite file (the standard library's :mod:`sqlite3`).

The file is in WAL mode with ``synchronous=FULL``: a measurement that :meth:`SQLiteStore.add` has
returned survives a killed process and a power loss; readers never wait for the writer. Each add is
one ``BEGIN IMMEDIATE ... COMMIT``; another process adding to the same file waits for it (up to
:data:`BUSY_TIMEOUT_S`) instead of failing.
"""

from __future__ import annotations

import os
import sqlite3

from holecli.store import schema
from holecli.store.base import Store, StoreError, is_a_store

BUSY_TIMEOUT_S = 30.0
"""How long an add waits for another writer of the same file, seconds."""

_HEADER = b"SQLite format 3\x00"


class SQLiteStore(Store):
    """A results store in an SQLite file, created (with its folder's permissions) when missing.

    Parameters
    ----------
    path : str or os.PathLike
        The file. An existing file must be a holecli store of this schema version or an older one,
        or an empty file or database; anything else is refused and left as it is.
    create : bool
        Create the file and the tables when missing (False: refuse a missing file or an empty database).

    Raises
    ------
    StoreError
        When the file is not a holecli store (another database, not SQLite at all, a newer schema),
        or cannot be created, opened or written.
    """

    engine = "sqlite"

    def __init__(self, path, *, create=True):
        self.path = os.fspath(path)
        self.location = str(self.path)
        self._connection = None
        self._may_create = create
        existed = os.path.lexists(self.path)
        if not existed and not create:
            raise StoreError(f"{self.location}: no such results store")
        if existed:
            self._check_header()
        self._check_writable(existed)
        try:
            self._connection = sqlite3.connect(self.path, timeout=BUSY_TIMEOUT_S, isolation_level=None,
                                               check_same_thread=False)
            self._connection.row_factory = sqlite3.Row
            self._open(existed)
        except sqlite3.Error as error:
            self.close()
            if not existed and os.path.exists(self.path) and os.path.getsize(self.path) == 0:
                os.unlink(self.path)  # the empty file the failed open left
            raise StoreError(f"{self.location}: cannot open the results store: {_reason(error)}") from None
        except StoreError:
            self.close()
            raise

    def _check_header(self):
        """Refuse, before SQLite touches it, a file that is not an SQLite database (or empty)."""
        if os.path.isdir(self.path):
            raise StoreError(f"{self.location}: is a folder, not a results store file")
        try:
            with open(self.path, "rb") as file:
                head = file.read(len(_HEADER))
        except OSError as error:
            raise StoreError(f"{self.location}: cannot open the results store: {error.strerror or error}") from None
        if head and head != _HEADER:
            raise StoreError(f"{self.location}: not a holecli results store (not an SQLite database); "
                             f"it was left as it is")

    def _check_writable(self, existed):
        """Refuse a store file, or a folder, this process cannot write (SQLite writes its WAL beside it):
        said now, not at the first add."""
        folder = os.path.dirname(os.path.abspath(self.path))
        if existed and not os.access(self.path, os.W_OK):
            raise StoreError(f"{self.location}: cannot open the results store: the file cannot be written "
                             f"(permission denied)")
        if os.path.isdir(folder) and not os.access(folder, os.W_OK | os.X_OK):
            raise StoreError(f"{self.location}: cannot open the results store: its folder {folder} cannot be written "
                             f"(permission denied)")

    def _open(self, existed):
        """Check an existing database is a store of ours, then set the pragmas and create the tables."""
        connection = self._connection
        connection.execute(f"PRAGMA busy_timeout = {int(BUSY_TIMEOUT_S * 1000)}")
        tables = {row[0] for row in connection.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}
        version = None
        if "store_info" in tables:
            found = connection.execute("SELECT value FROM store_info WHERE key = 'schema_version'").fetchone()
            version = None if found is None else found[0]
        existing = is_a_store(self.location, tables, version, "an SQLite database")
        if not existing and not self._may_create:
            raise StoreError(f"{self.location}: not a holecli results store (an empty SQLite database)")
        connection.execute("PRAGMA foreign_keys = ON")
        mode = connection.execute("PRAGMA journal_mode = WAL").fetchone()[0]
        if str(mode).lower() != "wal":
            raise StoreError(f"{self.location}: the file system does not allow SQLite's WAL mode (journal mode {mode})")
        connection.execute("PRAGMA synchronous = FULL")
        if not existing:
            self._create()

    def _create(self):
        """The tables, indexes and ``store_info`` rows, in one transaction."""
        connection = self._connection
        connection.execute("BEGIN IMMEDIATE")
        try:
            for statement in schema.ddl("sqlite"):
                connection.execute(statement)
            connection.executemany("INSERT OR IGNORE INTO store_info (key, value) VALUES (?, ?)",
                                   schema.store_info_rows())
            connection.execute("COMMIT")
        except BaseException:
            connection.execute("ROLLBACK")
            raise

    def _insert(self, measurement, holes, characteristics):
        connection = self._connection
        if connection is None:
            raise StoreError(f"{self.location}: the results store is closed")
        try:
            connection.execute("BEGIN IMMEDIATE")
            try:
                connection.execute(schema.insert_sql("measurement", "sqlite"), measurement)
                connection.executemany(schema.insert_sql("hole", "sqlite"), holes)
                connection.executemany(schema.insert_sql("characteristic", "sqlite"), characteristics)
                connection.execute("COMMIT")
            except BaseException:
                if connection.in_transaction:
                    connection.execute("ROLLBACK")
                raise
        except sqlite3.IntegrityError as error:
            raise StoreError(f"{self.location}: cannot add measurement {measurement['id']}: {_reason(error)}") from None
        except sqlite3.Error as error:
            raise StoreError(f"{self.location}: cannot add the measurement: {_reason(error)}") from None

    def _select(self, sql, parameters):
        if self._connection is None:
            raise StoreError(f"{self.location}: the results store is closed")
        try:
            return [dict(row) for row in self._connection.execute(sql, parameters)]
        except sqlite3.Error as error:
            raise StoreError(f"{self.location}: cannot read the results store: {_reason(error)}") from None

    def _parameter(self, name, kind="text"):
        return f":{name}"

    def _received_column(self):
        return "received"  # stored as schema.utc_text writes it

    def close(self):
        """Close the connection (again: nothing)."""
        if self._connection is not None:
            self._connection.close()
            self._connection = None


def _reason(error):
    """An sqlite3 error as one line."""
    return " ".join(str(error).split()) or type(error).__name__
