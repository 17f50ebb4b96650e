"""The results store's schema, one for SQLite and PostgreSQL, and the rows of a record (pure functions).

Three tables hold a measurement: ``measurement`` (one row: who, when, what file, the verdict, the
options and the whole record as JSON), ``hole`` (a row per hole found: center, diameter, normal, the
features and their uncertainty) and ``characteristic`` (a row per checked characteristic of a hole:
its value against its limits and the decision). ``store_info`` says which schema the store has.
Statistical process control is then plain SQL over ``hole`` and ``characteristic`` joined to
``measurement``.

The row builders (:func:`measurement_row`, :func:`hole_rows`, :func:`characteristic_rows`,
:func:`verdict_word`) turn a record (:func:`holecli.measure_scan`'s, or a batch error record) into
the values of these rows; the engines (:mod:`holecli.store.sqlite`, :mod:`holecli.store.postgres`)
only write them.
"""

from __future__ import annotations

import datetime
import json
import re

from holecli import __version__

SCHEMA_VERSION = 1
"""The version of the tables below; a store with a newer one is refused."""

VERDICTS = ("pass", "fail", "undecided", "unchecked", "error")
"""The verdict words of a measurement (:func:`verdict_word`)."""

META_COLUMNS = ("part", "serial", "cell", "operator")
"""The metadata keys that have columns of their own (any other key is kept in ``meta`` only)."""

META_VALUE_MAX = 200

META_KEYS_MAX = 20
"""The most metadata keys a measurement may have."""
"""The longest metadata value, in characters."""

# Each column: (name, kind, constraint). The kinds are mapped to each engine's types by TYPES.
MEASUREMENT_COLUMNS = (
    ("id", "text", "PRIMARY KEY"),             # uuid4 hex (or the id the caller gave)
    ("received", "timestamp", "NOT NULL"),     # when the request came, UTC
    ("source", "text", "NOT NULL"),            # "serve", "batch", ...
    ("file", "text", ""),                      # the scan as named in the request/record
    ("path", "text", ""),                      # its resolved path (batch), else NULL
    ("part", "text", ""),
    ("serial", "text", ""),
    ("cell", "text", ""),
    ("operator", "text", ""),
    ("meta", "json", "NOT NULL"),              # every metadata key given, as a JSON object
    ("spec", "text", ""),                      # the spec file the holes were checked against
    ("spec_sha256", "text", ""),               # the SHA-256 of that file
    ("verdict", "text", "NOT NULL"),           # pass, fail, undecided, unchecked, error
    ("holes", "integer", ""),                  # holes found (NULL for an error record)
    ("processing_ms", "real", ""),             # wall time of the measurement, ms
    ("points", "bigint", ""),                  # points of the scan
    ("units", "text", ""),                     # the unit of the lengths (NULL: the file's, undeclared)
    ("options", "json", ""),                   # the record's detection options, JSON
    ("holecli_version", "text", ""),
    ("schema_version", "text", ""),            # the record's schema version (not the store's)
    ("error", "text", ""),                     # why the file could not be measured
    ("record", "json", "NOT NULL"),            # the whole record, JSON, exactly as added
)

HOLE_COLUMNS = (
    ("measurement_id", "text", "NOT NULL REFERENCES measurement (id) ON DELETE CASCADE"),
    ("idx", "integer", "NOT NULL"),            # the hole's place in the record's holes, from 0
    ("name", "text", ""),                      # the spec's name of the hole, if checked
    ("x", "real", ""), ("y", "real", ""), ("z", "real", ""),          # center, record's unit
    ("diameter", "real", ""),                  # record's unit
    ("nx", "real", ""), ("ny", "real", ""), ("nz", "real", ""),       # unit normal
    ("type", "text", ""),                      # through, blind, countersunk, counterbored, ...
    ("countersink_diameter", "real", ""),
    ("countersink_angle", "real", ""),         # degrees (included angle)
    ("countersink_depth", "real", ""),
    ("bore_diameter", "real", ""),
    ("perpendicularity_deg", "real", ""),
    ("u_diameter", "real", ""),                # standard uncertainty of the diameter
    ("in_tolerance", "smallint", ""),          # 1, 0, NULL (not checked)
    ("warnings", "json", "NOT NULL"),          # JSON list of warning codes
)
HOLE_KEY = ("measurement_id", "idx")

