"""Writing a point cloud: :func:`save_points`, in the formats of :data:`WRITE_EXTENSIONS`."""

from __future__ import annotations

import os

import numpy as np

from holecli.io.formats import WRITE_EXTENSIONS, expected, format_of, writer
from holecli.io.outfile import write_bytes

__all__ = ["WRITE_EXTENSIONS", "save_points"]


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
        raise ValueError(f"cannot save {name!r}: unsupported extension {extension!r} "
                         f"(expected {expected(WRITE_EXTENSIONS)})")
    array = _as_points(points)
    write_bytes(name, writer(format_of(extension))(array, float32, extension))


def _as_points(points) -> np.ndarray:
    array = np.asarray(points)
    if array.dtype.kind not in "iuf":
        raise ValueError(f"points must be a numeric array, got dtype {array.dtype}")
    if array.ndim != 2 or array.shape[1] != 3:
        raise ValueError(f"points must have shape (n, 3), got {array.shape}")
    return np.ascontiguousarray(array, dtype=np.float64)
