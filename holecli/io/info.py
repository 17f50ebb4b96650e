"""What a point-cloud file holds, for a first look (``holecli info``): counts, extent, spacing, unit.

:func:`describe_cloud` is pure (a :class:`holecli.io.Cloud` in, a dict out); :func:`file_fields` reads
the names a file's header gives its values (PLY properties, PCD fields, LAS dimensions, a text
table's header); :func:`guess_unit` is the rule that guesses the unit from the scale.

The guess of the unit (:func:`guess_unit`) assumes a scan of a drilled part: a part some 0.5 mm to
20 m across (its largest dimension, ``E``), scanned at 2 µm to 5 mm between points (the median
distance from a point to its nearest neighbour, ``s``). In millimetres that is ``0.002 <= s <= 5`` and
``0.5 <= E <= 20000``; in metres ``2e-6 <= s <= 0.005`` and ``0.0005 <= E <= 20``. A scan that fits
one of the two is guessed in it; one that fits both (``s`` between 0.002 and 0.005, ``E`` between 0.5
and 20) or neither gets no guess. Inches are never guessed: their scale is that of millimetres.
It is a guess, never used as the file's unit: give ``--units``.
"""

from __future__ import annotations

import os
from typing import Optional

import numpy as np

__all__ = ["SPACING_SAMPLE", "describe_cloud", "file_fields", "guess_unit", "point_spacing"]

# Points whose nearest neighbour is looked for (a random sample, seeded): enough for a median to
# a percent or so, fast on a cloud of millions.
SPACING_SAMPLE = 2000

# (unit, spacing range, largest-dimension range) of the guess, see the module docstring.
_SCALES = (
    ("mm", (0.002, 5.0), (0.5, 20000.0)),
    ("m", (2e-6, 0.005), (0.0005, 20.0)),
)
_UNIT_WORDS = {"mm": "millimetres", "m": "metres"}


def point_spacing(points: np.ndarray, sample: int = SPACING_SAMPLE, seed: int = 0) -> Optional[float]:
    """The median distance from a point to its nearest other point, over a random sample of points.

    Parameters
    ----------
    points : (n, 3) float ndarray
        Finite points.
    sample : int
        The most points whose neighbour is looked for (all of them when there are fewer).
    seed : int
        Seed of the sample.

    Returns
    -------
    float or None
        The median of the nonzero distances (repeated points left out); None when there are fewer
        than 2 distinct points.

    Examples
    --------
    >>> import numpy as np
    >>> grid = np.array([[x, y, 0.0] for x in range(10) for y in range(10)]) * 0.5
    >>> point_spacing(grid)
    0.5
    """
    from scipy.spatial import cKDTree

    if len(points) < 2:
        return None
    rng = np.random.default_rng(seed)
    chosen = points if len(points) <= sample else points[rng.choice(len(points), sample, replace=False)]
    distances, _ = cKDTree(points).query(chosen, k=2)
    nearest = distances[:, 1]
    nearest = nearest[nearest > 0]
    return float(np.median(nearest)) if len(nearest) else None


def guess_unit(spacing: Optional[float], largest: float):
    """A guess of a scan's unit from its point spacing and largest dimension (module docstring).

    Parameters
    ----------
    spacing : float or None
        :func:`point_spacing`.
    largest : float
        The largest of the extents along x, y and z.

    Returns
    -------
    unit : {"mm", "m"} or None
        None: no guess.
    reason : str
        Why, in a sentence.

    Examples
    --------
    >>> guess_unit(0.09, 20.0)[0], guess_unit(9e-5, 0.02)[0], guess_unit(0.003, 2.0)[0]
    ('mm', 'm', None)
    """
    if spacing is None:
        return None, "no guess: fewer than 2 distinct points"
    fits = [unit for unit, (low_s, high_s), (low_e, high_e) in _SCALES
            if low_s <= spacing <= high_s and low_e <= largest <= high_e]
    scale = f"point spacing {spacing:.3g} and largest dimension {largest:.3g}"
    if len(fits) == 1:
        inches = " (or inches, which scale cannot tell from them)" if fits[0] == "mm" else ""
        return fits[0], f"a guess: {scale} are those of a part scanned in {_UNIT_WORDS[fits[0]]}{inches}"
    if fits:
        return None, f"no guess: {scale} fit a scan in millimetres and one in metres alike"
    return None, f"no guess: {scale} fit neither a scan in millimetres nor one in metres"


