"""The JSON Schema of holecli's records (``record.schema.json``, shipped with the package).

It describes the record of ``holecli detect`` (``$defs/detect_record``), a line of ``holecli batch``
(``$defs/batch_line``: a measured file's ``batch_record`` or a ``batch_error``) and every part of them,
for :data:`holecli.results.SCHEMA_VERSION`. holecli does not validate its own output at run time
(``jsonschema`` is a test dependency only); the tests check real output against it.
"""

from __future__ import annotations

import json
from importlib import resources

SCHEMA_FILE = "record.schema.json"
KINDS = ("detect_record", "batch_record", "batch_error", "batch_line", "served_record")


def record_schema(kind=None) -> dict:
    """The JSON Schema of the records.

    Parameters
    ----------
    kind : {"detect_record", "batch_record", "batch_error", "batch_line", "served_record"}, optional
        Root the schema at that definition; by default it accepts any of them.

    Returns
    -------
    dict
        A draft 2020-12 JSON Schema (a new dict on every call).

    Raises
    ------
    ValueError
        When ``kind`` is not one of :data:`KINDS`.

    Examples
    --------
    >>> from holecli.results import SCHEMA_VERSION
    >>> from holecli.schema import record_schema
    >>> record_schema()["$defs"]["detect_record"]["properties"]["schema_version"]["const"] == SCHEMA_VERSION
    True
    """
    schema = json.loads(resources.files(__name__).joinpath(SCHEMA_FILE).read_text(encoding="utf-8"))
    if kind is None:
        return schema
    if kind not in KINDS:
        raise ValueError(f"kind must be one of {', '.join(KINDS)}, got {kind!r}")
    schema.pop("anyOf")
    schema["$ref"] = f"#/$defs/{kind}"
    return schema
