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

Where each thing happens:

- this module: :class:`Cloud`, :func:`read_cloud`, :func:`read_stream`, :func:`load_points`, :func:`save_points`, the
  checks every file goes through (exists, a regular file, a supported extension, not empty), the
  dispatch by extension, and dropping the non-finite rows;
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

import csv
import os
import re
import secrets
import stat
import struct
import tempfile
from dataclasses import dataclass
from typing import Optional

import numpy as np

from holecli.errors import LoadError
from holecli.io._common import _BadFile, _describe
from holecli.io.outfile import write_bytes
from holecli.io.pcd import encode_pcd, read_pcd
from holecli.io.ply import encode_ply, read_ply
from holecli.io.text import TableColumns, encode_table, parse_columns, read_table_columns
from holecli.vocabulary import INPUT_EXTENSIONS, INPUT_FORMATS

__all__ = ["INPUT_FORMATS", "MAX_STREAM_BYTES", "STDIN_NAME", "SUPPORTED_EXTENSIONS", "WRITE_EXTENSIONS", "Cloud",
           "TableColumns", "load_points", "parse_columns", "read_cloud", "read_stream", "save_points"]

# What read_cloud reads (and by name, ``input_format``), and what save_points writes.
SUPPORTED_EXTENSIONS = INPUT_EXTENSIONS
WRITE_EXTENSIONS = (".ply", ".pcd", ".csv", ".txt", ".xyz")
# What messages and records call standard input.
STDIN_NAME = "<stdin>"
# The most :func:`read_stream` reads: a stream has no size to check beforehand and may never end
# (``cat /dev/zero |``). 2 GiB is some 89 million points of a binary PLY with double x, y, z, far
# beyond a scan of one part; a larger cloud can still be read from a file.
MAX_STREAM_BYTES = 2 << 30
_TEXT_EXTENSIONS = (".csv", ".txt", ".xyz")
_EXPECTED = ".ply, .pcd, .csv, .txt, .xyz, .e57, .las or .laz"
_WRITE_EXPECTED = ".ply, .pcd, .csv, .txt or .xyz"
# The first bytes the E57 and LAS readers check their signature in.
_SIGNATURE_BYTES = 8


@dataclass(frozen=True, eq=False)
class Cloud:
    """The points of one file.

    Attributes
    ----------
    points : (n, 3) float64 ndarray
        The finite points, C-contiguous, in file units, in file order; n >= 1.
    dropped : int
        Rows of the file dropped because a coordinate was NaN or infinite (the empty cells of an
        organized cloud, for example), or because the file flags the point invalid (E57).
    path : str
        The file the points were read from.
    units : str or None
        The length unit the format itself declares: ``"m"`` for E57 (the standard's unit); for a
        text table, the unit its header's names give (``x_mm,y_mm,z_mm``: ``"mm"``); None for
        every other file, which does not say.
    columns : holecli.io.text.TableColumns or None
        Which columns of a text table were read as x, y, z; None for every other format.
    """

    points: np.ndarray
    dropped: int
    path: str
    units: Optional[str] = None
    columns: Optional[TableColumns] = None


def read_cloud(path, scan=None, input_format=None, columns=None) -> Cloud:
    """Read the points of a PLY, PCD, CSV, TXT, XYZ, E57, LAS or LAZ file.

    Parameters
    ----------
    path : str or os.PathLike
        The file; its extension (any case) selects the format, unless ``input_format`` is given.
    scan : int, optional
        The scan to read, from 0, of an E57 file that holds several; by default every scan, each
        moved into the file's common frame by its pose, merged into one cloud. A file of any other
        format holds one scan, 0.
    input_format : {"ply", "pcd", "csv", "txt", "xyz", "e57", "las", "laz"}, optional
        The format to read the file in, whatever its extension (``scan.asc`` as ``"xyz"``).
    columns : sequence of 3 (str or int), optional
        The x, y, z columns of a text table: header names or 0-based indices
        (:func:`holecli.io.text.parse_columns`); by default found from the header or the data
        (:mod:`holecli.io.text`). Refused for any other format.

    Returns
    -------
    Cloud
        The finite points of the file and the number of rows dropped as non-finite (or flagged
        invalid by an E57 file).

    Raises
    ------
    LoadError
        For any problem with the file: missing, a directory, unsupported extension, empty, garbled
        or truncated, no x, y, z coordinates, a non-numeric value, or no finite point at all; a
        ``scan`` the file does not have; an E57, LAS or LAZ file when the optional extra that reads
        it is not installed.
    ValueError
        When ``input_format`` is not one of :data:`INPUT_FORMATS` or ``scan`` is not a whole number >= 0.
    """
    name = os.fspath(path)
    _check_scan(scan)
    extension = _extension(name, input_format)
    raw, flagged, units, read = _read_checked(name, extension, name, scan, columns)
    return _finite_cloud(raw, name, flagged, units, read)


