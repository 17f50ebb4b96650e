"""What every results store does, whatever its engine: :class:`Store` and :class:`StoreError`.

An engine (:class:`holecli.store.sqlite.SQLiteStore`, :class:`holecli.store.postgres.PostgresStore`)
supplies a connection, one transaction per added measurement, and its way of writing a parameter;
the rows themselves come from :mod:`holecli.store.schema`.
"""

from __future__ import annotations

import datetime
import re
import uuid

from holecli.errors import HoleCliError
from holecli.store import schema


class StoreError(HoleCliError):
    """A results store cannot be opened, read or written; the message (one line) names the store,
    its password never shown."""


class Store:
    """A results store: measurements added one transaction each, read back by id or found by filters.

    Not thread-safe: one thread uses a store at a time. Use it as a context manager, or call
    :meth:`close`.

    Attributes
    ----------
    location : str
        The store as messages and health reports name it (a PostgreSQL password replaced by ``***``).
    """

    location: str
    engine: str  # "sqlite" or "postgres": the types and SQL of holecli.store.schema

    def add(self, record, *, id=None, received=None, processing_ms=None, meta=None, source="serve") -> str:
        """Store one measurement: its row, a row per hole, a row per checked characteristic, in one
        transaction committed (durably) before this returns.

        Parameters
        ----------
        record : dict
            A ``detect``/``batch`` record (JSON-ready), or a batch error record
            (``{"file", "path", "error", ...}``: verdict ``error``, no holes).
        id : str, optional
            The measurement's id (default: a new uuid4, 32 hex digits).
        received : str or datetime.datetime, optional
            When the request came (default: now); stored as ISO-8601 UTC with milliseconds.
        processing_ms : float, optional
            The wall time of the measurement, ms.
        meta : Mapping, optional
            ``part``, ``serial``, ``cell``, ``operator`` and any other word key, string values of at
            most 200 characters.
        source : str
            Who adds it: ``serve``, ``batch``.

        Returns
        -------
        str
            The id.

        Raises
        ------
        ValueError
            For bad metadata, a bad ``received`` or a record holding a NaN (nothing is stored).
        StoreError
            When the store cannot write it (nothing is stored), or the id is taken.
        """
        id = uuid.uuid4().hex if id is None else str(id)
        received = schema.utc_text(datetime.datetime.now(datetime.timezone.utc) if received is None else received)
        measurement = schema.measurement_row(record, id=id, received=received, processing_ms=processing_ms, meta=meta,
                                             source=source)
        self._insert(measurement, schema.hole_rows(record, id), schema.characteristic_rows(record, id))
        return id

    def get(self, id) -> dict | None:
        """The stored answer of a measurement, or None when no measurement has this id.

        Returns
        -------
        dict or None
            The record as added, plus ``id``, ``received`` (ISO-8601 UTC, ms, ``Z``),
            ``processing_ms``, ``stored`` (True) and ``meta`` (``part``, ``serial``, ``cell``,
            ``operator``, None when not given, and any other key given).
        """
        rows = self._select(f"SELECT id, {self._received_column()} AS received, processing_ms, "
                            f"{self._text_column('meta')} AS meta, {self._text_column('record')} AS record "
                            f"FROM measurement WHERE id = {self._parameter('id')}", {"id": str(id)})
        if not rows:
            return None
        row = rows[0]
        return schema.stored_answer(row["record"], id=row["id"], received=row["received"],
                                    processing_ms=row["processing_ms"], meta_text=row["meta"])

    def find(self, *, part=None, serial=None, since=None, until=None, verdict=None, limit=100) -> list:
        """The measurements that match every filter given, newest first.

        Parameters
        ----------
        part, serial : str, optional
            Equal to the metadata's.
        since : str, optional
            Received at or after this ISO-8601 date or date-time (UTC without an offset).
        until : str, optional
            Received at or before it (a date: up to the end of that day).
        verdict : {"pass", "fail", "undecided", "unchecked", "error"}, optional
        limit : int or None
            At most this many (None: all).

        Returns
        -------
        list of dict
            Summaries ``{"id", "received", "file", "part", "serial", "cell", "operator", "spec",
            "verdict", "holes", "processing_ms"}``; measurements received in the same millisecond
            in no set order among themselves.

        Raises
        ------
        ValueError
            For an unknown verdict, a date that is not ISO-8601 or a limit that is not a positive int.
        """
        conditions, parameters = self._filters(part=part, serial=serial, since=since, until=until,
                                               verdict=verdict)
        if limit is not None and (isinstance(limit, bool) or not isinstance(limit, int) or limit < 1):
            raise ValueError(f"limit must be a positive integer or None, got {limit!r}")
        columns = ", ".join(f"{self._received_column()} AS received" if key == "received" else key
                            for key in schema.SUMMARY_KEYS)
        sql = (f"SELECT {columns} FROM measurement" + (" WHERE " + " AND ".join(conditions) if conditions else "")
               + " ORDER BY measurement.received DESC, id DESC" + ("" if limit is None else f" LIMIT {int(limit)}"))
        return [schema.summary(row) for row in self._select(sql, parameters)]

    def answers(self, *, part=None, serial=None, since=None, until=None, verdict=None) -> list:
        """The stored answers (as :meth:`get` gives them) of every measurement that matches the
        filters (those of :meth:`find`), oldest first: the measurement order of a lot's reports.

        Returns
        -------
        list of dict
            In ``received`` order, then by id among those received in the same millisecond.

        Raises
        ------
        ValueError
            As :meth:`find`.
        """
        conditions, parameters = self._filters(part=part, serial=serial, since=since, until=until, verdict=verdict)
        sql = (f"SELECT id, {self._received_column()} AS received, processing_ms, "
               f"{self._text_column('meta')} AS meta, {self._text_column('record')} AS record FROM measurement"
               + (" WHERE " + " AND ".join(conditions) if conditions else "")
               + " ORDER BY measurement.received, id")
        return [schema.stored_answer(row["record"], id=row["id"], received=row["received"],
                                     processing_ms=row["processing_ms"], meta_text=row["meta"])
                for row in self._select(sql, parameters)]

    def _filters(self, *, part, serial, since, until, verdict):
        """The WHERE conditions and parameters of :meth:`find`'s filters."""
        conditions, parameters = [], {}
        for name, value in (("part", part), ("serial", serial)):
            if value is not None:
                conditions.append(f"{name} = {self._parameter(name)}")
                parameters[name] = str(value)
        if since is not None:
            conditions.append(f"received >= {self._parameter('since', 'timestamp')}")
            parameters["since"] = schema.utc_text(since)
        if until is not None:
            conditions.append(f"received < {self._parameter('until', 'timestamp')}")
            parameters["until"] = schema.until_bound(until)
        if verdict is not None:
            if verdict not in schema.VERDICTS:
                raise ValueError(f"verdict must be one of {', '.join(schema.VERDICTS)}, got {verdict!r}")
            conditions.append(f"verdict = {self._parameter('verdict')}")
            parameters["verdict"] = verdict
        return conditions, parameters

    def count(self) -> int:
        """The number of measurements stored."""
        return self._select("SELECT count(*) AS n FROM measurement", {})[0]["n"]

    def close(self):
        """Close the connection (again: nothing)."""
        raise NotImplementedError

    def __enter__(self):
        return self

    def __exit__(self, *exc_info):
        self.close()
        return False

    def __repr__(self):
        return f"{type(self).__name__}({self.location!r})"

    # What an engine supplies.
    def _insert(self, measurement, holes, characteristics):
        """Insert the rows in one transaction, committed before returning; StoreError on failure."""
        raise NotImplementedError

    def _select(self, sql, parameters) -> list:
        """The rows of a query, as dicts; StoreError on failure."""
        raise NotImplementedError

    def _parameter(self, name, kind="text") -> str:
        """How the SQL names the parameter ``name`` (of the schema kind ``kind``)."""
        raise NotImplementedError

    def _received_column(self) -> str:
        """The SQL expression of ``measurement.received`` as :func:`holecli.store.schema.utc_text` writes it."""
        raise NotImplementedError

    def _text_column(self, name) -> str:
        """The SQL expression of a JSON column as its text."""
        return name