CHARACTERISTIC_COLUMNS = (
    ("measurement_id", "text", "NOT NULL REFERENCES measurement (id) ON DELETE CASCADE"),
    ("hole_idx", "integer", "NOT NULL"),
    ("name", "text", "NOT NULL"),              # the conformance key: diameter, position, ...
    ("value", "real", ""),                     # the deviation (or value) checked
    ("lower", "real", ""),                     # its limits (NULL: none on that side)
    ("upper", "real", ""),
    ("expanded_uncertainty", "real", ""),      # U = k u
    ("decision", "text", ""),                  # pass, fail, undecided, not_measured
    ("reason", "text", ""),
)
CHARACTERISTIC_KEY = ("measurement_id", "hole_idx", "name")

STORE_INFO_COLUMNS = (("key", "text", "PRIMARY KEY"), ("value", "text", "NOT NULL"))

TABLES = {"store_info": STORE_INFO_COLUMNS, "measurement": MEASUREMENT_COLUMNS, "hole": HOLE_COLUMNS,
          "characteristic": CHARACTERISTIC_COLUMNS}
KEYS = {"hole": HOLE_KEY, "characteristic": CHARACTERISTIC_KEY}
INDEXES = (("measurement_part_serial", "measurement", ("part", "serial")),
           ("measurement_received", "measurement", ("received",)),
           ("measurement_verdict", "measurement", ("verdict",)))

# The types of each engine. The JSON columns are ``json`` on PostgreSQL, not ``jsonb``: jsonb
# reorders an object's keys, and a stored record must come back exactly as it was added.
TYPES = {
    "sqlite": {"text": "TEXT", "timestamp": "TEXT", "json": "TEXT", "real": "REAL", "integer": "INTEGER",
               "bigint": "INTEGER", "smallint": "INTEGER"},
    "postgres": {"text": "text", "timestamp": "timestamptz", "json": "json", "real": "double precision",
                 "integer": "integer", "bigint": "bigint", "smallint": "smallint"},
}


def store_info_rows() -> list:
    """The ``store_info`` rows of a store created now: ``(key, value)`` for ``schema_version``,
    ``created`` (:func:`utc_text` of now) and ``holecli_version``."""
    return [("schema_version", str(SCHEMA_VERSION)),
            ("created", utc_text(datetime.datetime.now(datetime.timezone.utc))),
            ("holecli_version", __version__)]


def ddl(engine) -> list:
    """The statements that create the tables and indexes (each ``IF NOT EXISTS``).

    Parameters
    ----------
    engine : {"sqlite", "postgres"}

    Returns
    -------
    list of str
    """
    types = TYPES[engine]
    statements = []
    for table, columns in TABLES.items():
        lines = [f"{name} {types[kind]} {constraint}".rstrip() for name, kind, constraint in columns]
        if table in KEYS:
            lines.append(f"PRIMARY KEY ({', '.join(KEYS[table])})")
        statements.append(f"CREATE TABLE IF NOT EXISTS {table} (\n    " + ",\n    ".join(lines) + "\n)")
    for name, table, columns in INDEXES:
        statements.append(f"CREATE INDEX IF NOT EXISTS {name} ON {table} ({', '.join(columns)})")
    return statements


def insert_sql(table, engine) -> str:
    """The INSERT of one row of ``table`` with named parameters (``:name`` for SQLite, ``%(name)s``
    for psycopg; on PostgreSQL the JSON and timestamp values, given as text, are cast).

    Parameters
    ----------
    table : str
        One of :data:`TABLES`.
    engine : {"sqlite", "postgres"}

    Returns
    -------
    str
    """
    columns = TABLES[table]
    if engine == "sqlite":
        values = [f":{name}" for name, _, _ in columns]
    else:
        casts = {"json": "::json", "timestamp": "::timestamptz"}
        values = [f"%({name})s{casts.get(kind, '')}" for name, kind, _ in columns]
    return f"INSERT INTO {table} ({', '.join(name for name, _, _ in columns)}) VALUES ({', '.join(values)})"