def read_stream(stream, input_format, name=STDIN_NAME, max_bytes=None, scan=None, columns=None) -> Cloud:
    """Read the points of a cloud from a binary stream (standard input: ``sys.stdin.buffer``).

    The stream is copied, up to ``max_bytes``, into a temporary file in :func:`tempfile.gettempdir`,
    which is then read and checked exactly as :func:`read_cloud` reads and checks a file of that
    format: damaged data is refused alike. The readers that open a file by its name (E57, LAS) get
    it as ``/proc/self/fd/N``. On Linux that file has no name at all (``O_TMPFILE``, else it is
    unlinked as soon as it is made): whatever happens, a SIGKILL in the middle of the copy too,
    nothing is left behind. Where there is no ``/proc/self/fd``, the file is named
    ``holecli-stdin-PID-XXXXXXXX.FORMAT`` and removed before this returns, and one left by a
    process that was killed is removed by the next :func:`read_stream` (as are the
    ``holecli-stdin-XXXXXXXX.FORMAT`` of holecli before 0.2 once an hour old).

    Parameters
    ----------
    stream : binary file object
        Read to its end (``read`` returning ``b""``).
    input_format : {"ply", "pcd", "csv", "txt", "xyz"}
        Its format: a stream has no extension.
    name : str
        What messages and :attr:`Cloud.path` call the stream.
    max_bytes : int, optional
        The most that is read (default :data:`MAX_STREAM_BYTES`); a longer stream is refused (it is
        read no further).
    scan : int, optional
        As for :func:`read_cloud` (an E57 stream's scan).
    columns : sequence of 3 (str or int), optional
        As for :func:`read_cloud`.

    Returns
    -------
    Cloud
        As :func:`read_cloud`, with ``path`` ``name``.

    Raises
    ------
    LoadError
        Named ``name``: the stream is longer than ``max_bytes``, cannot be read, or holds no valid
        cloud of that format (as :func:`read_cloud`), or the temporary file cannot be written.
    ValueError
        When ``input_format`` is not one of :data:`INPUT_FORMATS`.

    Examples
    --------
    >>> import io
    >>> from holecli.io import read_stream
    >>> read_stream(io.BytesIO(b"x,y,z\\n0,0,0\\n1,0,0\\n0,1,0\\n"), "csv").points.shape
    (3, 3)
    >>> read_stream(io.BytesIO(b""), "ply")
    Traceback (most recent call last):
        ...
    holecli.errors.LoadError: <stdin>: empty file
    """
    _check_scan(scan)
    extension = _extension("", input_format)
    max_bytes = MAX_STREAM_BYTES if max_bytes is None else max_bytes
    try:
        descriptor, path, temporary = _stream_copy_file(extension)
    except OSError as exc:
        raise LoadError(name, f"cannot make a temporary file to read it into ({_describe(exc)})") from None
    try:
        with os.fdopen(descriptor, "wb", closefd=False) as copy:
            _copy_stream(stream, copy, max_bytes, name)
        raw, flagged, units, read = _read_checked(path, extension, name, scan, columns)
        return _finite_cloud(raw, name, flagged, units, read)
    finally:
        os.close(descriptor)
        if temporary is not None:
            try:
                os.unlink(temporary)
            except OSError:
                pass