def describe_cloud(cloud, fields=None, input_format=None, units=None) -> dict:
    """What ``holecli info`` says of a cloud: counts, extent, dimensions, columns, spacing, units.

    Parameters
    ----------
    cloud : holecli.io.Cloud
        The points read (:func:`holecli.io.read_cloud`).
    fields : list of str, optional
        The names the file gives its values (:func:`file_fields`).
    input_format : str, optional
        The format the file was read in (``--input-format``; None: by its extension).
    units : {"mm", "m", "in"}, optional
        ``--units``: the file's unit as the user knows it.

    Returns
    -------
    dict
        ``file``, ``format``, ``points`` (``total``, ``finite``, ``dropped``), ``extent`` (``min``,
        ``max``: x, y, z), ``dimensions`` (max - min), ``columns`` (a text table's
        ``input_columns``, else None), ``fields``, ``point_spacing`` (:func:`point_spacing`) and
        ``units`` (``declared``, ``declared_by``: ``"--units"``, ``"header"``, ``"format"`` or
        None; ``guess`` and ``guess_reason``: :func:`guess_unit`). Lengths in the file's unit.
    """
    points = cloud.points
    low, high = points.min(axis=0), points.max(axis=0)
    dimensions = high - low
    spacing = point_spacing(points)
    guess, reason = guess_unit(spacing, float(dimensions.max()))
    if units is not None:
        declared, by = units, "--units"
    elif cloud.units is not None:
        declared, by = cloud.units, "header" if cloud.columns is not None else "format"
    else:
        declared, by = None, None
    if declared is not None and guess is not None and declared != guess:
        reason += f"; the declared unit is {declared}: is it the file's?"
    fmt = input_format or os.path.splitext(str(cloud.path))[1].lower().lstrip(".") or None
    return {
        "file": str(cloud.path),
        "format": fmt,
        "points": {"total": len(points) + cloud.dropped, "finite": len(points), "dropped": cloud.dropped},
        "extent": {"min": low.tolist(), "max": high.tolist()},
        "dimensions": dimensions.tolist(),
        "columns": None if cloud.columns is None else cloud.columns.to_dict(),
        "fields": None if fields is None else list(fields),
        "point_spacing": spacing,
        "units": {"declared": declared, "declared_by": by, "guess": guess, "guess_reason": reason},
    }


def file_fields(path, extension, columns=None):
    """The names a file gives its values, from its header; None when it gives none or they cannot be read.

    Parameters
    ----------
    path : str
        A file :func:`holecli.io.read_cloud` has read.
    extension : str
        Its format as an extension (``".ply"``, ...).
    columns : holecli.io.text.TableColumns, optional
        A text table's columns: its header.

    Returns
    -------
    list of str or None
        PLY: the vertex element's properties; PCD: the fields as written; LAS/LAZ: the point
        format's dimensions (laspy); text: the header; E57 and a table without a header: None.
    """
    from holecli.io._common import _MAX_HEADER_BYTES, _BadFile

    try:
        if extension in (".csv", ".txt", ".xyz"):
            return None if columns is None or columns.header is None else list(columns.header)
        if extension in (".ply", ".pcd"):
            with open(path, "rb") as stream:
                head = stream.read(_MAX_HEADER_BYTES)
            if extension == ".ply":
                from holecli.io.ply import _read_ply_header

                vertex = [element for element in _read_ply_header(head).elements if element.name == "vertex"]
                return [prop.name for prop in vertex[0].properties] if vertex else None
            from holecli.io.pcd import _read_pcd_header

            return list(_read_pcd_header(head).original_fields)
    except (_BadFile, OSError, ValueError, IndexError):
        return None
    if extension in (".las", ".laz"):
        try:
            import laspy

            with laspy.open(path) as reader:
                return list(reader.header.point_format.dimension_names)
        except Exception:  # noqa: BLE001 - the file was read; its names are a nicety
            return None
    return None