def verdict_word(record) -> str:
    """The verdict of a record in one word.

    Parameters
    ----------
    record : dict
        A ``detect``/``batch`` record or a batch error record.

    Returns
    -------
    {"error", "unchecked", "pass", "fail", "undecided"}
        ``error`` when the record has ``error``; ``unchecked`` without ``verdict`` (no tolerances);
        ``pass`` when ``verdict.in_tolerance`` is true; ``fail`` when a check is out of tolerance or
        a nominal hole is missing; else ``undecided``.

    Examples
    --------
    >>> verdict_word({"file": "a.ply", "error": "a.ply: no points"})
    'error'
    >>> verdict_word({"holes": [], "verdict": {"in_tolerance": False, "out_of_tolerance": 0, "missing": ["A"]}})
    'fail'
    """
    if "error" in record:
        return "error"
    verdict = record.get("verdict")
    if verdict is None:
        return "unchecked"
    if verdict.get("in_tolerance"):
        return "pass"
    if verdict.get("out_of_tolerance") or verdict.get("missing"):
        return "fail"
    return "undecided"


def hole_verdict_word(hole) -> str:
    """The verdict of one hole of a record in one word (as the line protocol and OPC UA give it).

    Parameters
    ----------
    hole : dict
        A hole of a ``detect`` record.

    Returns
    -------
    {"unchecked", "pass", "fail", "undecided"}
        ``unchecked`` when the hole was not checked (no tolerances, or none applies to it:
        ``in_tolerance`` absent or null); ``pass`` when in tolerance; ``undecided`` when the checks
        that did not pass are only undecided (a value within the measurement's uncertainty of a
        limit); else ``fail``.

    Examples
    --------
    >>> hole_verdict_word({"in_tolerance": False, "failed_checks": [], "undecided_checks": ["diameter"]})
    'undecided'
    """
    checked = hole.get("in_tolerance")
    if checked is None:
        return "unchecked"
    if checked:
        return "pass"
    if not hole.get("failed_checks") and hole.get("undecided_checks"):
        return "undecided"
    return "fail"


def record_json(record) -> str:
    """The JSON text a record is stored as: compact, ASCII (a file name that is not UTF-8 keeps its
    escaped bytes), no NaN. ``json.loads`` of it gives the record back, floats exactly.

    Raises
    ------
    ValueError
        When the record holds a NaN or an infinity (JSON has neither).
    """
    return json.dumps(record, separators=(",", ":"), allow_nan=False)


def check_meta(meta) -> dict:
    """The metadata of a measurement, checked: every key of :data:`META_COLUMNS` (None when not
    given) and the others given.

    Parameters
    ----------
    meta : Mapping or None
        At most :data:`META_KEYS_MAX` keys, each a word of at most 40 characters (letters, digits,
        ``_``, not starting with a digit); values one line of text (no control character) of at most
        :data:`META_VALUE_MAX` characters, or None.

    Returns
    -------
    dict

    Raises
    ------
    ValueError
        For a key that is not a word or a value that is not such a string.
    """
    checked = dict.fromkeys(META_COLUMNS)
    if len(meta or {}) > META_KEYS_MAX:
        raise ValueError(f"meta: more than {META_KEYS_MAX} keys ({len(meta)})")
    for key, value in (meta or {}).items():
        if not isinstance(key, str) or not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]{0,39}", key):
            raise ValueError(f"meta key {str(key)[:40]!r} is not a word (letters, digits, _; at most 40)")
        if value is not None and not isinstance(value, str):
            raise ValueError(f"meta {key}: a string is expected, got {type(value).__name__}")
        if value is not None and len(value) > META_VALUE_MAX:
            raise ValueError(f"meta {key}: longer than {META_VALUE_MAX} characters ({len(value)})")
        if value is not None and any(ord(character) < 32 or ord(character) == 127 for character in value):
            raise ValueError(f"meta {key}: a control character (a line break, ...) in it")
        checked[key] = value
    return checked