# The names of read_stream's copies: holecli-stdin-PID-XXXXXXXX.FORMAT, and those of holecli before
# 0.2 (mkstemp's, no PID), taken for stale once _LEGACY_COPY_AGE_S old (a copy in use is written to
# or read within seconds; a stream of 2 GiB is copied in minutes).
_COPY_PREFIX = "holecli-stdin-"
_COPY_NAME = re.compile(r"holecli-stdin-([0-9]+)-[a-z0-9_]{8}\.[a-z0-9]+")
_LEGACY_COPY_NAME = re.compile(r"holecli-stdin-[a-z0-9_]{8}\.[a-z0-9]+")
_LEGACY_COPY_AGE_S = 3600.0
# Where a process's open files have a path (Linux): the copy of a stream needs no name of its own.
_FD_FOLDER = "/proc/{pid}/fd"


def _stream_copy_file(extension):
    """A new file for :func:`read_stream`'s copy: ``(descriptor, path to read it by, name to remove)``.

    With ``/proc/self/fd`` (Linux) the file has no name, so that nothing can be left of it: the path
    is ``/proc/self/fd/N`` and the name to remove None. Otherwise a file named by this process's id,
    which this run removes, or a later one when this process was killed.
    """
    folder = tempfile.gettempdir()
    _remove_stale_copies(folder)
    fd_folder = _FD_FOLDER.format(pid=os.getpid())
    if os.path.isdir(fd_folder):
        descriptor = None
        if hasattr(os, "O_TMPFILE"):
            try:
                descriptor = os.open(folder, os.O_TMPFILE | os.O_RDWR, 0o600)
            except OSError:  # a file system without O_TMPFILE: a named file, unlinked at once
                descriptor = None
        if descriptor is None:
            descriptor, temporary = tempfile.mkstemp(prefix=f"{_COPY_PREFIX}{os.getpid()}-", suffix=extension)
            os.unlink(temporary)
        return descriptor, os.path.join(fd_folder, str(descriptor)), None
    descriptor, temporary = _named_copy(folder, extension)
    return descriptor, temporary, temporary


def _named_copy(folder, extension):
    while True:
        temporary = os.path.join(folder, f"{_COPY_PREFIX}{os.getpid()}-{secrets.token_hex(4)}{extension}")
        try:
            return os.open(temporary, os.O_RDWR | os.O_CREAT | os.O_EXCL, 0o600), temporary
        except FileExistsError:
            continue


def _remove_stale_copies(folder):
    """Remove the copies of standard input that killed processes left in ``folder``."""
    from holecli.io.outfile import remove_stale

    remove_stale(folder, _COPY_NAME, _LEGACY_COPY_NAME, _LEGACY_COPY_AGE_S)


def _copy_stream(stream, copy, max_bytes, name):
    """Copy ``stream`` to the file ``copy``, refusing more than ``max_bytes``."""
    copied = 0
    while True:
        try:
            chunk = stream.read(min(1 << 20, max_bytes + 1 - copied))
        except OSError as exc:
            raise LoadError(name, f"cannot read ({_describe(exc)})") from None
        if not chunk:
            return
        copied += len(chunk)
        if copied > max_bytes:
            raise LoadError(name, f"more than {max_bytes} bytes: too large to read from a stream "
                                  f"(give the file's name instead)")
        try:
            copy.write(chunk)
        except OSError as exc:
            raise LoadError(name, f"cannot copy it into a temporary file ({_describe(exc)})") from None


def _extension(name, input_format):
    """The extension that selects the reader: ``.FORMAT``, else the file's own (lower case)."""
    if input_format is None:
        return os.path.splitext(name)[1].lower()
    if input_format not in INPUT_FORMATS:
        raise ValueError(f"input_format must be one of {INPUT_FORMATS}, got {input_format!r}")
    return "." + input_format


def _check_scan(scan):
    if scan is not None and (isinstance(scan, bool) or int(scan) != scan or scan < 0):
        raise ValueError(f"scan must be a whole number >= 0, got {scan!r}")


