"""The point-cloud formats holecli reads and writes: one table, from which everything else is derived.

:data:`FORMATS` names each format, its extensions (messages call a format by its extension:
``unsupported extension '.obj' (expected .ply, ...)``, ``reading .e57 needs the optional extra``), the
functions that read and write it and the optional extra it needs. The extension lists (:data:`INPUT_EXTENSIONS`,
:data:`WRITE_EXTENSIONS`), the names ``input_format`` and ``--input-format`` take
(:data:`INPUT_FORMATS`) and the "expected ..." of the messages about an unsupported extension are
derived from it, so a new format is one more row here (and its reader).

Only the standard library is imported: the command line builds its choices from this module
without importing numpy or the readers; a format's functions are named, not imported, and
:func:`reader` / :func:`writer` import them when a file of that format is read or written.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from typing import Optional

__all__ = ["FORMATS", "INPUT_EXTENSIONS", "INPUT_FORMATS", "TEXT_EXTENSIONS", "WRITE_EXTENSIONS", "Format",
           "expected", "format_of", "reader", "writer"]


@dataclass(frozen=True)
class Format:
    """One point-cloud format.

    Attributes
    ----------
    name : str
        Its name, as ``input_format`` and ``--input-format`` take it (``"ply"``).
    extensions : tuple of str
        The file extensions, lower case with their dot, that select it (``(".ply",)``).
    read : str
        The function that reads a file of it, as ``"module:function"``; it is called
        ``function(path, scan, columns)`` and returns ``(rows, flagged, units, columns)`` (see
        :mod:`holecli.io.readers`).
    write : str or None
        The function that encodes points as a file of it, as ``"module:function"``, called
        ``function(points, float32, extension)`` and returning bytes; None when holecli does not
        write it.
    extra : str or None
        The optional dependency (``pip install holecli[EXTRA]``) its reader needs; None when the
        base install reads it.
    table : bool
        A text table (``--columns`` applies to it).
    scans : bool
        A file of it may hold several scans (``scan`` chooses one); every other file holds one, scan 0.
    """

    name: str
    extensions: tuple
    read: str
    write: Optional[str] = None
    extra: Optional[str] = None
    table: bool = False
    scans: bool = False


_READERS = "holecli.io.readers"

# The formats, in the order the messages and choices list them.
FORMATS = (
    Format("ply", (".ply",), f"{_READERS}:read_ply", write=f"{_READERS}:encode_ply"),
    Format("pcd", (".pcd",), f"{_READERS}:read_pcd", write=f"{_READERS}:encode_pcd"),
    Format("csv", (".csv",), f"{_READERS}:read_table", write=f"{_READERS}:encode_table", table=True),
    Format("txt", (".txt",), f"{_READERS}:read_table", write=f"{_READERS}:encode_table", table=True),
    Format("xyz", (".xyz",), f"{_READERS}:read_table", write=f"{_READERS}:encode_table", table=True),
    Format("e57", (".e57",), f"{_READERS}:read_e57", extra="e57", scans=True),
    Format("las", (".las",), f"{_READERS}:read_las", extra="las"),
    Format("laz", (".laz",), f"{_READERS}:read_las", extra="las"),
)

_BY_EXTENSION = {extension: fmt for fmt in FORMATS for extension in fmt.extensions}

# What holecli.io.read_cloud reads, by extension (any case), and what save_points writes.
INPUT_EXTENSIONS = tuple(_BY_EXTENSION)
WRITE_EXTENSIONS = tuple(extension for fmt in FORMATS if fmt.write for extension in fmt.extensions)
# The formats by name (``input_format``, ``--input-format``).
INPUT_FORMATS = tuple(fmt.name for fmt in FORMATS)
# The extensions of text tables (``--columns``).
TEXT_EXTENSIONS = tuple(extension for fmt in FORMATS if fmt.table for extension in fmt.extensions)


def format_of(extension):
    """The :class:`Format` of ``extension`` (lower case, with its dot), or None when none reads it.

    Examples
    --------
    >>> format_of(".laz").extra
    'las'
    >>> format_of(".obj") is None
    True
    """
    return _BY_EXTENSION.get(extension)


def expected(extensions):
    """``extensions`` as the messages list them: ``".ply, .pcd or .csv"``.

    Examples
    --------
    >>> expected(WRITE_EXTENSIONS)
    '.ply, .pcd, .csv, .txt or .xyz'
    """
    return ", ".join(extensions[:-1]) + " or " + extensions[-1] if len(extensions) > 1 else "".join(extensions)


def reader(fmt):
    """The function that reads a file of ``fmt`` (:attr:`Format.read`), imported now."""
    return _resolve(fmt.read)


def writer(fmt):
    """The function that encodes points as a file of ``fmt`` (:attr:`Format.write`), imported now."""
    return _resolve(fmt.write)


def _resolve(target):
    module, _, function = target.partition(":")
    return getattr(importlib.import_module(module), function)
