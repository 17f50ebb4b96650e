"""LAS and LAZ reading (ASPRS LAS 1.0 to 1.4; LAZ is LAS compressed), through the optional ``laspy``.

A LAS point stores x, y, z as 32-bit integers; the header's scales and offsets make them
coordinates (``x = X * x_scale + x_offset``), which laspy applies. LAZ needs a decompression backend
(``lazrs``, which the ``las`` extra installs, or ``laszip``).

What is refused, never measured: a file without the ``LASF`` signature, a header laspy cannot read,
scales that are zero or not finite and offsets that are not finite, fewer points than the header
announces (a file cut short), and, in an uncompressed file without extended VLRs, bytes after the
points the header announces (the sign of a count that is not the file's). A LAZ stream that does
not decompress is refused by the backend. A damaged byte inside an uncompressed point cannot be
seen (LAS has no checksum), as in a binary PLY.

``laspy`` is imported only here, when a LAS or LAZ file is read: a missing extra, or LAZ without a
backend, gives the one line ``reading .las needs the optional extra: pip install 'holecli[las]'``.
"""

from __future__ import annotations

import contextlib
import logging
import os

import numpy as np

from holecli.io._common import _BadFile, _describe, _need_extra

LAS_SIGNATURE = b"LASF"


def read_las(name: str, data_head: bytes) -> np.ndarray:
    """The points of a LAS or LAZ file, scaled and offset into coordinates.

    Parameters
    ----------
    name : str
        The file.
    data_head : bytes
        Its first bytes (at least 4, when the file is that long), to check the signature.

    Returns
    -------
    points : (n, 3) float64 ndarray
        x, y, z of every point, in file order.

    Raises
    ------
    _BadFile
        For a file that is not LAS, a damaged or truncated one, or laspy (or a LAZ backend) missing.
    """
    extension = os.path.splitext(name)[1].lower()
    if not data_head.startswith(LAS_SIGNATURE):
        raise _BadFile("not a LAS file (it does not start with the signature 'LASF')")
    try:
        import laspy
    except ImportError:
        raise _need_extra(extension, "las") from None
    with _quiet(), open(name, "rb") as stream:
        try:
            reader = laspy.LasReader(stream, closefd=False)
        except laspy.errors.LaspyException as exc:
            raise _BadFile(f"malformed LAS header ({_describe(exc)})") from None
        header = reader.header
        _check_header(header)
        count = int(header.point_count)
        if header.are_points_compressed and not laspy.LazBackend.detect_available():
            raise _need_extra(extension, "las")
        if not header.are_points_compressed:
            _check_uncompressed_size(header, os.fstat(stream.fileno()).st_size)
        if count == 0:
            return np.empty((0, 3))
        try:
            points = reader.read_points(-1)
        except (laspy.errors.LaspyException, ValueError, OSError) as exc:
            raise _BadFile(f"damaged LAS point data ({_describe(exc)})") from None
        except Exception as exc:  # noqa: BLE001 - lazrs and laszip raise errors of their own
            if type(exc).__module__.split(".")[0] not in ("lazrs", "laszip"):
                raise
            raise _BadFile(f"damaged LAZ point data ({_describe(exc)})") from None
        if len(points) != count:
            raise _BadFile(f"truncated LAS: the header announces {count} points but only {len(points)} are there")
        return np.column_stack([np.asarray(points.x, dtype=np.float64), np.asarray(points.y, dtype=np.float64),
                                np.asarray(points.z, dtype=np.float64)])


def _check_header(header):
    scales = np.asarray(header.scales, dtype=np.float64)
    offsets = np.asarray(header.offsets, dtype=np.float64)
    if not (np.all(np.isfinite(scales)) and np.all(scales != 0)):
        raise _BadFile(f"malformed LAS header: scales {', '.join(f'{v:g}' for v in scales)} (each must be a finite "
                       "non-zero number)")
    if not np.all(np.isfinite(offsets)):
        raise _BadFile("malformed LAS header: the offsets are not finite")


def _check_uncompressed_size(header, size):
    record = header.point_format.size
    end = header.offset_to_point_data + header.point_count * record
    count = header.point_count
    if size < end:
        whole = max(0, (size - header.offset_to_point_data) // record)
        raise _BadFile(f"truncated LAS: the header announces {count} points but only {whole} are there")
    extended = header.version.minor >= 4 and header.number_of_evlrs > 0
    waveform = bool(getattr(header, "start_of_waveform_data_packet_record", 0))
    if size > end and not extended and not waveform:
        raise _BadFile(f"malformed LAS: {size - end} bytes after the {count} points the header announces")


@contextlib.contextmanager
def _quiet():
    """laspy logs a short read as an error: with no logging set up, Python would print it on stderr.
    The reader reports the problem itself, so laspy's logger is silenced while it reads."""
    logger = logging.getLogger("laspy")  # the parent of laspy.lasreader, whose level it inherits
    level = logger.level
    logger.setLevel(logging.CRITICAL + 1)
    try:
        yield
    finally:
        logger.setLevel(level)
