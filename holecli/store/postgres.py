"""The results store in a PostgreSQL database (psycopg 3, the extra ``postgres``).

The tables are :mod:`holecli.store.schema`'s, created in the connection's current schema when the
database has none of its own (a database with other tables is refused: give the store a database
of its own, or a schema with ``?options=-csearch_path%3Dholecli``). Each add is one transaction; it
returns after PostgreSQL's COMMIT (``synchronous_commit`` as the server has it: on by default, the
commit is on disk). A connection lost (a restarted server) is opened again at the next call.
"""

from __future__ import annotations


import psycopg
from psycopg.conninfo import conninfo_to_dict
from psycopg.rows import dict_row

from holecli.store import schema
from holecli.store.base import Store, StoreError, is_a_store, redacted

CONNECT_TIMEOUT_S = 10
"""How long opening a connection may take, seconds."""

# The store's tables are created under this lock, so that two processes opening a new database at
# once do not both create them (PostgreSQL's CREATE TABLE IF NOT EXISTS is not safe against that).
_CREATE_LOCK = 0x686F6C65  # "hole"


class PostgresStore(Store):
    """A results store in a PostgreSQL database.

    Parameters
    ----------
    url : str
        ``postgresql://user[:password]@host[:port]/database[?...]`` (libpq's URL).
    create : bool
        Create the tables when the database has none (False: refuse it).

    Raises
    ------
    StoreError
        When the server cannot be reached, the database holds other tables or a newer schema, or
        the tables cannot be created.
    """

    engine = "postgres"

    def __init__(self, url, *, create=True):
        self._url = url
        self.location = redacted(url)
        self._connection = None
        self._may_create = create
        try:
            self._connection = self._connect()
            self._open()
        except psycopg.Error as error:
            self.close()
            raise StoreError(f"{self.location}: cannot open the results store: {self._reason(error)}") from None
        except StoreError:
            self.close()
            raise

    def _connect(self):
        return psycopg.connect(self._url, autocommit=True, row_factory=dict_row, connect_timeout=CONNECT_TIMEOUT_S)

    def _open(self):
        """Check the database holds a store of ours or nothing, then create the tables when missing."""
        connection = self._connection
        tables = {row["table_name"] for row in connection.execute(
            "SELECT table_name FROM information_schema.tables WHERE table_schema = current_schema()")}
        version = None
        if "store_info" in tables:
            found = connection.execute("SELECT value FROM store_info WHERE key = 'schema_version'").fetchone()
            version = None if found is None else found["value"]
        if is_a_store(self.location, tables, version, "a database"):
            return
        if not self._may_create:
            raise StoreError(f"{self.location}: not a holecli results store (the database holds no tables of one)")
        with connection.transaction():
            connection.execute("SELECT pg_advisory_xact_lock(%s)", (_CREATE_LOCK,))
            for statement in schema.ddl("postgres"):
                connection.execute(statement)
            with connection.cursor() as cursor:
                cursor.executemany("INSERT INTO store_info (key, value) VALUES (%s, %s) ON CONFLICT (key) DO NOTHING",
                                   schema.store_info_rows())

    def _connected(self):
        """The connection, opened again when the server dropped it."""
        if self._connection is None:
            raise StoreError(f"{self.location}: the results store is closed")
        if self._connection.broken or self._connection.closed:
            self._connection.close()
            self._connection = self._connect()
        return self._connection

    def _insert(self, measurement, holes, characteristics):
        try:
            connection = self._connected()
            with connection.transaction(), connection.cursor() as cursor:
                cursor.execute(schema.insert_sql("measurement", "postgres"), measurement)
                cursor.executemany(schema.insert_sql("hole", "postgres"), holes)
                cursor.executemany(schema.insert_sql("characteristic", "postgres"), characteristics)
        except psycopg.errors.UniqueViolation as error:
            raise StoreError(f"{self.location}: cannot add measurement {measurement['id']}: "
                             f"{self._reason(error)}") from None
        except psycopg.Error as error:
            raise StoreError(f"{self.location}: cannot add the measurement: {self._reason(error)}") from None

    def _select(self, sql, parameters):
        try:
            return self._connected().execute(sql, parameters).fetchall()
        except psycopg.Error as error:
            raise StoreError(f"{self.location}: cannot read the results store: {self._reason(error)}") from None

    def _parameter(self, name, kind="text"):
        return f"%({name})s" + ("::timestamptz" if kind == "timestamp" else "")

    def _received_column(self):
        return "to_char(received AT TIME ZONE 'UTC', 'YYYY-MM-DD\"T\"HH24:MI:SS.MS\"Z\"')"

    def _text_column(self, name):
        return f"{name}::text"

    def _reason(self, error):
        """A psycopg error as one line, without the password."""
        text = " ".join(str(error).split()) or type(error).__name__
        try:
            password = conninfo_to_dict(self._url).get("password")
        except psycopg.Error:
            password = None
        return text.replace(password, "***") if password else text

    def close(self):
        """Close the connection (again: nothing)."""
        if self._connection is not None:
            self._connection.close()
            self._connection = None
