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

import math

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

# The fan cue (fan_side): a fan's rays diverge, so its point spacing on a face grows with the range
# (angular step x range / cos(incidence)). Off-surface points seen through the surface (farther)
# are sparser than the surface around them, a boss's top (nearer) denser; parallel rays give the
# same spacing at any range. Only clusters of at least FAN_MIN_POINTS points count (a median of
# fewer nearest-neighbour distances scatters too much; outliers and mixed edge points come alone)
FAN_MIN_POINTS = 100
# ... of points whose own face (the principal plane of FAN_NORMAL_NEIGHBOURS neighbours) is within
# FAN_MAX_SLOPE_DEG of the surface: a bore's or a boss's side wall, projected onto the plane, folds
# to a line and would look dense wherever it lies (its incidence, not its range, sets its spacing).
FAN_NORMAL_NEIGHBOURS = 8
FAN_MAX_SLOPE_DEG = 30.0
# A cluster votes only when its own principal plane (over all its points) is within this of the
# surface: the per-point test above keeps the flattest strip of a wide countersink's cone (110 deg
# included, 35 deg from the surface, drilled 5 deg off: 30 deg), whose spacing its incidence sets
# (measured 6 % denser on a 10 deg view, which named the wrong side). Floors and bosses' tops lie
# within the drilling angle (measured 0-5 deg on benchmarks/features.py's scenes), cones' strips 26-30.
FAN_MAX_FACE_SLOPE_DEG = 10.0
# The ring of surface points within this many spacings of a cluster is its reference.
FAN_RING_SPACINGS = 10.0
# A cluster votes only when its spacing differs from its ring's by this factor: a face 4 mm behind at
# a 100 mm standoff. A face within FAN_MAX_SLOPE_DEG of the surface but not parallel to it changes
# its spacing through its incidence alone by a few percent (measured 1.2 % on the validation suite's
# angle part, the second face of the angle; the smallest real vote there: 6.2 %, a counterbore's
# floor 6 mm down); a boss 1-3 mm in front (1-3 %) does not vote: undecided, the convention stands.
FAN_RATIO = 1.04
# The cue reads a spacing that the scanner's geometry sets, so it needs a regular sampling: a lattice
# (a profiler's lines and points, noisy or not) has nearest-neighbour distances that hardly spread
# (robust coefficient of variation near 0), random sampling (a CAD mesh sampled evenly, synthetic
# random clouds) spreads them by about half their median (a Poisson pattern: 0.5), and two random
# clusters' medians then differ by chance. A cluster or ring spread more than this does not vote.
FAN_MAX_SPREAD = 0.2


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
    cue : str
        With ``source == "data"``: ``"seen_through"`` (:func:`seen_through`) or ``"fan_spacing"``
        (:func:`fan_side`), else ``""``.
    """

    sign: int
    source: str
    behind: int
    front: int
    conflict: bool = False
    cue: str = ""


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
    near_xy = xy[surface & _in_box(xy, low, high)]
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


def decide(normal, view_dir, below, above, fan=None):
    """The :class:`Facing` of a surface whose z-positive normal is ``normal``, from ``view_dir``
    (None: not given), the counts of :func:`seen_through` and, when those do not decide, ``fan``
    (:func:`fan_side`'s sign or None)."""
    cue = ""
    if max(below, above) >= MIN_POINTS and min(below, above) <= MAX_OTHER * max(below, above):
        data = 1 if below > above else -1  # the points seen through lie away from the sensor
        cue = "seen_through"
    else:
        data = fan
        cue = "" if fan is None else "fan_spacing"
    if view_dir is not None:
        sign = -1 if float(np.asarray(normal) @ np.asarray(view_dir, dtype=np.float64)) > 0 else 1
        source = "view_dir"
    elif data is not None:
        sign, source = data, "data"
    else:
        sign, source = 1, "convention"
    behind, front = (below, above) if sign > 0 else (above, below)
    return Facing(sign=sign, source=source, behind=behind, front=front,
                  conflict=data is not None and data != sign, cue=cue if source == "data" else "")


def fan_spacing(xy, heights, surface, band, spacing, reach):
    """Per cluster of off-surface points on faces near parallel to the surface: the ratio of its
    median nearest-neighbour spacing (in the plane) to that of the surface points in a ring around it
    (:data:`FAN_RING_SPACINGS`), and its median height.

    The spacing is read in the plane frame: on a face parallel to the surface, the fan's spacing along
    the line is angular step x range / cos(incidence), with the same incidence as the surface around
    it, so the ratio is the ratio of ranges; faces steeper than :data:`FAN_MAX_SLOPE_DEG` (walls),
    whose incidence dominates, are left out, and so are clusters whose own plane is steeper than
    :data:`FAN_MAX_FACE_SLOPE_DEG` (a countersink cone's flattest strip). ``reach`` links points into
    clusters (a grid cell).

    Returns
    -------
    list of (ratio, height, points, ring points)
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    depth = DEPTH_BANDS * band + DEPTH_SPACINGS * spacing
    index = np.flatnonzero(~surface & (np.abs(heights) > depth))
    if len(index) < FAN_MIN_POINTS:
        return []
    local = np.column_stack([xy[index], heights[index]])
    tree = cKDTree(local)
    # Faces parallel to the surface only (a floor, a boss's top): see FAN_MAX_SLOPE_DEG.
    k = min(FAN_NORMAL_NEIGHBOURS, len(index))
    _, neighbours = tree.query(local, k)
    patches = local[neighbours] - local[neighbours].mean(axis=1, keepdims=True)
    _, vectors = np.linalg.eigh(np.einsum("nki,nkj->nij", patches, patches))
    flat = np.abs(vectors[:, 2, 0]) > np.cos(np.radians(FAN_MAX_SLOPE_DEG))
    index, local = index[flat], local[flat]
    if len(index) < FAN_MIN_POINTS:
        return []
    pairs = cKDTree(local).query_pairs(reach, output_type="ndarray")
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(len(index), len(index)))
    count, labels = connected_components(graph, directed=False)
    surface_xy = None  # (taken when a cluster gets that far)
    ring_reach = FAN_RING_SPACINGS * spacing
    out = []
    for label in range(count):
        members = np.flatnonzero(labels == label)
        if len(members) < FAN_MIN_POINTS or _slope_deg(local[members]) > FAN_MAX_FACE_SLOPE_DEG:
            continue
        cluster_xy = xy[index[members]]
        cluster_tree = cKDTree(cluster_xy)
        distances, _ = cluster_tree.query(cluster_xy, 2)
        inner = float(np.median(distances[:, 1]))
        if _spread(distances[:, 1]) > FAN_MAX_SPREAD:
            continue
        if surface_xy is None:
            surface_xy = xy[surface]
        low, high = cluster_xy.min(axis=0) - ring_reach, cluster_xy.max(axis=0) + ring_reach
        # The surface points around the ring's box: a ring point's nearest neighbours among them are
        # its nearest among all the surface points whenever they lie within ring_reach (anything
        # outside lies over 1.5 ring_reach away), else they are looked up among all of them.
        around = np.flatnonzero(_in_box(surface_xy, low - 1.5 * ring_reach, high + 1.5 * ring_reach))
        around_xy = surface_xy[around]
        candidates = np.flatnonzero(_in_box(around_xy, low, high))
        to_cluster, _ = cluster_tree.query(around_xy[candidates], 1, distance_upper_bound=ring_reach)
        ring = candidates[np.isfinite(to_cluster)]
        if len(ring) < FAN_MIN_POINTS:
            continue
        ring_xy = around_xy[ring]
        distances, _ = cKDTree(around_xy).query(ring_xy, 2)
        far = np.flatnonzero(~(distances[:, 1] <= ring_reach))
        if len(far):
            distances[far] = cKDTree(surface_xy).query(ring_xy[far], 2)[0]
        outer = float(np.median(distances[:, 1]))
        if _spread(distances[:, 1]) > FAN_MAX_SPREAD:
            continue
        side = float(np.median(heights[index[members]]))
        out.append((inner / outer, side, len(members), len(ring)))
    return out


def _in_box(xy, low, high):
    """Whether each point of ``xy`` (n, 2) lies in the closed box ``[low, high]``."""
    return (xy[:, 0] >= low[0]) & (xy[:, 0] <= high[0]) & (xy[:, 1] >= low[1]) & (xy[:, 1] <= high[1])


def _slope_deg(points):
    """Angle (degrees) between the principal plane of ``points`` (m, 3: plane-frame x, y, height) and
    the surface."""
    centred = points - points.mean(axis=0)
    _, vectors = np.linalg.eigh(centred.T @ centred)
    return math.degrees(math.acos(min(1.0, abs(float(vectors[2, 0])))))


def _spread(distances):
    """Robust coefficient of variation of nearest-neighbour distances (1.4826 MAD / median)."""
    median = float(np.median(distances))
    if not median > 0:
        return math.inf
    return 1.4826 * float(np.median(np.abs(distances - median))) / median


def fan_side(clusters):
    """The sensor's side from :func:`fan_spacing`'s clusters: +1 (the z-positive side), -1, or None.

    A cluster sparser than its ring by :data:`FAN_RATIO` lies farther from the sensor than the
    surface, a denser one nearer; the side is decided only when at least one cluster votes and every
    voting cluster says the same side."""
    votes = set()
    for ratio, height, _, _ in clusters:
        if ratio > FAN_RATIO:
            votes.add(1 if height < 0 else -1)    # farther: on the side away from the sensor
        elif ratio < 1.0 / FAN_RATIO:
            votes.add(1 if height > 0 else -1)    # nearer: on the sensor's side
    return votes.pop() if len(votes) == 1 else None