def _read_checked(path, extension, name, scan=None, columns=None):
    """:func:`_read_raw`, its problems raised as LoadError named ``name``."""
    try:
        return _read_raw(path, extension, scan, columns)
    except _BadFile as exc:
        raise LoadError(name, str(exc)) from None
    except (OSError, ValueError, struct.error, csv.Error, OverflowError, MemoryError) as exc:
        # Every known bad input is reported above with its own message; this is the safety net
        # that keeps an unforeseen one a one-line error instead of a traceback.
        raise LoadError(name, f"unreadable file ({_describe(exc)})") from exc


def load_points(path) -> np.ndarray:
    """Read the finite points of a point-cloud file.

    Parameters
    ----------
    path : str or os.PathLike
        A ``.ply``, ``.pcd``, ``.csv``, ``.txt``, ``.xyz``, ``.e57``, ``.las`` or ``.laz`` file (an
        E57's scans merged, see :func:`read_cloud`).

    Returns
    -------
    points : (n, 3) float64 ndarray
        C-contiguous, in file units; rows with a NaN or infinite coordinate are left out
        (:func:`read_cloud` tells how many).

    Raises
    ------
    LoadError
        See :func:`read_cloud`.

    Examples
    --------
    From the root of the repository:

    >>> from holecli.io import load_points
    >>> points = load_points("sample_clouds/table1.ply")
    >>> points.shape, points.dtype
    ((7062, 3), dtype('float64'))
    >>> bool(points.flags.c_contiguous)
    True
    """
    return read_cloud(path).points


def save_points(path, points, float32=False) -> None:
    """Write points to a PLY, PCD, CSV, TXT or XYZ file, replacing a regular file atomically.

    PLY is written as binary_little_endian and PCD as ``DATA binary``, both with double x, y, z;
    CSV gets an ``x,y,z`` header, ``.txt`` and ``.xyz`` are space separated without one. Text holds
    the shortest decimal that reads back to the same double. The data go to a temporary file in the
    same folder, which then replaces ``path``: a reader never sees half a file, and on failure the
    temporary file is removed and ``path`` is left as it was. A symbolic link gets its target
    written, a device or FIFO is written directly (see :func:`holecli.io.outfile.write_bytes`).

    Parameters
    ----------
    path : str or os.PathLike
        The file to write; its extension (any case) selects the format.
    points : (n, 3) array_like of float
        The points; NaN and infinite values are written as they are.
    float32 : bool
        Write single-precision values, as laser profilers do (binary PLY ``property float``, PCD
        ``SIZE 4``; text with each value rounded to float32, written so that it reads back exactly).

    Returns
    -------
    None

    Raises
    ------
    ValueError
        If the extension is not supported or ``points`` is not a numeric (n, 3) array.
    OSError
        If the file cannot be written.
    """
    name = os.fspath(path)
    extension = os.path.splitext(name)[1].lower()
    if extension not in WRITE_EXTENSIONS:
        raise ValueError(f"cannot save {name!r}: unsupported extension {extension!r} (expected {_WRITE_EXPECTED})")
    array = _as_points(points)
    if extension == ".ply":
        payload = encode_ply(array, float32)
    elif extension == ".pcd":
        payload = encode_pcd(array, float32)
    else:
        payload = encode_table(array.astype(np.float32) if float32 else array, header=extension == ".csv")
    write_bytes(name, payload)


# --- checks every file goes through, and the dispatch by extension ----------------------------