def is_a_store(location, tables, version, what) -> bool:
    """Whether a database holds a results store (True), or nothing yet (False: create the tables).

    Parameters
    ----------
    location : str
        What the messages call the store.
    tables : set of str
        The tables the database holds.
    version : str or None
        Its ``store_info`` schema version, None when it has none.
    what : str
        What the messages call a database of the engine ("an SQLite database", "a database").

    Raises
    ------
    StoreError
        A database with other tables (not a store); a store of a newer schema (:func:`check_version`).
    """
    if tables and version is None:
        shown = ", ".join(sorted(tables)[:5]) + (", ..." if len(tables) > 5 else "")
        raise StoreError(f"{location}: not a holecli results store ({what} with other tables: {shown}); "
                         f"it was left as it is")
    if version is not None:
        check_version(location, version)
        return True
    return False


def check_version(location, version):
    """Refuse a store whose schema version is newer than :data:`holecli.store.schema.SCHEMA_VERSION`
    (or not a version at all).

    Raises
    ------
    StoreError
    """
    try:
        number = int(version)
    except (TypeError, ValueError):
        raise StoreError(f"{location}: not a holecli results store (schema_version {version!r}); "
                         f"it was left as it is") from None
    if number > schema.SCHEMA_VERSION:
        raise StoreError(f"{location}: the results store has schema version {number}, newer than this holecli's "
                         f"({schema.SCHEMA_VERSION}): use a newer holecli; the store was left as it is")


def redacted(url) -> str:
    """``url`` with its password (in the user part or a ``password=`` parameter) shown as ``***``.

    Examples
    --------
    >>> redacted("postgresql://cell:s3cret@db.local:5432/results?sslmode=require&password=x")
    'postgresql://cell:***@db.local:5432/results?sslmode=require&password=***'
    """
    url = re.sub(r"(://[^:/@?#]*:)[^@/?#]*@", r"\1***@", url)
    return re.sub(r"(?i)([?&]password=)[^&#]*", r"\1***", url)
