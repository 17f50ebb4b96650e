"""Reading one point-cloud file: :class:`Cloud`, :func:`read_cloud`, :func:`load_points`, the checks every
file goes through (exists, a regular file, a supported extension, not empty), the dispatch by
extension through :data:`holecli.io.formats.FORMATS`, and dropping the non-finite rows."""

from __future__ import annotations

import csv
import os
import stat
import struct
from dataclasses import dataclass
from typing import TYPE_CHECKING, Optional

import numpy as np

from holecli.errors import LoadError
from holecli.io._common import _BadFile, _describe
from holecli.io.formats import INPUT_EXTENSIONS, INPUT_FORMATS, TEXT_EXTENSIONS, expected, format_of, reader

if TYPE_CHECKING:  # (only named in Cloud's fields: reading a PLY does not import the text tables' reader)
    from holecli.io.text import TableColumns

__all__ = ["Cloud", "file_kind", "load_points", "read_cloud"]


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


# --- checks every file goes through, and the dispatch by extension ----------------------------


def _read_raw(name: str, extension: str, scan=None, columns=None):
    """All coordinate rows of the file, non-finite ones included, as (n, 3) float64; the points
    left out because the file flags them invalid; the unit the format declares (or None); the
    columns read (:class:`TableColumns`, text tables; else None).
    ``extension`` (``.ply``, ...; the file's own or the one of the format asked for) selects the reader
    (:data:`holecli.io.formats.FORMATS`)."""
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
    fmt = format_of(extension)
    if fmt is None:
        shown = repr(extension) if extension else "(none)"
        raise _BadFile(f"unsupported extension {shown} (expected {expected(INPUT_EXTENSIONS)}; a text file of x y z "
                       "rows under another name: give --input-format xyz, or csv)")
    if info.st_size == 0:
        raise _BadFile("empty file")
    if columns is not None and not fmt.table:
        raise _BadFile(f"--columns is for text tables ({', '.join(TEXT_EXTENSIONS)}), not {extension} files")
    if not fmt.scans and scan is not None and scan != 0:
        raise _BadFile(f"scan {scan} is out of range: a {extension} file holds 1 scan (scan 0)")
    return reader(fmt)(name, scan, columns)


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
