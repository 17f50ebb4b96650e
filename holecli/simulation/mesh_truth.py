"""Ground truth of the drilled holes of a CAD triangle mesh, for scoring a hole detector.

A CAD part exported as STL, PLY or OBJ carries its holes only implicitly: as polygons of many
segments where a bore, a cone or a floor meets the face it is drilled in. :func:`mesh_holes` finds
them from the mesh alone and describes each as a sensor looking along ``view`` would see it.

Method
------
1. Weld vertices with identical coordinates (STL stores each triangle's corners separately) and
   drop triangles with a repeated corner or zero area. Wind the faces consistently (a walk over
   manifold edges) and, for a closed component, outward (positive signed volume).
2. Feature edges: boundary edges, non-manifold edges and edges whose two faces' normals differ by
   more than ``angle_deg`` (the comparison does not depend on the faces' winding).
3. Loops: connected components of the feature-edge graph in which every vertex has degree 2, each
   ordered into a vertex cycle. Components with a branch (degree > 2, e.g. a box's outline) are
   not loops.
4. Circles: a plane through each loop (SVD of the centred vertices) and a circle in that plane
   (algebraic start, geometric least squares). A loop is a circle when it has at least
   ``MIN_SEGMENTS`` vertices, winds once about the centre in steps of at most ``MAX_STEP_DEG``, and
   both its out-of-plane spread and its deviation from the circle (the largest of the vertices'
   radial residuals and the polygon's sagitta ``r - inradius``) stay below ``MAX_DEVIATION`` x r.
5. Holes: circles whose axes are parallel within ``AXIS_PARALLEL_DEG`` and whose centres lie on a
   common axis within ``COAXIAL`` x r are one hole. The axis is oriented toward the sensor
   (``axis . view < 0``) and the loops are sorted by height along it.
6. The surface edge is the highest loop where the face outside the loop is flat (its third vertex
   lies radially outward, within ``angle_deg`` of the loop's plane) and the faces inside go down
   into the material (or the loop is a boundary), and, where the winding is known, the outside
   face looks toward the sensor (seen from behind, a pin's foot would otherwise pass). A face next
   to a loop is flat when its normal is within ``angle_deg`` of the axis; its side (radially out or
   in, up or down) is that of its third vertex. The centre is moved along the axis onto a quadratic
   fit of the surface around the edge (a no-op on a plane; on a curved sheet the edge is a saddle).
7. Between consecutive loops the wall is a cylinder (radius change within ``STEP_ANGLE_DEG`` of
   the axis), a flat step (height change within ``STEP_ANGLE_DEG`` of the plane) or a cone. The
   last loop closes the hole when faces inside it are on the inward side (a floor): blind.

Kinds: ``through`` (cylinder to an open far loop), ``countersunk`` (a cone from the edge down to a
smaller loop), ``counterbored`` (a cylinder, then a flat step), ``blind`` (a cylinder to a floor),
``other`` (anything else circular). A planar, non-circular loop that is a surface edge is a cut-out
(``slot`` when it is elongated, else ``cutout``) with ``is_hole`` False and its extent.

All tolerances are angles or ratios, so a part in metres behaves like one in millimetres, and they
are far above float32 resolution (a vertex of a 300 mm part rounded to float32 moves ~2e-5 mm).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional

import numpy as np

from holecli.errors import HoleCliError, PointsError
from holecli.geometry.circle import fit_circle_algebraic, fit_circle_geometric

__all__ = ["MeshHole", "MeshLoop", "mesh_holes", "mesh_truth", "MeshError"]

# Fewest vertices of a loop accepted as a circle.
MIN_SEGMENTS = 24
# Largest angular step (degrees) between consecutive vertices of a circular loop, about its centre.
MAX_STEP_DEG = 30.0
# Largest out-of-plane spread and deviation from the circle, as a fraction of the radius.
MAX_DEVIATION = 0.02
# Axes of one hole's loops are parallel within this angle (degrees).
AXIS_PARALLEL_DEG = 0.5
# Centres of one hole's loops lie on the common axis within this fraction of the smaller radius.
COAXIAL = 0.01
# A wall between two loops is a cylinder (or a flat step) when it is within this angle (degrees) of
# the axis (of the plane).
STEP_ANGLE_DEG = 0.5
# Vertices of the faces around an edge loop within this many radii of the axis shape the surface fit.
SURFACE_REACH = 2.0
# A slot's length exceeds its width by at least this factor; a rounder cut-out is a 'cutout'.
SLOT_ELONGATION = 1.05


class MeshError(HoleCliError, ValueError):
    """The mesh or a parameter handed to :func:`mesh_holes` is unusable."""


@dataclass(frozen=True, eq=False)
class MeshLoop:
    """A closed loop of feature edges fitted with a plane and a circle.

    Attributes
    ----------
    vertices : (k,) int64
        Indices into the welded vertex array, in order around the loop.
    points : (k, 3) float64
        Their coordinates, mm (the mesh's units).
    center : (3,) float64
        Centre of the fitted circle, in the loop's plane.
    normal : (3,) float64
        Unit normal of the loop's plane (sign arbitrary until a hole orients it).
    radius : float
        Radius of the least-squares circle through the vertices.
    circumradius, inradius : float
        Largest vertex distance and smallest edge distance from the centre.
    planarity : float
        Largest distance of a vertex from the plane.
    deviation : float
        ``max(max |radial residual|, radius - inradius)``.
    circular : bool
        Whether the loop passed the circle test of the module docstring.
    """

    vertices: np.ndarray
    points: np.ndarray
    center: np.ndarray
    normal: np.ndarray
    radius: float
    circumradius: float
    inradius: float
    planarity: float
    deviation: float
    circular: bool


@dataclass(frozen=True, eq=False)
class MeshHole:
    """A hole (or a non-circular cut-out) of a mesh, seen along a view direction.

    Attributes
    ----------
    kind : str
        'through', 'countersunk', 'counterbored', 'blind', 'other'; 'slot' or 'cutout' when not a hole.
    is_hole : bool
        False for a slot or cut-out.
    center : (3,) float64
        Where the axis meets the surface, mm: the edge circle's centre, moved along the axis onto a
        quadratic fit of the surface around the edge when that surface is curved.
    axis : (3,) float64
        Unit axis toward the sensor (``axis . view <= 0``).
    normal : (3,) float64
        Unit normal of the surface outside the edge (area-weighted), toward the sensor.
    edge_diameter : float or None
        Diameter of the least-squares circle through the edge polygon's vertices, mm; None for a
        cut-out.
    edge_circumdiameter, edge_indiameter : float or None
        Twice the edge polygon's circumradius and inradius, mm (in the edge's plane).
    bore_diameter : float or None
        Diameter of the hole's smallest loop.
    depth : float or None
        Axial distance from ``center`` to the last loop, mm (the thickness for a plain through hole).
    through : bool
        Whether the far end is open.
    segments : int
        Vertices of the edge polygon.
    loop_heights, loop_diameters : tuple of float
        Each loop of the hole from the edge down: axial depth of its plane below ``center`` and
        its diameter (depths and the countersink, counterbore and floor depths all count from
        ``center``).
    countersink_angle_deg, countersink_depth : float or None
        Included cone angle (degrees) and axial depth from the edge to the cone's small end.
    counterbore_diameter, counterbore_depth : float or None
        The step's diameter and its axial depth below the edge.
    floor_depth : float or None
        Axial depth of a blind hole's floor below the edge.
    length, width : float or None
        A cut-out's extent along and across its principal direction, mm; None for holes.
    direction : (3,) float64 or None
        A cut-out's principal direction.
    view_cosine : float
        ``-axis . view``: 1 when the sensor looks straight down the hole.
    edge_loop : MeshLoop
        The surface edge.
    edge_axial_offset : (3,) tuple of float
        Min, mean and max of the edge vertices' offsets along ``axis`` from ``center`` (zero on a
        flat surface; on a curved one the edge is a saddle around ``center``); empty for a cut-out.
    """

    kind: str
    is_hole: bool
    center: np.ndarray
    axis: np.ndarray
    normal: np.ndarray
    edge_diameter: float
    edge_circumdiameter: float
    edge_indiameter: float
    bore_diameter: Optional[float]
    depth: Optional[float]
    through: bool
    segments: int
    loop_heights: tuple
    loop_diameters: tuple
    countersink_angle_deg: Optional[float]
    countersink_depth: Optional[float]
    counterbore_diameter: Optional[float]
    counterbore_depth: Optional[float]
    floor_depth: Optional[float]
    length: Optional[float]
    width: Optional[float]
    direction: Optional[np.ndarray]
    view_cosine: float
    edge_loop: MeshLoop
    edge_axial_offset: tuple = ()

    def to_dict(self) -> dict:
        """JSON-ready dict: vectors as lists, floats as Python floats, no loop object.

        Returns
        -------
        dict
            The hole's fields by name (``kind``, ``is_hole``, ``center``, ``axis``, ``normal``, the
            edge's diameters, ...), None where a field does not apply.
        """
        out = {}
        for name in ("kind", "is_hole", "center", "axis", "normal", "edge_diameter",
                     "edge_circumdiameter", "edge_indiameter", "bore_diameter", "depth", "through",
                     "segments", "loop_heights", "loop_diameters", "countersink_angle_deg",
                     "countersink_depth", "counterbore_diameter", "counterbore_depth", "floor_depth",
                     "length", "width", "direction", "view_cosine", "edge_axial_offset"):
            value = getattr(self, name)
            if isinstance(value, np.ndarray) or isinstance(value, tuple):
                value = [float(x) for x in value]
            elif isinstance(value, (bool, np.bool_)):
                value = bool(value)
            elif isinstance(value, (int, np.integer)) and name == "segments":
                value = int(value)
            elif value is not None and not isinstance(value, str):
                value = float(value)
            out[name] = value
        return out


# --------------------------------------------------------------------------------------------------
# Validation


def _validate(vertices, triangles, view, angle_deg):
    v = np.asarray(vertices)
    if v.ndim != 2 or v.shape[1] != 3 or len(v) < 3:
        raise MeshError(f"vertices must be an (n, 3) array with n >= 3, got shape {v.shape}")
    if not np.issubdtype(v.dtype, np.number):
        raise MeshError(f"vertices must be numbers, got dtype {v.dtype}")
    v = v.astype(np.float64)
    if not np.all(np.isfinite(v)):
        raise MeshError("vertices must be finite, got NaN or infinite coordinates")
    t = np.asarray(triangles)
    if t.ndim != 2 or t.shape[1] != 3 or len(t) < 1:
        raise MeshError(f"triangles must be an (m, 3) array with m >= 1, got shape {t.shape}")
    if not np.issubdtype(t.dtype, np.integer):
        raise MeshError(f"triangles must be integer vertex indices, got dtype {t.dtype}")
    t = t.astype(np.int64)
    if t.min() < 0 or t.max() >= len(v):
        raise MeshError(f"triangles must index vertices in [0, {len(v)}), got indices in "
                        f"[{t.min()}, {t.max()}]")
    d = np.asarray(view, dtype=np.float64).reshape(-1)
    if d.shape != (3,) or not np.all(np.isfinite(d)) or np.linalg.norm(d) == 0:
        raise MeshError(f"view must be a finite non-zero 3-vector, got {view!r}")
    if isinstance(angle_deg, bool) or not isinstance(angle_deg, (int, float, np.floating, np.integer)) \
            or not 0.0 < float(angle_deg) < 90.0:
        raise MeshError(f"angle_deg must be a number in (0, 90) degrees, got {angle_deg!r}")
    return v, t, d / np.linalg.norm(d), float(angle_deg)


# --------------------------------------------------------------------------------------------------
# Mesh topology


def _weld(v, t):
    """Merge vertices with identical coordinates; drop triangles with a repeated corner or no area."""
    unique, inverse = np.unique(v, axis=0, return_inverse=True)
    t = inverse.reshape(-1)[t]
    keep = (t[:, 0] != t[:, 1]) & (t[:, 1] != t[:, 2]) & (t[:, 0] != t[:, 2])
    t = t[keep]
    cross = np.cross(unique[t[:, 1]] - unique[t[:, 0]], unique[t[:, 2]] - unique[t[:, 0]])
    area2 = np.linalg.norm(cross, axis=1)
    keep = area2 > 0
    return unique, t[keep], cross[keep] / area2[keep, None], area2[keep] / 2.0


@dataclass(frozen=True, eq=False)
class _Edges:
    pairs: np.ndarray        # (e, 2) sorted vertex pairs
    faces: list              # per edge, the faces that hold it
    feature: np.ndarray      # (e,) bool
    index: dict              # (a, b) sorted -> edge id


def _unique_edges(directed, n):
    """Undirected edges of (k, 2) directed ones: sorted pairs (e, 2), inverse (k,), counts (e,)."""
    lo = np.minimum(directed[:, 0], directed[:, 1]).astype(np.int64)
    hi = np.maximum(directed[:, 0], directed[:, 1]).astype(np.int64)
    keys, inverse, counts = np.unique(lo * n + hi, return_inverse=True, return_counts=True)
    return np.column_stack([keys // n, keys % n]), inverse.reshape(-1), counts


def _wind(v, t, normals):
    """Wind every triangle consistently with its neighbours and outward where that is known.

    Faces are flipped along a breadth-first walk over manifold edges so that neighbours traverse
    their shared edge in opposite directions. A closed component is then turned so that its signed
    volume is positive (normals out of the material); an open one keeps the winding of most of its
    original faces. ``trusted`` marks the faces whose outward side is known: those of closed
    components, and of open ones that were consistently wound already (a CAD export's own winding).
    Returns ``(triangles, normals, trusted)``.
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import breadth_first_order, connected_components

    m = len(t)
    directed = np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]])
    face = np.tile(np.arange(m), 3)
    forward = directed[:, 0] < directed[:, 1]
    _, inverse, counts = _unique_edges(directed, len(v))
    order = np.argsort(inverse, kind="stable")
    starts = np.concatenate([[0], np.cumsum(counts)])
    two = np.flatnonzero(counts == 2)
    f1, f2 = face[order[starts[two]]], face[order[starts[two] + 1]]
    disagree = forward[order[starts[two]]] == forward[order[starts[two] + 1]]
    # Edge weights 1 (agree) or 2 (disagree), symmetric, so a lookup of (parent, child) is direct.
    graph = coo_matrix((np.concatenate([1 + disagree, 1 + disagree]).astype(np.int8),
                        (np.concatenate([f1, f2]), np.concatenate([f2, f1]))), shape=(m, m)).tocsr()
    n_comp, labels = connected_components(graph, directed=False)
    open_edge = np.zeros(m, bool)
    open_edge[face[order[starts[np.flatnonzero(counts == 1)]]]] = True
    flip = np.zeros(m, bool)
    bad = np.zeros(n_comp, bool)
    np.logical_or.at(bad, labels[np.concatenate([f1[disagree], f2[disagree]])], True)
    for c in range(n_comp):
        if not bad[c]:
            continue
        root = int(np.flatnonzero(labels == c)[0])
        walk, pred = breadth_first_order(graph, root, directed=False, return_predecessors=True)
        child = walk[1:]
        against = np.zeros(m, bool)
        against[child] = np.asarray(graph[pred[child], child]).ravel() == 2
        for f in child.tolist():  # parents come first in breadth-first order
            flip[f] = flip[pred[f]] ^ against[f]
    closed = ~np.bincount(labels, weights=open_edge, minlength=n_comp).astype(bool)
    tri = np.where(flip[:, None], t[:, ::-1], t)
    centre = v.mean(axis=0)
    a, b, c3 = v[tri[:, 0]] - centre, v[tri[:, 1]] - centre, v[tri[:, 2]] - centre
    volume = np.bincount(labels, weights=np.einsum("ij,ij->i", a, np.cross(b, c3)), minlength=n_comp)
    sizes = np.bincount(labels, minlength=n_comp)
    flipped_share = np.bincount(labels, weights=flip, minlength=n_comp) / sizes
    turn = np.where(closed, volume < 0, flipped_share > 0.5)
    flip ^= turn[labels]
    tri = np.where(flip[:, None], t[:, ::-1], t)
    trusted = (closed | ~bad)[labels]
    return tri, np.where(flip[:, None], -normals, normals), trusted


