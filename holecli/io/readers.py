"""Each format's reader and writer behind one signature, as :data:`holecli.io.formats.FORMATS` names them.

A reader is called ``read(path, scan, columns)`` after the checks every file goes through
(:func:`holecli.io.cloud.read_cloud`) and returns ``(rows, flagged, units, columns)``: every
coordinate row, non-finite ones included, as (n, 3) float64; the points the file flags invalid; the
unit the format declares (or None); the columns read of a text table (or None). A writer is called
``encode(points, float32, extension)`` and returns the file's bytes. Each format's module is imported
when a file of that format is read or written (E57 and LAS with their optional libraries): a one-shot
``holecli detect`` of a PLY imports neither the PCD nor the text tables' reader.
"""

from __future__ import annotations

import numpy as np

from holecli.io import ply
from holecli.io._common import _BadFile

# The first bytes the E57 and LAS readers check their signature in.
_SIGNATURE_BYTES = 8


def read_ply(path, scan=None, columns=None):
    """A PLY file's rows (see the module's docstring)."""
    return ply.read_ply(path, _whole(path)), 0, None, None


def read_pcd(path, scan=None, columns=None):
    """A PCD file's rows (see the module's docstring)."""
    from holecli.io import pcd

    return pcd.read_pcd(path, _whole(path)), 0, None, None


def read_table(path, scan=None, columns=None):
    """A CSV, TXT or XYZ table's rows, in the columns ``columns`` or those found (see the module's docstring)."""
    from holecli.io import text

    points, read = text.read_table_columns(path, columns)
    return points, 0, read.unit, read


def read_e57(path, scan=None, columns=None):
    """An E57 file's rows, scan ``scan`` or every scan moved by its pose (see the module's docstring)."""
    from holecli.io.e57 import E57_UNITS, read_e57 as read

    points, flagged = read(path, _head(path), scan)
    return points, flagged, E57_UNITS, None


def read_las(path, scan=None, columns=None):
    """A LAS or LAZ file's rows (see the module's docstring)."""
    from holecli.io.las import read_las as read

    return read(path, _head(path)), 0, None, None


def encode_ply(points, float32, extension=".ply"):
    """``points`` as a binary_little_endian PLY file."""
    return ply.encode_ply(points, float32)


def encode_pcd(points, float32, extension=".pcd"):
    """``points`` as a ``DATA binary`` PCD file."""
    from holecli.io import pcd

    return pcd.encode_pcd(points, float32)


def encode_table(points, float32, extension):
    """``points`` as a text table: ``.csv`` with an ``x,y,z`` header, ``.txt`` and ``.xyz`` without."""
    from holecli.io import text

    return text.encode_table(points.astype(np.float32) if float32 else points, header=extension == ".csv")


def _whole(path):
    """The bytes of a PLY or PCD file, refused when there is nothing but white space."""
    with open(path, "rb") as stream:
        data = stream.read()
    if data.isspace():
        raise _BadFile("empty file")
    return data


def _head(path):
    with open(path, "rb") as stream:
        return stream.read(_SIGNATURE_BYTES)