def _read_raw(name: str, extension: str, scan=None, columns=None):
    """All coordinate rows of the file, non-finite ones included, as (n, 3) float64; the points
    left out because the file flags them invalid; the unit the format declares (or None); the
    columns read (:class:`TableColumns`, text tables; else None).
    ``extension`` (``.ply``, ...; the file's own or the one of the format asked for) selects the reader."""
    try:
        info = os.stat(name)
    except FileNotFoundError:
        raise _BadFile("file not found") from None
    except PermissionError:
        raise _BadFile("permission denied") from None
    except OSError as exc:
        raise _BadFile(f"cannot open file ({_describe(exc)})") from None
    if stat.S_ISDIR(info.st_mode):
        raise _BadFile(f"is a directory (to measure every scan in it: holecli batch {name})")
    if not stat.S_ISREG(info.st_mode):
        # Decided before opening: opening a FIFO blocks until a writer comes, and a device never ends.
        raise _BadFile(f"not a regular file ({file_kind(info.st_mode)})")
    if extension not in SUPPORTED_EXTENSIONS:
        shown = repr(extension) if extension else "(none)"
        raise _BadFile(f"unsupported extension {shown} (expected {_EXPECTED}; a text file of x y z rows "
                       "under another name: give --input-format xyz, or csv)")
    if info.st_size == 0:
        raise _BadFile("empty file")
    if columns is not None and extension not in _TEXT_EXTENSIONS:
        raise _BadFile(f"--columns is for text tables (.csv, .txt, .xyz), not {extension} files")
    if extension == ".e57":
        from holecli.io.e57 import E57_UNITS, read_e57

        points, flagged = read_e57(name, _head(name), scan)
        return points, flagged, E57_UNITS, None
    if scan is not None and scan != 0:
        raise _BadFile(f"scan {scan} is out of range: a {extension} file holds 1 scan (scan 0)")
    if extension in (".las", ".laz"):
        from holecli.io.las import read_las

        return read_las(name, _head(name)), 0, None, None
    if extension in _TEXT_EXTENSIONS:
        points, read = read_table_columns(name, columns)
        return points, 0, read.unit, read
    with open(name, "rb") as stream:
        data = stream.read()
    if data.isspace():
        raise _BadFile("empty file")
    if extension == ".ply":
        return read_ply(name, data), 0, None, None
    return read_pcd(name, data), 0, None, None


def _head(name: str) -> bytes:
    with open(name, "rb") as stream:
        return stream.read(_SIGNATURE_BYTES)


def file_kind(mode: int) -> str:
    """What a file that is not a regular file is, for messages: ``"a FIFO"``, ``"a folder"``, ...

    Parameters
    ----------
    mode : int
        The ``st_mode`` of the file's :func:`os.stat`.

    Returns
    -------
    str
        ``"a folder"``, ``"a FIFO"``, ``"a character device"``, ``"a block device"``,
        ``"a socket"``, or ``"file type 0o..."`` for any other kind.
    """
    for test, kind in (
        (stat.S_ISDIR, "a folder"),
        (stat.S_ISFIFO, "a FIFO"),
        (stat.S_ISCHR, "a character device"),
        (stat.S_ISBLK, "a block device"),
        (stat.S_ISSOCK, "a socket"),
    ):
        if test(mode):
            return kind
    return f"file type {stat.S_IFMT(mode):#o}"


def _finite_cloud(raw: np.ndarray, name: str, flagged: int = 0, units=None, columns=None) -> Cloud:
    """Drop the rows with a non-finite coordinate and refuse a cloud with no point left (``flagged``:
    the points the reader left out as flagged invalid, counted as dropped too)."""
    finite = np.isfinite(raw).all(axis=1)
    kept = int(np.count_nonzero(finite))
    if kept == 0:
        if len(raw) == 0 and flagged == 0:
            raise LoadError(name, "no points")
        if flagged:
            raise LoadError(name, f"no valid points (all {len(raw) + flagged} points are flagged invalid "
                                  "or have a NaN or infinite coordinate)")
        raise LoadError(name, f"no finite points (all {len(raw)} rows have a NaN or infinite coordinate)")
    points = raw if kept == len(raw) else raw[finite]
    return Cloud(np.ascontiguousarray(points, dtype=np.float64), len(raw) - kept + flagged, name, units, columns)


def _as_points(points) -> np.ndarray:
    array = np.asarray(points)
    if array.dtype.kind not in "iuf":
        raise ValueError(f"points must be a numeric array, got dtype {array.dtype}")
    if array.ndim != 2 or array.shape[1] != 3:
        raise ValueError(f"points must have shape (n, 3), got {array.shape}")
    return np.ascontiguousarray(array, dtype=np.float64)