def _edges(t, normals, angle_deg):
    m = len(t)
    directed = np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]])
    face = np.tile(np.arange(m), 3)
    forward = directed[:, 0] < directed[:, 1]
    unique, inverse, counts = _unique_edges(directed, int(t.max()) + 1)
    order = np.argsort(inverse, kind="stable")
    starts = np.concatenate([[0], np.cumsum(counts)])
    feature = counts != 2
    faces = [None] * len(unique)
    cos_limit = math.cos(math.radians(angle_deg))
    two = np.flatnonzero(counts == 2)
    first = order[starts[two]]
    second = order[starts[two] + 1]
    # Consistently wound neighbours traverse their edge in opposite directions; if not, one
    # face's normal is flipped for the comparison so that winding does not matter.
    sign = np.where(forward[first] != forward[second], 1.0, -1.0)
    cosine = sign * np.einsum("ij,ij->i", normals[face[first]], normals[face[second]])
    feature[two] = cosine < cos_limit
    for e in np.flatnonzero(feature):
        faces[e] = face[order[starts[e]:starts[e + 1]]]
    index = {(int(a), int(b)): e for e, (a, b) in enumerate(unique) if feature[e]}
    return _Edges(pairs=unique, faces=faces, feature=feature, index=index)


def _cycles(edges):
    """Vertex cycles of the components of the feature-edge graph whose vertices all have degree 2."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    fe = edges.pairs[edges.feature]
    if len(fe) == 0:
        return []
    n = int(fe.max()) + 1
    graph = coo_matrix((np.ones(len(fe)), (fe[:, 0], fe[:, 1])), shape=(n, n))
    _, labels = connected_components(graph, directed=False)
    degree = np.bincount(fe.ravel(), minlength=n)
    neighbours = {}
    for a, b in fe:
        neighbours.setdefault(int(a), []).append(int(b))
        neighbours.setdefault(int(b), []).append(int(a))
    used = np.zeros(n, bool)
    bad = np.zeros(labels.max() + 1, bool)
    np.logical_or.at(bad, labels[degree > 2], True)
    cycles = []
    for start in neighbours:
        if used[start] or bad[labels[start]]:
            continue
        cycle = [start]
        used[start] = True
        prev, cur = start, neighbours[start][0]
        while cur != start:
            cycle.append(cur)
            used[cur] = True
            a, b = neighbours[cur]
            prev, cur = cur, (b if a == prev else a)
        if len(cycle) >= 3:
            cycles.append(np.asarray(cycle, dtype=np.int64))
    return cycles


# --------------------------------------------------------------------------------------------------
# Loop fits


def _fit_loop(v, cycle):
    p = v[cycle]
    mean = p.mean(axis=0)
    _, s, vt = np.linalg.svd(p - mean, full_matrices=False)
    normal = vt[2]
    e1, e2 = vt[0], vt[1]
    planarity = float(np.max(np.abs((p - mean) @ normal)))
    xy = np.column_stack([(p - mean) @ e1, (p - mean) @ e2])
    nan = np.full(3, np.nan)
    try:
        fit = fit_circle_geometric(xy, start=fit_circle_algebraic(xy))
    except PointsError:
        return MeshLoop(cycle, p, nan, normal, math.nan, math.nan, math.nan, planarity, math.inf, False)
    c2, r = fit.center, fit.radius
    center = mean + c2[0] * e1 + c2[1] * e2
    rel = xy - c2
    dist = np.hypot(rel[:, 0], rel[:, 1])
    nxt = np.roll(rel, -1, axis=0)
    seg = nxt - rel
    length2 = np.einsum("ij,ij->i", seg, seg)
    tpar = np.clip(-np.einsum("ij,ij->i", rel, seg) / np.where(length2 > 0, length2, 1.0), 0.0, 1.0)
    closest = rel + tpar[:, None] * seg
    inradius = float(np.min(np.hypot(closest[:, 0], closest[:, 1])))
    circumradius = float(np.max(dist))
    deviation = max(float(np.max(np.abs(fit.residuals))), r - inradius)
    angles = np.arctan2(rel[:, 1], rel[:, 0])
    steps = np.angle(np.exp(1j * (np.roll(angles, -1) - angles)))
    winds_once = (abs(abs(steps.sum()) - 2 * math.pi) < 1e-6 and
                  (np.all(steps > 0) or np.all(steps < 0)))
    circular = bool(len(cycle) >= MIN_SEGMENTS and winds_once
                    and np.max(np.abs(steps)) <= math.radians(MAX_STEP_DEG)
                    and planarity <= MAX_DEVIATION * r and deviation <= MAX_DEVIATION * r)
    return MeshLoop(cycle, p, center, normal, float(r), circumradius, inradius, planarity,
                    float(deviation), circular)


def _group(loops):
    """Indices of the circular loops grouped into coaxial sets (union-find)."""
    circ = [i for i, lp in enumerate(loops) if lp.circular]
    parent = {i: i for i in circ}

    def root(i):
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    cos_par = math.cos(math.radians(AXIS_PARALLEL_DEG))
    if not circ:
        return []
    centers = np.array([loops[i].center for i in circ])
    normals = np.array([loops[i].normal for i in circ])
    radii = np.array([loops[i].radius for i in circ])
    for x, i in enumerate(circ[:-1]):
        d = centers[x + 1:] - centers[x]
        off_a = np.linalg.norm(d - np.outer(d @ normals[x], normals[x]), axis=1)
        off_b = np.linalg.norm(d - (np.einsum("ij,ij->i", d, normals[x + 1:]))[:, None]
                               * normals[x + 1:], axis=1)
        ok = ((np.abs(normals[x + 1:] @ normals[x]) >= cos_par)
              & (np.maximum(off_a, off_b) <= COAXIAL * np.minimum(radii[x], radii[x + 1:])))
        for y in np.flatnonzero(ok):
            parent[root(circ[x + 1 + y])] = root(i)
    groups = {}
    for i in circ:
        groups.setdefault(root(i), []).append(i)
    return list(groups.values())


# --------------------------------------------------------------------------------------------------
# Faces around a loop


@dataclass(frozen=True)
class _Sides:
    """What lies next to a loop: counts of the faces along its edges, by kind and side."""

    out_flat: int        # flat (normal within angle_deg of the axis), radially outward
    in_flat: int         # flat, radially inward
    up: int              # not flat, rising from the loop toward the sensor
    down: int            # not flat, falling away from the sensor
    in_down: int         # of ``down``, those leaning inward (a cone closing the hole)
    boundary: bool       # some loop edge has a single face
    out_normal: np.ndarray  # area-weighted normal of the outward flat faces, toward the axis's side
    out_vertices: tuple  # third vertices of the outward flat faces
    out_facing: float    # sum of area x (outward normal . axis) over the trusted outward flat faces
    out_trusted: int     # how many outward flat faces have a known outward side


def _sides(loop, axis, center, v, t, normals, areas, trusted, edges, angle_deg):
    # Flatness is judged by the face's normal, robust to slivers whose third vertex lies nearly on
    # the edge's line; the side (in or out, up or down) by the third vertex, robust to winding.
    cos_flat = math.cos(math.radians(angle_deg))
    cyc = loop.vertices
    p = loop.points - center
    # Signed area about the axis: positive when the loop runs counter-clockwise seen from the
    # sensor, its interior then on the left of each edge.
    winding = np.sign(np.cross(p, np.roll(p, -1, axis=0)).sum(axis=0) @ axis) or 1.0
    a_ids, b_ids, f_ids = [], [], []
    boundary = False
    for a, b in zip(cyc.tolist(), np.roll(cyc, -1).tolist()):
        e = edges.index.get((min(a, b), max(a, b)))
        if e is None:
            continue
        faces = edges.faces[e].tolist()
        boundary |= len(faces) == 1
        a_ids += [a] * len(faces)
        b_ids += [b] * len(faces)
        f_ids += faces
    a_ids, b_ids, f_ids = (np.asarray(x, dtype=np.int64) for x in (a_ids, b_ids, f_ids))
    w_ids = t[f_ids].sum(axis=1) - a_ids - b_ids   # each face's third vertex
    mid = (v[a_ids] + v[b_ids]) / 2.0
    # Outward: in the plane, perpendicular to the edge, away from the loop's interior.
    radial = -winding * np.cross(axis, v[b_ids] - v[a_ids]).reshape(-1, 3)
    radial /= np.maximum(np.linalg.norm(radial, axis=1), 1e-300)[:, None]
    d = v[w_ids] - mid
    s = np.einsum("ij,ij->i", d, radial)
    h = d @ axis
    n = normals[f_ids]
    n_axis = n @ axis
    flat = np.abs(n_axis) >= cos_flat
    out = flat & (s > 0)
    out_flat = int(out.sum())
    in_flat = int((flat & (s <= 0)).sum())
    up = int((~flat & (h > 0)).sum())
    down_mask = ~flat & (h <= 0)
    down = int(down_mask.sum())
    in_down = int((down_mask & (s < 0)).sum())
    oriented = np.where(n_axis[out, None] >= 0, n[out], -n[out])
    acc = (areas[f_ids[out], None] * oriented).sum(axis=0) if out_flat else np.zeros(3)
    outside = set(w_ids[out].tolist())
    known = out & trusted[f_ids]
    out_trusted = int(known.sum())
    facing = float((areas[f_ids[known]] * n_axis[known]).sum())
    return _Sides(out_flat, in_flat, up, down, int(in_down), boundary, acc, tuple(sorted(outside)),
                  float(facing), out_trusted)


def _surface_offset(edge, axis, v, outside):
    """Height along ``axis`` of the surface at the edge's centre, above the edge loop's plane.

    A quadratic height field ``z(x, y)`` in the loop's frame, fitted to the loop's vertices and the
    outward faces' vertices within ``SURFACE_REACH`` radii of the axis. On a plane the loop's
    vertices alone make the fit rank-deficient (``x^2 + y^2 = r^2``) and the offset is zero; on a
    curved sheet the loop is a saddle and its plane lies off the surface by about ``r^2 / (4 R)``.
    """
    r = edge.radius
    ids = np.asarray(outside, dtype=np.int64)
    extra = v[ids] - edge.center if len(ids) else np.zeros((0, 3))
    z_extra = extra @ axis
    radial = np.linalg.norm(extra - np.outer(z_extra, axis), axis=1)
    extra = extra[radial <= SURFACE_REACH * r]
    if len(extra) < 3:
        return 0.0
    pts = np.vstack([edge.points - edge.center, extra])
    e1 = np.cross(axis, [1.0, 0.0, 0.0] if abs(axis[0]) < 0.9 else [0.0, 1.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(axis, e1)
    x, y, z = pts @ e1 / r, pts @ e2 / r, pts @ axis
    design = np.column_stack([np.ones_like(x), x, y, x * x, x * y, y * y])
    coef, _, rank, sv = np.linalg.lstsq(design, z, rcond=None)
    if rank < 6 or sv[-1] < 1e-6 * sv[0]:
        return 0.0
    return float(coef[0])


def _is_surface_edge(sides):
    # Where the winding is known, the surface outside must face the sensor (material below it):
    # seen from behind, a pin's foot looks like a hole's edge otherwise.
    faces_sensor = sides.out_trusted == 0 or sides.out_facing > 0
    return sides.out_flat > 0 and sides.up == 0 and (sides.down > 0 or sides.boundary) and faces_sensor


# --------------------------------------------------------------------------------------------------
# Holes


def _orient(axis, view):
    return -axis if axis @ view > 0 else axis


def _descend(heights, radii):
    """Loop order from the sensor down; loops of one flat step follow the wall that reaches them."""
    tan_step = math.tan(math.radians(STEP_ANGLE_DEG))
    left = list(np.argsort(-heights, kind="stable"))
    order = [left.pop(0)]
    while left:
        top = left[0]
        level = [i for i in left
                 if abs(heights[i] - heights[top]) <= tan_step * abs(radii[i] - radii[top])]
        nxt = min(level, key=lambda i: abs(radii[i] - radii[order[-1]]))
        left.remove(nxt)
        order.append(nxt)
    return np.asarray(order)


def _hole(group, loops, v, t, normals, areas, trusted, edges, view, angle_deg):
    ref = loops[group[0]]
    axis = _orient(ref.normal, view)
    members = [loops[i] for i in group]
    heights = np.array([(lp.center - ref.center) @ axis for lp in members])
    order = _descend(heights, np.array([lp.radius for lp in members]))
    members = [members[i] for i in order]
    heights = heights[order]
    sides = [_sides(lp, axis, lp.center, v, t, normals, areas, trusted, edges, angle_deg) for lp in members]
    top = next((k for k, s in enumerate(sides) if _is_surface_edge(s)), None)
    if top is None:
        return None
    members, heights, sides = members[top:], heights[top:], sides[top:]
    edge = members[0]
    offset = _surface_offset(edge, axis, v, sides[0].out_vertices)
    center = edge.center + offset * axis
    depths = heights[0] + offset - heights
    axial = (edge.points - center) @ axis
    radii = np.array([lp.radius for lp in members])
    tan_step = math.tan(math.radians(STEP_ANGLE_DEG))
    walls = []
    for k in range(len(members) - 1):
        dr, dh = radii[k + 1] - radii[k], depths[k + 1] - depths[k]
        if abs(dr) <= tan_step * abs(dh):
            walls.append("cylinder")
        elif abs(dh) <= tan_step * abs(dr):
            walls.append("step")
        else:
            walls.append("cone")
    last = sides[-1]
    # A floor: faces inside the last loop, flat or a cone closing toward the axis (a drill point).
    floor = len(members) > 1 and (last.in_flat > 0 or last.in_down > 0) and not last.boundary
    through = not floor
    result = dict(countersink_angle_deg=None, countersink_depth=None, counterbore_diameter=None,
                  counterbore_depth=None, floor_depth=None)
    if walls and walls[0] == "cone" and radii[1] < radii[0]:
        kind = "countersunk"
        result["countersink_angle_deg"] = math.degrees(
            2.0 * math.atan2(radii[0] - radii[1], depths[1] - depths[0]))
        result["countersink_depth"] = float(depths[1])
    elif len(walls) >= 2 and walls[0] == "cylinder" and walls[1] == "step" and radii[2] < radii[1]:
        kind = "counterbored"
        result["counterbore_diameter"] = float(radii[0] + radii[1])
        result["counterbore_depth"] = float(depths[1])
    elif floor and all(w == "cylinder" for w in walls):
        kind = "blind"
    elif not floor and (not walls or walls[0] == "cylinder"):
        # Seen from the far side, a countersunk or counterbored hole is a bore that widens later.
        kind = "through"
    else:
        kind = "other"
    if floor:
        result["floor_depth"] = float(depths[-1])
    normal = sides[0].out_normal
    normal = normal / np.linalg.norm(normal) if np.linalg.norm(normal) > 0 else axis.copy()
    normal = _orient(normal, view)
    return MeshHole(kind=kind, is_hole=True, center=center, axis=axis, normal=normal,
                    edge_diameter=2.0 * edge.radius, edge_circumdiameter=2.0 * edge.circumradius,
                    edge_indiameter=2.0 * edge.inradius, bore_diameter=float(2.0 * radii.min()),
                    depth=float(depths[-1]) if len(members) > 1 else None, through=through,
                    segments=len(edge.vertices), loop_heights=tuple(float(x) for x in depths),
                    loop_diameters=tuple(float(2 * r) for r in radii), length=None, width=None,
                    direction=None, view_cosine=float(-axis @ view), edge_loop=edge,
                    edge_axial_offset=(float(axial.min()), float(axial.mean()), float(axial.max())),
                    **result)


def _cutout(loop, v, t, normals, areas, trusted, edges, view, angle_deg):
    if loop.planarity > MAX_DEVIATION * max(np.ptp(loop.points, axis=0).max(), 1e-300):
        return None
    axis = _orient(loop.normal, view)
    mean = loop.points.mean(axis=0)
    sides = _sides(loop, axis, mean, v, t, normals, areas, trusted, edges, angle_deg)
    if not _is_surface_edge(sides):
        return None
    rel = loop.points - mean
    rel -= np.outer(rel @ axis, axis)
    _, _, vt = np.linalg.svd(rel, full_matrices=False)
    direction = vt[0]
    across = np.cross(axis, direction)
    along = rel @ direction
    side = rel @ across
    # The extent's centre, not the vertex mean (a slot's vertices crowd at its rounded ends).
    center = mean + (along.max() + along.min()) / 2 * direction + (side.max() + side.min()) / 2 * across
    length, width = float(np.ptp(along)), float(np.ptp(side))
    normal = sides.out_normal
    normal = _orient(normal / np.linalg.norm(normal), view) if np.linalg.norm(normal) > 0 else axis
    kind = "slot" if length > SLOT_ELONGATION * width else "cutout"
    return MeshHole(kind=kind, is_hole=False, center=center, axis=axis, normal=normal,
                    edge_diameter=None, edge_circumdiameter=None, edge_indiameter=None,
                    bore_diameter=None, depth=None, through=sides.down > 0, segments=len(loop.vertices),
                    loop_heights=(), loop_diameters=(), countersink_angle_deg=None,
                    countersink_depth=None, counterbore_diameter=None, counterbore_depth=None,
                    floor_depth=None, length=length, width=width, direction=direction,
                    view_cosine=float(-axis @ view), edge_loop=loop, edge_axial_offset=())


def mesh_holes(vertices, triangles, view=(0.0, 0.0, -1.0), *, angle_deg=20.0) -> tuple:
    """The drilled holes and cut-outs of a CAD triangle mesh, seen along ``view``.

    Parameters
    ----------
    vertices : (n, 3) float
        Vertex coordinates (any units; float32 is promoted). Duplicates are welded.
    triangles : (m, 3) int
        Vertex indices; winding need not be consistent.
    view : (3,) float
        Direction the sensor looks along (into the part), any length > 0.
    angle_deg : float
        Dihedral angle (degrees, in (0, 90)) above which an edge is a feature edge. A countersink
        whose cone meets the surface at less than this (included angle > 180 - 2 angle_deg) is missed.

    Returns
    -------
    tuple of MeshHole
        Holes first, then cut-outs; each group sorted by centre (x, then y, then z).

    Raises
    ------
    MeshError
        Bad shapes, non-finite coordinates, indices out of range, a zero view or a bad angle.
    """
    v, t, view, angle_deg = _validate(vertices, triangles, view, angle_deg)
    v, t, normals, areas = _weld(v, t)
    if len(t) == 0:
        raise MeshError("triangles must include at least one with non-zero area, got none")
    t, normals, trusted = _wind(v, t, normals)
    edges = _edges(t, normals, angle_deg)
    loops = [_fit_loop(v, c) for c in _cycles(edges)]
    holes = []
    for group in _group(loops):
        hole = _hole(group, loops, v, t, normals, areas, trusted, edges, view, angle_deg)
        if hole is not None:
            holes.append(hole)
    cutouts = [c for c in (_cutout(lp, v, t, normals, areas, trusted, edges, view, angle_deg)
                           for lp in loops if not lp.circular) if c is not None]
    key = lambda h: tuple(h.center)  # noqa: E731
    return tuple(sorted(holes, key=key)) + tuple(sorted(cutouts, key=key))


def _region_test(region):
    if region is None:
        return None
    if callable(region):
        return lambda p: np.asarray(region(p), dtype=bool).reshape(len(p))
    box = np.asarray(region, dtype=np.float64).reshape(-1)
    if box.shape != (6,) or not np.all(np.isfinite(box)) or np.any(box[0::2] > box[1::2]):
        raise MeshError("region must be a callable or a box (xmin, xmax, ymin, ymax, zmin, zmax) "
                        f"with min <= max, got {region!r}")
    lo, hi = box[0::2], box[1::2]
    return lambda p: np.all((p >= lo) & (p <= hi), axis=1)


def _circle_points(hole, count=64):
    """The edge polygon's vertices and ``count`` points of its fitted circle (a cut-out: vertices)."""
    pts = hole.edge_loop.points
    if not hole.is_hole:
        return pts
    a = hole.axis
    e1 = np.cross(a, [1.0, 0.0, 0.0] if abs(a[0]) < 0.9 else [0.0, 1.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(a, e1)
    phi = np.linspace(0.0, 2 * math.pi, count, endpoint=False)
    r = hole.edge_diameter / 2
    circle = hole.center + r * (np.outer(np.cos(phi), e1) + np.outer(np.sin(phi), e2))
    return np.vstack([pts, circle])


def mesh_truth(vertices, triangles, view=(0.0, 0.0, -1.0), region=None, *, angle_deg=20.0) -> dict:
    """JSON-ready truth of a mesh's holes for scoring a detector.

    Parameters
    ----------
    vertices, triangles, view, angle_deg
        As for :func:`mesh_holes`.
    region : callable or (6,) float, optional
        The scanned region in the mesh frame: a callable taking (k, 3) points and returning (k,)
        bools, or an axis-aligned box ``(xmin, xmax, ymin, ymax, zmin, zmax)``.

    Returns
    -------
    dict
        ``{"view": [...], "angle_deg": float, "features": [...], "holes": [...], "cutouts": [...]}``
        (features = holes then cut-outs, as in :func:`holecli.simulation.panel.panel_truth`); each entry is
        :meth:`MeshHole.to_dict`, plus ``"inside_region"`` (whether the whole edge, its polygon
        vertices and 64 points of its circle, lies in the region) when a region is given.

    Raises
    ------
    MeshError
        As for :func:`mesh_holes`, and for a ``region`` that is neither a callable nor a box.
    """
    inside = _region_test(region)
    found = mesh_holes(vertices, triangles, view, angle_deg=angle_deg)
    holes, cutouts = [], []
    for h in found:
        d = h.to_dict()
        if inside is not None:
            d["inside_region"] = bool(np.all(inside(_circle_points(h))))
        (holes if h.is_hole else cutouts).append(d)
    view = np.asarray(view, dtype=np.float64).reshape(-1)
    return {"view": [float(x) for x in view / np.linalg.norm(view)], "angle_deg": float(angle_deg),
            "features": holes + cutouts, "holes": holes, "cutouts": cutouts}