def utc_text(moment) -> str:
    """A moment as the store writes it: ISO-8601 UTC with milliseconds and ``Z``.

    Parameters
    ----------
    moment : datetime.datetime or str
        An aware datetime, a naive one (taken as UTC), or an ISO-8601 string (a date is its midnight;
        without an offset, UTC).

    Returns
    -------
    str
        ``YYYY-MM-DDTHH:MM:SS.mmmZ``.

    Raises
    ------
    ValueError
        For a string that is not ISO-8601.

    Examples
    --------
    >>> utc_text("2026-12-03T10:00:00.1234+01:00")
    '2026-12-03T09:00:00.123Z'
    >>> utc_text("2026-12-03")
    '2026-12-03T00:00:00.000Z'
    """
    if isinstance(moment, str):
        moment = parse_moment(moment)
    if moment.tzinfo is None:
        moment = moment.replace(tzinfo=datetime.timezone.utc)
    moment = moment.astimezone(datetime.timezone.utc)
    return moment.strftime("%Y-%m-%dT%H:%M:%S.") + f"{moment.microsecond // 1000:03d}Z"


def parse_moment(text) -> datetime.datetime:
    """An ISO-8601 date or date-time string as an aware datetime (UTC when it has no offset).

    Raises
    ------
    ValueError
        When ``text`` is neither.
    """
    if not isinstance(text, str):
        raise ValueError(f"an ISO-8601 date or date-time is expected, got {text!r}")
    try:
        moment = datetime.datetime.fromisoformat(text.strip().replace("Z", "+00:00").replace("z", "+00:00"))
    except ValueError:
        raise ValueError(f"not an ISO-8601 date or date-time: {text!r}") from None
    if moment.tzinfo is None:
        moment = moment.replace(tzinfo=datetime.timezone.utc)
    return moment


def until_bound(text) -> str:
    """The exclusive upper bound of ``until``: the end of the day for a date (``2026-12-03`` takes
    the whole 3rd), else the moment itself plus a millisecond (the stored precision), so that a
    measurement received at ``until`` is included.

    Examples
    --------
    >>> until_bound("2026-12-03")
    '2026-12-04T00:00:00.000Z'
    >>> until_bound("2026-12-03T10:00:00Z")
    '2026-12-03T10:00:00.001Z'
    """
    if isinstance(text, str) and re.fullmatch(r"\s*\d{4}-\d\d-\d\d\s*", text):
        return utc_text(parse_moment(text) + datetime.timedelta(days=1))
    moment = parse_moment(utc_text(text))  # truncated to the stored milliseconds
    return utc_text(moment + datetime.timedelta(milliseconds=1))


def _text(value):
    """A string for a TEXT column: a file name that is not UTF-8 (surrogate escapes) gets U+FFFD for
    its bad bytes (the record's JSON keeps them exactly)."""
    if value is None:
        return None
    value = str(value)
    return value.encode("utf-8", "surrogateescape").decode("utf-8", "replace")


def _number(value):
    """A float column's value: None stays None; anything else a float."""
    return None if value is None else float(value)


def measurement_row(record, *, id, received, processing_ms=None, meta=None, source="serve") -> dict:
    """The ``measurement`` row of a record.

    Parameters
    ----------
    record : dict
        A ``detect``/``batch`` record or a batch error record.
    id : str
        The measurement's id.
    received : str
        When it came, as :func:`utc_text` writes it.
    processing_ms : float, optional
    meta : Mapping, optional
        Checked by :func:`check_meta`.
    source : str
        Who added it (``serve``, ``batch``).

    Returns
    -------
    dict
        ``{column: value}`` in the order of :data:`MEASUREMENT_COLUMNS`; JSON columns as JSON text.

    Raises
    ------
    ValueError
        For bad metadata or a record holding a NaN.
    """
    meta = check_meta(meta)
    options = record.get("options")
    tolerances = (options or {}).get("tolerances") or {}
    holes = record.get("holes")
    row = {
        "id": id, "received": received, "source": source,
        "file": _text(record.get("file")), "path": _text(record.get("path")),
        **{key: meta[key] for key in META_COLUMNS},
        "meta": json.dumps(meta, separators=(",", ":")),
        "spec": _text(tolerances.get("spec_file")), "spec_sha256": tolerances.get("spec_sha256"),
        "verdict": verdict_word(record),
        "holes": None if "error" in record or holes is None else len(holes),
        "processing_ms": _number(processing_ms),
        "points": record.get("points"),
        "units": record.get("units"),
        "options": None if options is None else json.dumps(options, separators=(",", ":"), allow_nan=False),
        "holecli_version": record.get("holecli_version"),
        "schema_version": record.get("schema_version"),
        "error": _text(record.get("error")),
        "record": record_json(record),
    }
    return {name: row[name] for name, _, _ in MEASUREMENT_COLUMNS}


