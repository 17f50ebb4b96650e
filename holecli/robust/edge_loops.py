"""Holes of a cloud made of a CAD mesh's own vertices: the edge loops of the surface (issue 24, item 2).

A CAD kernel triangulates each face with no vertex inside it, so the cloud of an export's vertices
holds points only along the edges: each hole is a loop of N vertices on its edge circle in the top
face (a countersink's inner loop and the bore's bottom loop lie below it), the border is a chain of
corners, and no point lies inside a flat face. The regular method sees the faces as gaps (its
sampling estimate finds empty circles many spacings wide) and reports nothing. A sensor never
samples a surface this way: its points fill the faces.

This module measures such a cloud from the loops themselves (arrays in, results out):

1. the surface's points (the plane's inliers, in its frame) are linked to their two nearest
   neighbours; the links both ends agree on form the loops (closed chains, every vertex with two
   links): along a loop, neighbours are one chord apart;
2. a loop is a hole's edge when it passes every check of :data:`holecli.vocabulary.LOOP_CHECKS` (enough vertices, on one
   circle within the noise, alone on its circle, the face outside it, empty inside, no boss);
3. its diameter is the least-squares circle of the polygon's *sides* (the mean distance of the
   sides' points from the centre, integrated along each side): the surface the mesh describes, the
   same convention as :func:`holecli.simulation.cad_cloud.cad_truth`; for N vertices on a circle of
   diameter D it is ``D cos(pi/N) (a sqrt(1+a^2) + asinh a) / (2a)``, ``a = tan(pi/N)``;
4. the loops below it on its axis give the type: a smaller loop at a cone's angle (countersunk), a
   loop of its own radius and a smaller one on one floor (counterbored), else a bore of its radius.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from holecli.geometry.lsq import gauss_newton
from holecli.settings import DEFAULT_SETTINGS
from holecli.vocabulary import LOOP_CHECKS

#: The sampling estimate's gap (the largest empty circles of the faces) over its spacing above which
#: the surface is looked at for vertex loops. A sensor's sampling leaves gaps of 1-3 spacings (the
#: validation suite: at most 2.6, with lines five points apart); a vertex export's faces are tens of
#: spacings wide. Only a gate on the cost (a neighbour query of every surface point): the checks below
#: decide what a hole is.
GAP_RATIO = 4.0
#: ... or when the surface holds at most this many points (the search costs 16 ms on a 5,000-point grid, the worst case: every tie a loop).
SMALL_SURFACE = 5_000
#: Fewest vertices of a hole's edge loop (a CAD kernel tessellates a circle with 8 or more segments).
MIN_VERTICES = 8
#: A vertex lies on the loop's circle within this many height-noise sigmas (plus round-off).
ROUND_SIGMAS = 4.0
#: A loop is alone on its circle when no other surface point comes within this many of its chords.
ISOLATION_CHORDS = 1.5
#: Included angles (degrees) a countersink's cone may have between the edge loop and the smaller loop below.
CONE_ANGLES_DEG = (30.0, 150.0)

#: The checks applied, in this order (each has a test that needs it: tests/robust/test_edge_loops.py).
ACTIVE_CHECKS = tuple(LOOP_CHECKS)


@dataclass(frozen=True)
class Ring:
    """A loop of vertices below the edge on the hole's axis."""

    depth: float           # below the surface (along the normal, away from the sensor)
    center: np.ndarray     # (2,) plane frame
    diameter: float        # least-squares circle of the polygon's sides
    rms: float             # of the vertices about their circle
    points: int


@dataclass(frozen=True)
class EdgeLoop:
    """A hole's edge measured from its loop of vertices (plane frame)."""

    center: np.ndarray     # (2,)
    diameter: float        # least-squares circle of the polygon's sides
    vertex_diameter: float  # the circle through the vertices (the design circle of a CAD export)
    vertices: int
    rms: float             # radial rms of the vertices about their circle
    max_residual: float
    roundness: float       # circumradius - inradius of the polygon (max vertex radius - min side distance)
    u_center: float        # standard uncertainty per in-plane coordinate
    u_diameter: float
    height: float          # mean height of its vertices above the plane
    u_height: float
    type: str              # through, countersunk, counterbored
    rings: tuple = ()      # of Ring below it, shallowest first
    cone_angle_deg: Optional[float] = None
    counterbore_depth: Optional[float] = None
    bore: Optional[Ring] = None


