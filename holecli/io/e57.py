"""E57 reading (ASTM E2807, what FARO, Leica and Hexagon scanners export), through the optional ``pye57``.

An E57 file holds one or more scans (``data3D``), each with its points in its own frame and a pose
(a rotation quaternion and a translation) that puts them in the file's common frame. Coordinates are
in metres, by the standard. :func:`read_e57` reads every scan, each transformed by its pose, into one
array, or the one scan asked for.

What is refused, never measured: a file without the ``ASTM-E57`` signature, any error of libE57
(every 1 KiB page of an E57 file carries a CRC, so a flipped byte, a cut or appended bytes are found
there), a pose that is not a finite unit quaternion and a finite translation, a file without scans,
a scan index out of range. Points flagged invalid (``cartesianInvalidState`` or
``sphericalInvalidState`` not 0) are dropped and counted like NaN rows.

``pye57`` is imported only here, and only when an E57 file is read: a missing extra gives the one
line ``reading .e57 needs the optional extra: pip install 'holecli[e57]'``.
"""

from __future__ import annotations

import math

import numpy as np

from holecli.io._common import _BadFile, _need_extra

# The first bytes of every E57 file (its physical header: "ASTM-E57", then the version and sizes).
E57_SIGNATURE = b"ASTM-E57"

# E57 coordinates are in metres (ASTM E2807, section 8.4.2).
E57_UNITS = "m"

# How far a pose's quaternion may be from unit length (writers store it in single or double
# precision; a damaged one is far off).
_UNIT_QUATERNION_TOLERANCE = 1e-3


def read_e57(name: str, data_head: bytes, scan=None):
    """The points of an E57 file: every scan transformed by its pose, or the one scan asked for.

    Parameters
    ----------
    name : str
        The file (libE57 reads it itself).
    data_head : bytes
        Its first bytes (at least 8, when the file is that long), to check the signature before
        libE57 sees the file.
    scan : int or None
        The index of the scan to read, from 0; None for every scan, merged.

    Returns
    -------
    points : (n, 3) float64 ndarray
        The points that are not flagged invalid, in the file's common frame (metres), scan after
        scan; NaN coordinates are left in for the caller to drop and count.
    flagged : int
        Points left out because their scan flags them invalid.

    Raises
    ------
    _BadFile
        For a file that is not E57, a damaged one, a bad pose, no scans, ``scan`` out of range, or
        pye57 missing.
    """
    if not data_head.startswith(E57_SIGNATURE):
        raise _BadFile("not an E57 file (it does not start with the signature 'ASTM-E57')")
    try:
        import pye57
        from pye57 import libe57
    except ImportError:
        raise _need_extra(".e57", "e57") from None
    try:
        with pye57.E57(name) as e57:
            count = e57.scan_count
            if count == 0:
                raise _BadFile("no scans in the E57 file (its data3D is empty)")
            if scan is not None and not 0 <= scan < count:
                raise _BadFile(out_of_range(scan, count))
            chosen = range(count) if scan is None else [scan]
            parts, flagged = [], 0
            for index in chosen:
                points, invalid = _read_scan(e57, index)
                parts.append(points)
                flagged += invalid
    except libe57.E57Exception as exc:
        raise _BadFile(f"damaged or unreadable E57 file ({_e57_problem(exc)})") from None
    points = np.concatenate(parts) if parts else np.empty((0, 3))
    return np.ascontiguousarray(points, dtype=np.float64), flagged


def _read_scan(e57, index):
    """The points of scan ``index`` in the file's frame, and how many were flagged invalid."""
    header = e57.get_header(index)
    total = header.point_count
    if total == 0:
        return np.empty((0, 3)), 0
    where = f"scan {index}"
    if header.has_pose():
        _check_pose(header, where)
    try:
        data = e57.read_scan(index, transform=True, ignore_missing_fields=True)
    except ValueError as exc:  # pye57's words for a scan without the coordinates it reads
        raise _BadFile(f"{where}: {str(exc).splitlines()[0]}") from None
    except Exception as exc:  # noqa: BLE001 - pye57 raises a bare Exception for unknown coordinates
        if type(exc) is not Exception:
            raise
        raise _BadFile(f"{where}: no cartesian or spherical coordinates in its points") from None
    points = np.column_stack([np.asarray(data[axis], dtype=np.float64)
                              for axis in ("cartesianX", "cartesianY", "cartesianZ")])
    # read_scan leaves out the points flagged invalid; what it left out is the difference.
    return points, total - len(points)


def _check_pose(header, where):
    """Refuse a pose that would move the points by garbage: a non-finite or non-unit rotation, a
    non-finite translation."""
    rotation = np.asarray(header.rotation, dtype=np.float64)
    translation = np.asarray(header.translation, dtype=np.float64)
    norm = float(np.sqrt(np.sum(rotation * rotation))) if np.all(np.isfinite(rotation)) else math.nan
    if not (math.isfinite(norm) and abs(norm - 1.0) <= _UNIT_QUATERNION_TOLERANCE):
        raise _BadFile(f"{where}: the pose's rotation is not a unit quaternion "
                       f"({', '.join(f'{value:g}' for value in rotation)})")
    if translation.shape != (3,) or not np.all(np.isfinite(translation)):
        raise _BadFile(f"{where}: the pose's translation is not 3 finite numbers")


def out_of_range(scan, count):
    """The message for scan ``scan`` of a file of ``count`` scans (``count`` >= 1)."""
    scans = "1 scan (scan 0)" if count == 1 else f"{count} scans (0 to {count - 1})"
    return f"scan {scan} is out of range: the file has {scans}"


def _e57_problem(exc) -> str:
    """libE57's message without its debug lines: ``checksum mismatch, file is corrupted``."""
    first = (str(exc).strip().splitlines() or [type(exc).__name__])[0]
    # "size in file header not same as actual (ErrorBadFileLength)": the code adds nothing for a user
    if first.endswith(")") and " (Error" in first:
        first = first[: first.rindex(" (Error")]
    return first.strip().rstrip(".") or type(exc).__name__