def hole_rows(record, measurement_id) -> list:
    """The ``hole`` rows of a record: one per hole, in the record's order (none for an error record).

    Parameters
    ----------
    record : dict
    measurement_id : str

    Returns
    -------
    list of dict
        ``{column: value}`` in the order of :data:`HOLE_COLUMNS`.
    """
    rows = []
    for idx, hole in enumerate(record.get("holes") or ()):
        center = hole.get("center") or (None, None, None)
        normal = hole.get("normal") or (None, None, None)
        countersink = hole.get("countersink") or {}
        in_tolerance = hole.get("in_tolerance")
        rows.append({
            "measurement_id": measurement_id, "idx": idx, "name": hole.get("name"),
            "x": _number(center[0]), "y": _number(center[1]), "z": _number(center[2]),
            "diameter": _number(hole.get("diameter")),
            "nx": _number(normal[0]), "ny": _number(normal[1]), "nz": _number(normal[2]),
            "type": hole.get("type"),
            "countersink_diameter": _number(countersink.get("diameter")),
            "countersink_angle": _number(countersink.get("angle_deg")),
            "countersink_depth": _number(countersink.get("depth")),
            "bore_diameter": _number((hole.get("bore") or {}).get("diameter")),
            "perpendicularity_deg": _number(hole.get("perpendicularity_deg")),
            "u_diameter": _number((hole.get("uncertainty") or {}).get("diameter")),
            "in_tolerance": None if in_tolerance is None else int(bool(in_tolerance)),
            "warnings": json.dumps([warning["code"] for warning in hole.get("warnings") or ()]),
        })
    return rows


def characteristic_rows(record, measurement_id) -> list:
    """The ``characteristic`` rows of a record: one per entry of each hole's ``conformance``.

    Parameters
    ----------
    record : dict
    measurement_id : str

    Returns
    -------
    list of dict
        ``{column: value}`` in the order of :data:`CHARACTERISTIC_COLUMNS`; none for a record
        without tolerances.
    """
    rows = []
    for idx, hole in enumerate(record.get("holes") or ()):
        for name, entry in (hole.get("conformance") or {}).items():
            rows.append({
                "measurement_id": measurement_id, "hole_idx": idx, "name": name,
                "value": _number(entry.get("value")), "lower": _number(entry.get("lower")),
                "upper": _number(entry.get("upper")),
                "expanded_uncertainty": _number(entry.get("expanded_uncertainty")),
                "decision": entry.get("decision"), "reason": entry.get("reason"),
            })
    return rows


SUMMARY_KEYS = ("id", "received", "file", "part", "serial", "cell", "operator", "spec", "verdict", "holes",
                "processing_ms")
"""The keys of a summary of :meth:`holecli.store.Store.find`, in order."""


def summary(row) -> dict:
    """The summary :meth:`holecli.store.Store.find` gives of a measurement row.

    Parameters
    ----------
    row : Mapping
        The columns id, received (text), file, part, serial, cell, operator, spec, verdict, holes,
        processing_ms.

    Returns
    -------
    dict
    """
    return {key: row[key] for key in SUMMARY_KEYS}


def stored_answer(record_text, *, id, received, processing_ms, meta_text) -> dict:
    """What :meth:`holecli.store.Store.get` gives: the record as added, plus ``id``, ``received``,
    ``processing_ms``, ``stored`` (True) and ``meta``.

    Parameters
    ----------
    record_text : str
        The ``record`` column.
    id, received : str
    processing_ms : float or None
    meta_text : str
        The ``meta`` column (JSON).

    Returns
    -------
    dict
    """
    answer = json.loads(record_text)
    answer.update(id=id, received=received, processing_ms=processing_ms, stored=True, meta=json.loads(meta_text))
    return answer