@dataclass(frozen=True)
class LoopRejection:
    check: str             # a key of LOOP_CHECKS
    value: object
    limit: object
    center: np.ndarray
    radius: float


def faces_empty(spacing: float, gap: float) -> bool:
    """Whether the sampling estimate (``spacing``, ``gap``) leaves the faces empty (:data:`GAP_RATIO`)."""
    return bool(np.isfinite(gap) and spacing > 0 and gap >= GAP_RATIO * spacing)


def looks_like_vertices(spacing: float, gap: float, surface_points: int) -> bool:
    """Whether to look for vertex loops: the faces are empty (:func:`faces_empty`), or the surface is
    small enough for the search to cost nothing (:data:`SMALL_SURFACE`: a part of a few coarse loops
    leaves smaller gaps)."""
    return bool(surface_points <= SMALL_SURFACE or faces_empty(spacing, gap))


def coordinate_step(points, sample=10_000) -> float:
    """The round-off step of the cloud's coordinates: an ulp of its largest coordinate, of float32 when
    every (sampled) coordinate is a float32 (an STL's, a float32 PLY's), else of float64."""
    points = np.asarray(points)
    if not len(points):
        return 0.0
    largest = float(np.max(np.abs(points)))
    rows = points[:: max(1, len(points) // sample)]
    single = points.dtype == np.float32 or bool(np.all(rows.astype(np.float32).astype(rows.dtype) == rows))
    return float(np.spacing(np.float32(largest)) if single else np.spacing(largest))


def _circle_fit(xy):
    """Geometric least-squares circle (algebraic start, :func:`holecli.geometry.lsq.gauss_newton` on the
    centre, the radius the mean distance to it): centre (2,), radius."""
    mean = xy.mean(axis=0)
    q = xy - mean
    a = np.column_stack([2 * q, np.ones(len(q))])
    sol, *_ = np.linalg.lstsq(a, (q ** 2).sum(axis=1), rcond=None)

    def distances(c):
        d = q - c
        return np.hypot(d[:, 0], d[:, 1])

    def residuals(c):
        rho = distances(c)
        return rho - rho.mean()

    def jacobian(c, f):
        d = q - c
        j = -d / np.maximum(np.hypot(d[:, 0], d[:, 1]), 1e-300)[:, None]
        return j - j.mean(axis=0)

    def converged(c, step):
        return np.hypot(*step) <= 1e-15 * max(distances(c).mean(), 1e-300)

    c = gauss_newton(residuals, sol[:2], jacobian, iterations=20, converged=converged)
    return c + mean, float(distances(c).mean())


def sides_diameter(ordered, center) -> float:
    """Twice the mean distance from ``center`` of the points of the closed polygon ``ordered`` (m, 2),
    integrated exactly along each side (the least-squares circle of the sides about that centre)."""
    a = ordered - center
    b = np.roll(ordered, -1, axis=0) - center
    side = b - a
    length = np.hypot(side[:, 0], side[:, 1])
    ok = length > 0
    a, side, length = a[ok], side[ok], length[ok]
    t_dir = side / length[:, None]
    ta = np.einsum("ij,ij->i", a, t_dir)
    tb = ta + length
    h = np.abs(a[:, 0] * t_dir[:, 1] - a[:, 1] * t_dir[:, 0])
    h = np.maximum(h, 1e-300)

    def primitive(t):  # integral of sqrt(h^2 + t^2) dt
        return 0.5 * (t * np.sqrt(h * h + t * t) + h * h * np.arcsinh(t / h))

    return float(2.0 * np.sum(primitive(tb) - primitive(ta)) / np.sum(length))


def _loops(xy):
    """The closed chains of the mutual two-nearest-neighbour links of ``xy`` with at least
    :data:`MIN_VERTICES` vertices: arrays of indices in order along each chain."""
    n = len(xy)
    if n < MIN_VERTICES:
        return []
    _, index = cKDTree(xy).query(xy, k=3)
    src = np.repeat(np.arange(n), 2)
    dst = index[:, 1:].reshape(-1)
    low, high = np.minimum(src, dst).astype(np.int64), np.maximum(src, dst).astype(np.int64)
    keys, counts = np.unique(low * n + high, return_counts=True)
    keys = keys[counts == 2]  # both ends name each other
    links = np.column_stack([keys // n, keys % n])
    if not len(links):
        return []
    degree = np.bincount(links.reshape(-1), minlength=n)
    graph = coo_matrix((np.ones(len(links)), (links[:, 0], links[:, 1])), shape=(n, n))
    count, label = connected_components(graph, directed=False)
    sizes = np.bincount(label, minlength=count)
    good = sizes >= MIN_VERTICES
    good[np.unique(label[degree != 2])] = False  # a chain with an end or a branch is no loop
    if not good.any():
        return []
    # The two neighbours of every vertex of degree 2.
    ends = np.concatenate([links[:, 0], links[:, 1]])
    others = np.concatenate([links[:, 1], links[:, 0]])
    order = np.argsort(ends, kind="stable")
    ends, others = ends[order], others[order]
    first = np.searchsorted(ends, np.arange(n))
    loops = []
    for comp in np.flatnonzero(good):
        start = int(np.flatnonzero(label == comp)[0])
        chain, previous, current = [start], -1, start
        while True:
            a, b = others[first[current]], others[first[current] + 1]
            nxt = a if a != previous else b
            if nxt == start:
                break
            chain.append(int(nxt))
            previous, current = current, int(nxt)
        loops.append(np.asarray(chain))
    return loops


def top_face(xy, heights, noise, span_share=0.5):
    """The points of the face a sensor on the heights' positive side sees, in a cloud of vertices:
    of the levels of ``heights`` (parallel faces), those whose points span at least ``span_share`` of
    the largest span (convex hull area in the plane: the top and bottom of a part span all of it, a
    counterbore's floor or a boss's top a small part), the one nearest the sensor. A vertex export's
    faces hold their edges' vertices, not a number of points in proportion to their area, so the
    face holding the most points (a counterbore floor with its four loops) need not be the surface.
    Returns a boolean mask, or None when no level has three points off one line."""
    from scipy.spatial import ConvexHull, QhullError

    heights = np.asarray(heights, dtype=np.float64)
    order = np.argsort(heights)
    step = max(8.0 * noise, 1e-9)
    levels = np.split(order, np.flatnonzero(np.diff(heights[order]) > step) + 1)
    spans = []
    for level in levels:
        try:
            spans.append(ConvexHull(xy[level]).volume if len(level) >= 3 else 0.0)
        except QhullError:
            spans.append(0.0)
    if max(spans) <= 0:
        return None
    wide = [level for level, span in zip(levels, spans) if span >= span_share * max(spans)]
    best = max(wide, key=lambda level: float(np.mean(heights[level])))
    mask = np.zeros(len(heights), bool)
    mask[best] = True
    return mask


def _angular_gap_deg(vectors):
    if len(vectors) == 0:
        return 360.0
    angles = np.sort(np.arctan2(vectors[:, 1], vectors[:, 0]))
    gaps = np.diff(np.concatenate([angles, angles[:1] + 2 * math.pi]))
    return float(math.degrees(gaps.max()))


def _rings_below(xy, depth, center, radius, tolerance):
    """Loops of vertices below the surface on the axis through ``center`` (within ``radius``):
    grouped by depth, then by radius; each covering its circle. Shallowest first."""
    d = xy - center
    rho = np.hypot(d[:, 0], d[:, 1])
    near = rho <= radius + 4 * tolerance
    if np.count_nonzero(near) < MIN_VERTICES:
        return ()
    xy, depth, rho = xy[near], depth[near], rho[near]
    step = max(10 * tolerance, 1e-3 * radius)
    rings = []
    order = np.argsort(depth)
    splits = np.flatnonzero(np.diff(depth[order]) > step) + 1
    for level in np.split(order, splits):
        by_radius = level[np.argsort(rho[level])]
        for group in np.split(by_radius, np.flatnonzero(np.diff(rho[by_radius]) > step) + 1):
            if len(group) < MIN_VERTICES or _angular_gap_deg(d[near][group]) > 360.0 / 4:
                continue
            pts = xy[group]
            c, r = _circle_fit(pts)
            ordered = pts[np.argsort(np.arctan2(pts[:, 1] - c[1], pts[:, 0] - c[0]))]
            residual = np.hypot(*(pts - c).T) - r
            rings.append(Ring(depth=float(np.mean(depth[group])), center=c, diameter=sides_diameter(ordered, c),
                              rms=float(np.sqrt(np.mean(residual ** 2))), points=len(group)))
    rings.sort(key=lambda ring: (ring.depth, -ring.diameter))
    return tuple(rings)


def _hole_type(edge_diameter, rings, tolerance):
    """(type, cone angle, counterbore depth, bore ring) from the rings below the edge."""
    if not rings:
        return "through", None, None, None
    level = [r for r in rings if abs(r.depth - rings[0].depth) <= max(10 * tolerance, 1e-3 * edge_diameter)]
    same = [r for r in level if abs(r.diameter - edge_diameter) <= max(8 * tolerance, 0.01 * edge_diameter)]
    smaller = [r for r in level if r.diameter < edge_diameter - max(8 * tolerance, 0.01 * edge_diameter)]
    if same and smaller:
        return "counterbored", None, rings[0].depth, max(smaller, key=lambda r: r.diameter)
    if smaller and not same:
        ring = max(smaller, key=lambda r: r.diameter)
        angle = 2.0 * math.degrees(math.atan2(0.5 * (edge_diameter - ring.diameter), ring.depth))
        if CONE_ANGLES_DEG[0] <= angle <= CONE_ANGLES_DEG[1]:
            return "countersunk", angle, None, ring
    return "through", None, None, (same[0] if same else None)


def edge_loops(xy, heights, surface, noise, *, min_diameter=None, resolution=0.0, step=0.0,
               settings=DEFAULT_SETTINGS):
    """The holes whose edge is a loop of the surface's vertices (see the module docstring).

    Parameters
    ----------
    xy : (n, 2) float
        Every point in the plane frame (the surface's slid along the view when one was given).
    heights : (n,) float
        Signed heights above the plane, toward the sensor.
    surface : (n,) bool
        The plane's inliers (the top face's vertices).
    noise : float
        Robust sigma of the surface's heights (> 0: at least the data's resolution).
    min_diameter : float or None
        Smaller edges are not reported.
    resolution : float
        The data's resolution (a floor of the uncertainties).
    step : float
        The round-off step of the input coordinates (:func:`coordinate_step`): a vertex lies on its
        circle to about one step (float32 vertices at 250 mm: 3e-5 mm).
    settings : holecli.settings.RobustSettings
        Source of ``pocket_max_depth_ratio``: a floor less than that many diameters deep is a
        pocket's.

    Returns
    -------
    (list of EdgeLoop, list of LoopRejection)
    """
    xy = np.asarray(xy, dtype=np.float64)
    heights = np.asarray(heights, dtype=np.float64)
    surface = np.asarray(surface, bool)
    if np.count_nonzero(surface) < MIN_VERTICES:
        return [], []
    extent = float(np.max(np.abs(xy[surface]))) + 1e-300
    roundoff = max(64 * np.finfo(np.float64).eps * extent, 2.0 * step)
    tolerance = ROUND_SIGMAS * noise + roundoff
    floor = max(resolution, roundoff) / math.sqrt(12.0)  # a rectangular distribution one step wide
    # The face: the plane's inliers and the vertices within the noise of their band (a robust plane
    # fit leaves out a few noisy vertices of a loop, which would break it).
    band = max(float(np.max(np.abs(heights[surface]))), tolerance) + tolerance
    surface = surface | (np.abs(heights) <= band)
    face = xy[surface]
    above = xy[heights > band]
    below = heights < -band
    below_xy, below_depth = xy[below], -heights[below]
    found, rejected = [], []
    for loop in _loops(face):
        pts = face[loop]
        center, radius = _circle_fit(pts)

        def reject(check, value=None, limit=None):
            rejected.append(LoopRejection(check, value, limit, center, radius))

        residual = np.hypot(*(pts - center).T) - radius
        worst = float(np.max(np.abs(residual)))
        chords = np.hypot(*(np.roll(pts, -1, axis=0) - pts).T)
        reach = ISOLATION_CHORDS * float(chords.max())
        wide = max(8 * tolerance, 0.01 * radius)
        cache = {}

        def rho_others():  # distances of the face's other points from the centre (computed once, when asked)
            if "rho" not in cache:
                other = np.ones(len(face), bool)
                other[loop] = False
                cache["rho"] = np.hypot(*(face[other] - center).T)
            return cache["rho"]

        def rings_all():
            if "rings" not in cache:
                cache["rings"] = _rings_below(below_xy, below_depth, center, 2.0 * radius, tolerance)
            return cache["rings"]

        def count(mask):
            return int(np.count_nonzero(mask))

        def wider():
            rings = [ring for ring in rings_all() if ring.diameter > 2.0 * radius + 2.0 * wide
                     and np.hypot(*(ring.center - center)) <= wide]
            return bool(rings), max((r.diameter for r in rings), default=None), 2.0 * radius

        def pocket():
            # The first ring below of the edge's own size: a floor when no other vertex lies at its depth
            # (a through hole's bottom loop lies on the bottom face, with the part's other bottom vertices).
            # A ring beside it on that floor or below it (a counterbore's bore, a groove's island) is no
            # pocket's: its floor is whole.
            limit = settings.pocket_max_depth_ratio
            axis = [ring for ring in rings_all() if np.hypot(*(ring.center - center)) <= wide]
            rings = [ring for ring in axis if abs(ring.diameter - 2.0 * radius) <= wide]
            if not rings:
                return False, None, limit
            ring = min(rings, key=lambda r: r.depth)
            same_level = 2.0 * tolerance + 1e-3 * radius  # (its own vertices lie within the noise of it)
            if any(other is not ring and other.depth >= ring.depth - same_level for other in axis):
                return False, None, limit
            level = np.abs(below_depth - ring.depth) <= same_level
            beyond = np.hypot(*(below_xy[level] - center).T) > radius + reach
            ratio = ring.depth / (2.0 * radius)
            return not beyond.any() and ratio < limit, ratio, limit

        # Each check: () -> (failed, value, limit), evaluated in ACTIVE_CHECKS' order (the cheap first).
        failed = {"loop_not_round": lambda: (worst > tolerance, worst, tolerance),
                  "loop_not_isolated": lambda: (count(np.abs(rho_others() - radius) <= reach) > 0,
                                                count(np.abs(rho_others() - radius) <= reach), 0),
                  "loop_no_face_outside": lambda: (count(rho_others() > radius + reach) == 0,
                                                   count(rho_others() > radius + reach), 1),
                  "loop_material_inside": lambda: (count(rho_others() < radius - reach) > 0,
                                                   count(rho_others() < radius - reach), 0),
                  "loop_boss": lambda: ((b := count(np.hypot(*(above - center).T) < radius + tolerance)
                                         if len(above) else 0) > 0, b, 0),
                  "loop_wider_below": wider,
                  "loop_pocket": pocket}
        check = None
        for name in ACTIVE_CHECKS:
            result = failed[name]()
            if result[0]:
                check = name
                reject(check, *result[1:])
                break
        if check is not None:
            continue
        rings = tuple(ring for ring in rings_all() if ring.diameter <= 2.0 * radius + 2.0 * wide)
        ordered = pts
        diameter = sides_diameter(ordered, center)
        if min_diameter is not None and diameter < min_diameter:
            continue
        rms = float(np.sqrt(np.mean(residual ** 2)))
        n = len(loop)
        # The vertices are the edge: the centre and the radius are known to their scatter about the
        # circle (sqrt(2/N) per coordinate, 1/sqrt(N) on the radius), never below the data's resolution.
        u_center = math.hypot(rms * math.sqrt(2.0 / n), floor)
        u_diameter = math.hypot(2.0 * rms / math.sqrt(n), floor)
        h = heights[surface][loop]
        u_height = math.hypot(float(np.std(h)) / math.sqrt(n), floor)
        along, to_center = np.roll(pts, -1, axis=0) - pts, center - pts
        side_distance = np.abs(along[:, 0] * to_center[:, 1] - along[:, 1] * to_center[:, 0]) / np.maximum(chords, 1e-300)
        kind, angle, cbore_depth, bore = _hole_type(diameter, rings, tolerance)
        found.append(EdgeLoop(center=center, diameter=diameter, vertex_diameter=2.0 * radius, vertices=n, rms=rms,
                              max_residual=worst,
                              roundness=float(np.max(np.hypot(*(pts - center).T)) - np.min(side_distance)),
                              u_center=u_center, u_diameter=u_diameter, height=float(np.mean(h)), u_height=u_height,
                              type=kind, rings=rings, cone_angle_deg=angle, counterbore_depth=cbore_depth, bore=bore))
    return found, rejected
