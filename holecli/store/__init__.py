"""The results store: every measurement in a database, one schema for SQLite and PostgreSQL.

:func:`open_store` opens one by its location (a file path: SQLite; ``postgresql://...``:
PostgreSQL through psycopg 3). :meth:`Store.add` writes a record (a measurement row, a row per hole,
a row per checked characteristic) in one transaction committed before it returns; :meth:`Store.get`
gives it back exactly as added, :meth:`Store.find` finds measurements by part, serial, time and
verdict. The tables are :mod:`holecli.store.schema`'s, so statistical process control is plain SQL::

    SELECT m.received, h.diameter FROM hole h JOIN measurement m ON m.id = h.measurement_id
    WHERE m.part = 'P7' AND h.name = 'T1' ORDER BY m.received

Examples
--------
>>> import os, tempfile
>>> with tempfile.TemporaryDirectory() as folder, open_store(os.path.join(folder, "results.sqlite")) as store:
...     id = store.add({"file": "a.ply", "holes": []}, meta={"part": "P7"})
...     print([summary["verdict"] for summary in store.find(part="P7")], store.count())
['unchecked'] 1
"""

from __future__ import annotations

import os

from holecli.store.base import Store, StoreError, redacted
from holecli.store.sqlite import SQLiteStore

POSTGRES_SCHEMES = ("postgresql://", "postgres://")
"""How a location names a PostgreSQL database."""

__all__ = ["POSTGRES_SCHEMES", "SQLiteStore", "Store", "StoreError", "open_store"]


def open_store(location, *, create=True) -> Store:
    """Open (creating when needed) the results store at ``location``.

    Parameters
    ----------
    location : str or os.PathLike
        ``postgresql://...`` or ``postgres://...`` (a libpq URL): a PostgreSQL database, whose
        tables are created when missing; anything else: an SQLite file, created with its folder's
        permissions when missing.
    create : bool
        Create the store (the SQLite file, the tables) when there is none; False for a reader (``holecli
        report``), which is refused a location that holds no store and changes nothing there.

    Returns
    -------
    Store
        :class:`SQLiteStore` or :class:`holecli.store.postgres.PostgresStore`.

    Raises
    ------
    StoreError
        When the store cannot be opened or created, or what is there is not a holecli store (another
        database, a file that is not SQLite, a newer schema version): it is then left as it is.
    """
    text = os.fspath(location)
    if isinstance(text, str) and text.lower().startswith(POSTGRES_SCHEMES):
        # psycopg is imported only for a PostgreSQL store (an optional extra, and 150 ms)
        try:
            from holecli.store.postgres import PostgresStore
        except ImportError as error:
            raise StoreError(f"{redacted(text)}: a PostgreSQL store needs psycopg 3: pip install 'holecli[postgres]' "
                             f"({error})") from None
        return PostgresStore(text, create=create)
    return SQLiteStore(text, create=create)
