"""Reading and writing point-cloud files.

:func:`load_points` turns a file into an ``(n, 3)`` float64 array of finite points; :func:`read_cloud`
also tells how many rows were dropped because a coordinate was NaN or infinite; :func:`save_points`
writes an array back (in the formats of :data:`WRITE_EXTENSIONS`); :func:`read_stream` reads a cloud
from a stream (standard input). Supported formats, chosen by the extension (any case) or given as
``input_format``:

========  ==================================================================================
``.ply``  ascii, binary_little_endian, binary_big_endian; any element layout and property types
``.pcd``  DATA ascii, binary, binary_compressed (organized clouds too: their NaN rows are dropped)
``.csv``  comma, semicolon, tab or whitespace separated; optional header naming x, y, z
``.txt``  same as ``.csv``
``.xyz``  same as ``.csv``
``.e57``  ASTM E57, every scan moved by its pose (or one scan); metres; needs the ``e57`` extra
``.las``  ASPRS LAS 1.0 to 1.4, scaled integer coordinates; needs the ``las`` extra
``.laz``  LAS compressed (LASzip); needs the ``las`` extra (laspy with the lazrs backend)
========  ==================================================================================

Where each thing happens (this module is their face: every name below is importable from
``holecli.io``, and imported from its own module when first used, so that ``import holecli.io``
costs nothing):

- :mod:`holecli.io.formats`: the table of formats (:data:`~holecli.io.formats.FORMATS`: name,
  extensions, reader, writer, what messages call it, the optional extra), from which the
  extension lists, the ``input_format`` names and the "expected ..." of the messages are derived;
- :mod:`holecli.io.cloud`: :class:`Cloud`, :func:`read_cloud`, :func:`load_points`, the checks every
  file goes through (exists, a regular file, a supported extension, not empty), the dispatch by
  extension, and dropping the non-finite rows;
- :mod:`holecli.io.stream`: :func:`read_stream` (standard input);
- :mod:`holecli.io.write`: :func:`save_points`;
- :mod:`holecli.io.readers`: each format's reader and writer behind one signature;
- :mod:`holecli.io.ply`: PLY reading and writing;
- :mod:`holecli.io.pcd`: PCD reading (ascii, binary, binary_compressed/LZF, old PCL padding) and writing;
- :mod:`holecli.io.text`: CSV, TXT and XYZ tables, reading and writing;
- :mod:`holecli.io.e57`: E57 reading (pye57, imported when an E57 file is read);
- :mod:`holecli.io.las`: LAS and LAZ reading (laspy, imported when one is read);
- :mod:`holecli.io._common`: what the readers share: the error they raise, the phrases of its
  messages, the header size limit, x, y, z from binary records, and the ascii body reader of PLY
  and PCD;
- :mod:`holecli.io.outfile`: atomic writes of any output file; :mod:`holecli.io.decimal_text`:
  decimals for text output.

Every problem with a file raises :class:`holecli.errors.LoadError`, never another exception type,
and a file is never half-read: a count that disagrees with its header is refused rather than
padded or cut. Messages name rows and lines by their 1-based line number in the file.

A PLY or PCD file must be exactly as long as its header says: a binary body (every element of a
PLY, the records of a PCD, the sizes and LZF stream of a ``binary_compressed`` PCD) neither
shorter nor longer, an ascii body one non-blank line per record with nothing but blank lines
after the last. The one exception is the NUL padding of old PCL releases (up to about 1.8), whose
binary and binary_compressed writers stretch the file to one memory page plus the data: a PCD
exactly that long and ending in NUL bytes is read. Bytes after the data are otherwise the sign of
a damaged file or a wrong header (a count halved, a type relabelled, DATA ascii marked binary),
and reading on would measure reinterpreted bytes. Nothing is allocated by what a header asks for
before it is checked against what the file holds, so a count of 10^12 is refused at once.

open3d reads PLY and PCD, but not defensively: a missing, truncated or malformed file comes back as
an empty cloud, or as the header's point count filled with zeros or garbage, with at most a warning
on the console. So the headers are parsed and checked here, and the vertex data of PLY and of
uncompressed PCD is read with numpy from the parsed header, which is also faster. open3d is used
only to decompress ``binary_compressed`` PCD (LZF), after the header and the sizes are checked, and
is imported there: importing it costs more than a second, which ``--help`` and CSV input should not
pay.
"""

from __future__ import annotations

import importlib

__all__ = ["INPUT_FORMATS", "MAX_STREAM_BYTES", "STDIN_NAME", "SUPPORTED_EXTENSIONS", "WRITE_EXTENSIONS", "Cloud",
           "TableColumns", "load_points", "parse_columns", "read_cloud", "read_stream", "save_points"]

# Each name of the face and the module that defines it (SUPPORTED_EXTENSIONS: formats.INPUT_EXTENSIONS).
_HOMES = {
    "INPUT_FORMATS": "formats", "SUPPORTED_EXTENSIONS": "formats", "WRITE_EXTENSIONS": "formats",
    "Cloud": "cloud", "file_kind": "cloud", "load_points": "cloud", "read_cloud": "cloud",
    "MAX_STREAM_BYTES": "stream", "STDIN_NAME": "stream", "read_stream": "stream",
    "save_points": "write",
    "TableColumns": "text", "parse_columns": "text",
}
# The submodules an `import holecli.io` made attributes before this face was lazy.
_SUBMODULES = ("_common", "outfile", "pcd", "ply", "text")
_RENAMED = {"SUPPORTED_EXTENSIONS": "INPUT_EXTENSIONS"}


def __getattr__(name):
    home = _HOMES.get(name)
    if home is None and name in _SUBMODULES:  # holecli.io.ply and the others, as when they were imported here
        return importlib.import_module(f"{__name__}.{name}")
    if home is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(f"{__name__}.{home}"), _RENAMED.get(name, name))
    globals()[name] = value
    return value


def __dir__():
    return sorted({*globals(), *_HOMES})
