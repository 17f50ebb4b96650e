"""Which side of the surface the sensor saw.

Every step after the plane reads heights along its normal: points beyond the surface band on the
sensor's side stand up from the surface (a boss, outliers), points on the other side lie in a hole
(a countersink's cone, a bore wall, a floor seen through it). holecli reports normals with a positive
z (:func:`holecli.geometry.kernels.orient_normal`), which is the sensor's side only when the file's
frame has the sensor on +z: a part scanned upside down in a robot's frame, or a face inclined away
from +z, would read its floors and cones as bosses.

The side is taken, in this order, from:

1. ``--view-dir`` (the direction the sensor looks, from the sensor toward the part): the sensor is
   on the side of ``-view_dir``;
2. the data: points *seen through* the surface. A single view cannot see both a surface and a point
   straight behind it along the normal, unless that point was seen through an opening at a slant (a
   floor or a bore seen through a hole on an inclined or fan view). Seen from the other side, the same
   point would stand in front of a surface that is still seen: possible only for an overhang, never
   for a boss or a raised face, whose points lie over their own footprint. So the off-surface points
   that lie over the *inside* of the scanned surface (surrounded by its points, :data:`MAX_GAP_DEG`,
   so that the walls of holes and bosses, which lie on their outlines, do not count) are behind it; when they are many (:data:`MIN_POINTS`) and nearly all on one side
   (the other side at most :data:`MAX_OTHER` of them), that side is away from the sensor;
3. else the convention (the sensor on the side of the z-positive normal), as before, and the
   detection says so (:attr:`Facing.source` ``"convention"``).

A straight view of a through hole, or of a floor behind a hole seen square on with parallel rays,
shows nothing behind the surface's material: then the data cannot tell (a floor seen square on is the
mirror image of a boss) and the convention stands.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

# A point counts as over the surface's material when the surface points within one grid cell of it
# leave no angular gap wider than this (degrees): a bore wall's or a boss's side wall's points lie on
# their outline, with the surface on one side only (a gap of about 180 degrees, 176 on the outline
# of a hole of 20 cells' radius); a floor seen through a hole at a slant, under the material, is
# surrounded.
MAX_GAP_DEG = 120.0
# Only points farther from the plane than this many bands plus DEPTH_SPACINGS point spacings count:
# the surface's own noise and its mixed edge points stay within about one band.
DEPTH_BANDS = 2.0
DEPTH_SPACINGS = 2.0
# The data decide only with at least this many points seen through the surface ...
MIN_POINTS = 20
# ... and at most this fraction of that count on the other side (outliers, an overhang).
MAX_OTHER = 0.2


@dataclass(frozen=True)
class Facing:
    """The sensor's side of the surface.

    Attributes
    ----------
    sign : int
        +1: the sensor is on the side the z-positive plane normal points to; -1: on the other side.
    source : str
        ``"view_dir"``, ``"data"`` or ``"convention"`` (the data could not tell: the z-positive side).
    behind : int
        Off-surface points over the surface's material on the side away from the sensor.
    front : int
        ... on the sensor's side.
    conflict : bool
        ``--view-dir`` was given and the data say the other side (its sign reversed?).
    """

    sign: int
    source: str
    behind: int
    front: int
    conflict: bool = False


def seen_through(heights, xy, surface, grid, band, spacing):
    """Off-surface points lying over the inside of the scanned surface, below and above it.

    A point counts when it lies in a material cell of the occupancy grid, farther from the plane than
    :data:`DEPTH_BANDS` bands plus :data:`DEPTH_SPACINGS` spacings, and the surface points within
    one grid cell of it (in the plane) surround it: no angular gap between them wider than
    :data:`MAX_GAP_DEG`. A bore wall or a boss's side wall lies on its outline, with the surface on
    one side only (a gap of about 180 degrees).

    Parameters
    ----------
    heights : (n,) float
        Signed distance of every point from the plane (along the z-positive normal).
    xy : (n, 2) float
        The points in the plane frame.
    surface : (n,) bool
        The plane's inliers.
    grid : holecli.robust.candidates.Grid
        The occupancy grid of the surface points.
    band : float
        Largest |height| of a surface point.
    spacing : float
        The surface's point spacing.

    Returns
    -------
    (int, int)
        Points below (negative heights) and above.
    """
    from scipy.spatial import cKDTree

    depth = DEPTH_BANDS * band + DEPTH_SPACINGS * spacing
    index = np.flatnonzero(~surface & (np.abs(heights) > depth))
    index = index[grid.lookup(grid.material, xy[index])]
    if len(index) == 0:
        return 0, 0
    reach = grid.cell
    low, high = xy[index].min(axis=0) - reach, xy[index].max(axis=0) + reach
    near = np.flatnonzero(surface)
    near_xy = xy[near]
    near_xy = near_xy[np.all((near_xy >= low) & (near_xy <= high), axis=1)]
    tree = cKDTree(near_xy)
    surrounded = np.zeros(len(index), dtype=bool)
    for k, neighbours in enumerate(tree.query_ball_point(xy[index], reach)):
        if len(neighbours) < 3:
            continue
        offsets = near_xy[neighbours] - xy[index[k]]
        angles = np.sort(np.arctan2(offsets[:, 1], offsets[:, 0]))
        gaps = np.diff(np.concatenate([angles, angles[:1] + 2.0 * np.pi]))
        surrounded[k] = np.degrees(float(gaps.max())) < MAX_GAP_DEG
    over = index[surrounded]
    below = int(np.count_nonzero(heights[over] < 0))
    return below, len(over) - below


def decide(normal, view_dir, below, above):
    """The :class:`Facing` of a surface whose z-positive normal is ``normal``, from ``view_dir``
    (None: not given) and the counts of :func:`seen_through`."""
    if max(below, above) >= MIN_POINTS and min(below, above) <= MAX_OTHER * max(below, above):
        data = 1 if below > above else -1  # the points seen through lie away from the sensor
    else:
        data = None
    if view_dir is not None:
        sign = -1 if float(np.asarray(normal) @ np.asarray(view_dir, dtype=np.float64)) > 0 else 1
        source = "view_dir"
    elif data is not None:
        sign, source = data, "data"
    else:
        sign, source = 1, "convention"
    behind, front = (below, above) if sign > 0 else (above, below)
    return Facing(sign=sign, source=source, behind=behind, front=front,
                  conflict=data is not None and data != sign)
