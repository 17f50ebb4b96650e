"""Point clouds made from a CAD mesh the way engineers make them, and their truth in the validation format.

A laser profiler (:mod:`holecli.simulation.profiler`) is one way to get a cloud of a part; the first
thing an engineer tries is simpler, and makes clouds of another kind:

``vertices``
    The mesh's own vertices, as a CAD export gives them: a CAD kernel triangulates each face with no
    vertex inside it, so the points lie only along the edges (the loops of the holes, the border)
    and none inside a flat face. Of a mesh that has interior vertices (a panel of
    :mod:`holecli.simulation.panel`, meshed with a background grid and rings), only the vertices
    on a *feature edge* are kept (a boundary edge or one whose faces differ by more than
    ``FEATURE_ANGLE_DEG``), which is the vertex set a CAD export of the same part would have.
``surface``
    Even sampling of the surface: points placed at random on the triangles, each triangle drawn
    with a probability proportional to its area (``trimesh.sample.sample_surface``, Open3D's
    ``sample_points_uniformly``), ``area / spacing**2`` of them: every face of the part (top,
    bottom, sides, bore walls), not only what a sensor would see.
``lattice``
    An exact square lattice straight down: parallel rays along ``view`` at a fixed ``spacing`` in
    both directions, each giving the first surface it meets (the profiler with parallel rays, no
    camera occlusion, every face lit).

``faces`` restricts ``vertices`` and ``surface`` to some of the triangles: ``all``; ``no-walls``
(drop the faces within ``WALL_DEG`` of parallel to ``view``: bore walls, counterbore walls, the
part's sides); ``seen`` (only the faces turned toward the sensor, walls dropped: the top face, the
countersink cones, the counterbore floors). ``noise`` is a Gaussian sigma along ``view`` (the range
noise of the lattice) added to every point.

The truth (:func:`cad_truth`) is written in the format of the validation suite
(``../shared/validation/realistic/*.truth.json``, scored by ``score.py``): ``holes`` (the holes whose
edge the cloud shows, seen along ``view``: ``center``, ``edge_diameter`` (the least-squares circle of
the edge polygon), ``edge_roundness`` (circumradius - inradius of that polygon), ``surface_normal``,
``type``, ``status``), ``holes_on_other_surfaces`` (a counterbore's bore on its floor, and, when the
cloud holds faces turned away from the sensor, the holes seen from the other side) and ``cutouts``
(slots, cut-outs and bosses: ``centroid``, ``size``, ``kind``), in the output frame.
"""

from __future__ import annotations

import math
from typing import Optional

import numpy as np

__all__ = ["CLOUD_KINDS", "FACES", "FEATURE_ANGLE_DEG", "WALL_DEG", "cad_cloud", "cad_truth", "cloud_pitch", "feature_vertices"]

CLOUD_KINDS = ("vertices", "surface", "lattice")
FACES = ("all", "no-walls", "seen")
# A mesh edge is a feature edge (a CAD export has vertices there) when its two faces' normals differ
# by more than this (degrees); the facets of a curved sheet stay far below it.
FEATURE_ANGLE_DEG = 20.0
# A face is a wall (a bore, a side) when its normal is within this (degrees) of perpendicular to the view.
WALL_DEG = 10.0
# A hole is 'full' when its edge stays this many pitches inside the cloud's region, 'border' when less,
# 'partial' when the region cuts it (the validation suite's convention).
BORDER_PITCHES = 3.0
# Most points a cloud may have.
MAX_POINTS = 20_000_000

_TYPES = {"through": "plain", "blind": "blind", "countersunk": "countersink", "counterbored": "counterbore",
          "other": "other"}


def _unit(vector):
    vector = np.asarray(vector, dtype=np.float64).reshape(3)
    norm = float(np.linalg.norm(vector))
    if not np.isfinite(norm) or norm == 0:
        raise ValueError(f"a direction must be finite and non-zero, got {vector.tolist()}")
    return vector / norm


def _frame(view, line):
    view = _unit(view)
    line = _unit(line)
    line = line - (line @ view) * view
    if np.linalg.norm(line) < 1e-6:
        raise ValueError("line must not be along view")
    line /= np.linalg.norm(line)
    return view, line, np.cross(line, view)


def _welded(vertices, triangles):
    from holecli.simulation.mesh_truth import _weld

    v = np.asarray(vertices, dtype=np.float64)
    t = np.asarray(triangles, dtype=np.int64)
    return _weld(v, t)  # unique vertices, triangles, unit normals (winding as given), areas


def _face_mask(normals, view, faces, vertices, triangles):
    """Which triangles ``faces`` keeps; ``seen`` needs the outward normals (wound by mesh_truth's walk)."""
    if faces == "all":
        return np.ones(len(normals), bool)
    if faces not in FACES:
        raise ValueError(f"faces must be one of {', '.join(FACES)}, got {faces!r}")
    cosine = normals @ view
    wall = np.abs(cosine) < math.sin(math.radians(WALL_DEG))
    if faces == "no-walls":
        return ~wall
    from holecli.simulation.mesh_truth import _wind

    _, outward, _ = _wind(vertices, triangles, normals)
    return (outward @ view < 0) & ~wall


def feature_vertices(vertices, triangles, angle_deg: float = FEATURE_ANGLE_DEG) -> np.ndarray:
    """Indices (into the welded vertices) of the vertices on a feature edge: a boundary or non-manifold
    edge, or one whose faces' normals differ by more than ``angle_deg``; and the welded vertices."""
    from holecli.simulation.mesh_truth import _edges, _wind

    v, t, normals, _ = _welded(vertices, triangles)
    t, normals, _ = _wind(v, t, normals)
    edges = _edges(t, normals, angle_deg)
    on = np.unique(edges.pairs[edges.feature].reshape(-1))
    return on, v


def _in_region(points, region):
    if region is None:
        return np.ones(len(points), bool)
    target, line, motion, half_line, half_scan = region
    rel = points - target
    return (np.abs(rel @ line) <= half_line) & (np.abs(rel @ motion) <= half_scan)


def cad_cloud(vertices, triangles, kind: str, spacing: float = 0.1, *, view=(0.0, 0.0, -1.0),
              line=(1.0, 0.0, 0.0), faces: str = "all", noise: float = 0.0, rng=0, target=None,
              line_length: Optional[float] = None, scan_length: Optional[float] = None) -> np.ndarray:
    """A cloud of the mesh made as an engineer makes one (see the module docstring).

    Parameters
    ----------
    vertices, triangles : array_like
        The mesh (mm).
    kind : {'vertices', 'surface', 'lattice'}
    spacing : float
        ``surface``: the mean spacing (``area / spacing**2`` points); ``lattice``: its pitch. Not used by
        ``vertices``.
    view, line : (3,) float
        The direction the cloud is seen along (into the part) and the lattice's first axis.
    faces : {'all', 'no-walls', 'seen'}
        The triangles ``vertices`` and ``surface`` use (``lattice`` sees what the rays meet).
    noise : float
        Gaussian sigma along ``view``, mm.
    rng : int or numpy.random.Generator
    target, line_length, scan_length
        The region kept: ``target`` +- ``line_length / 2`` along ``line`` and +- ``scan_length / 2``
        along ``view x line``... as the profiler's (None: the whole part; ``target`` defaults to the
        middle of the part on its side facing the sensor).

    Returns
    -------
    (n, 3) float64
    """
    rng = np.random.default_rng(rng)
    view, line, motion = _frame(view, line)
    v = np.asarray(vertices, dtype=np.float64)
    if not (isinstance(spacing, (int, float)) and math.isfinite(spacing) and spacing > 0):
        raise ValueError(f"spacing must be a finite number > 0, got {spacing!r}")
    if not (math.isfinite(noise) and noise >= 0):
        raise ValueError(f"noise must be a finite number >= 0, got {noise!r}")
    low, high = v.min(axis=0), v.max(axis=0)
    if target is None:
        middle = 0.5 * (low + high)
        target = middle + (float(np.min(v @ view)) - float(middle @ view)) * view
    target = np.asarray(target, dtype=np.float64)
    full_line = float(np.ptp(v @ line))
    full_scan = float(np.ptp(v @ motion))
    region = None
    if line_length is not None or scan_length is not None:
        region = (target, line, motion, 0.5 * (line_length or 2 * full_line + 1.0),
                  0.5 * (scan_length or 2 * full_scan + 1.0))
    if kind == "lattice":
        from holecli.simulation.profiler import ProfilerSpec, scan_mesh

        spec = ProfilerSpec(target=tuple(target), standoff=float(np.ptp(v @ view)) + 10.0, view=tuple(view),
                            line=tuple(line), line_length=line_length or full_line + spacing,
                            scan_length=scan_length or full_scan + spacing, point_pitch=spacing, line_pitch=spacing,
                            fan=False, triangulation_deg=0.0, max_incidence_deg=90.0, range_noise=noise)
        return scan_mesh(v, triangles, spec, rng=rng).points
    uv, t, normals, areas = _welded(v, triangles)
    mask = _face_mask(normals, view, faces, uv, t)
    if kind == "vertices":
        on, _ = feature_vertices(uv, t[mask]) if mask.any() else (np.zeros(0, np.int64), uv)
        points = uv[on]
    elif kind == "surface":
        tri, area = t[mask], areas[mask]
        if region is not None:  # sample only near the region (cheaper), then cut exactly
            centroid = uv[tri].mean(axis=1)
            reach = np.max(np.linalg.norm(uv[tri] - centroid[:, None], axis=2), axis=1)
            rel = centroid - target
            near = (np.abs(rel @ line) <= region[3] + reach) & (np.abs(rel @ motion) <= region[4] + reach)
            tri, area = tri[near], area[near]
        total = float(area.sum())
        count = int(round(total / spacing ** 2))
        if count > MAX_POINTS:
            raise ValueError(f"{count} points would be sampled (at most {MAX_POINTS}): raise the spacing")
        if count == 0 or len(tri) == 0:
            points = np.zeros((0, 3))
        else:
            pick = rng.choice(len(tri), size=count, p=area / total)
            r1, r2 = np.sqrt(rng.random(count)), rng.random(count)
            a, b, c = uv[tri[pick, 0]], uv[tri[pick, 1]], uv[tri[pick, 2]]
            points = (1 - r1)[:, None] * a + (r1 * (1 - r2))[:, None] * b + (r1 * r2)[:, None] * c
    else:
        raise ValueError(f"kind must be one of {', '.join(CLOUD_KINDS)}, got {kind!r}")
    points = points[_in_region(points, region)]
    if noise > 0:
        points = points + rng.normal(0.0, noise, len(points))[:, None] * view
    return points


def cloud_pitch(points, kind: str, spacing: float) -> float:
    """The pitch a cloud is scored at: ``spacing`` for a lattice or a surface sampling; for the vertices,
    which have none, the median distance from a vertex to its nearest neighbour."""
    if kind != "vertices" or len(points) < 2:
        return float(spacing)
    from scipy.spatial import cKDTree

    distance, _ = cKDTree(points).query(points, k=2)
    return float(np.median(distance[:, 1]))


def _edge_margin(points, region):
    """Smallest distance of ``points`` inside ``region`` to its border (negative: some are outside)."""
    if region is None:
        return math.inf
    target, line, motion, half_line, half_scan = region
    rel = points - target
    return float(min(np.min(half_line - np.abs(rel @ line)), np.min(half_scan - np.abs(rel @ motion))))


def _circle(center, axis, radius, count=72):
    e1 = np.cross(axis, [1.0, 0.0, 0.0] if abs(axis[0]) < 0.9 else [0.0, 1.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(axis, e1)
    phi = np.linspace(0.0, 2 * math.pi, count, endpoint=False)
    return center + radius * (np.outer(np.cos(phi), e1) + np.outer(np.sin(phi), e2))


def cad_truth(vertices, triangles, *, view=(0.0, 0.0, -1.0), line=(1.0, 0.0, 0.0), pitch: float, faces="all",
              kind="lattice", target=None, line_length=None, scan_length=None, not_holes=(), frame=None) -> dict:
    """The truth of a CAD cloud in the validation suite's format (see the module docstring).

    Parameters
    ----------
    vertices, triangles : array_like
        The mesh (part frame, mm).
    view, line, faces, kind, target, line_length, scan_length
        As given to :func:`cad_cloud` (the region decides each hole's status).
    pitch : float
        The cloud's pitch (the status margin is ``BORDER_PITCHES`` of it).
    not_holes : sequence of dict
        Features that are no holes (a panel's slots, cut-outs and bosses): ``kind``, ``center`` and
        ``length`` or ``diameter``; added to ``cutouts``. The mesh's own non-circular loops are added too.
    frame : (4, 4) array_like or None
        Rigid transform from the part frame to the output frame.

    Returns
    -------
    dict
        ``units``, ``view_dir``, ``holes``, ``holes_on_other_surfaces``, ``cutouts`` (output frame).
    """
    from holecli.simulation.mesh_truth import mesh_truth

    view, line, motion = _frame(view, line)
    v = np.asarray(vertices, dtype=np.float64)
    if target is None:
        middle = 0.5 * (v.min(axis=0) + v.max(axis=0))
        target = middle + (float(np.min(v @ view)) - float(middle @ view)) * view
    region = None
    if line_length is not None or scan_length is not None:
        region = (np.asarray(target, float), line, motion, 0.5 * (line_length or math.inf),
                  0.5 * (scan_length or math.inf))
    matrix = np.eye(4) if frame is None else np.asarray(frame, dtype=np.float64)
    rot, shift = matrix[:3, :3], matrix[:3, 3]

    def point(p):
        return (rot @ np.asarray(p, float) + shift).tolist()

    def direction(d):
        return (rot @ np.asarray(d, float)).tolist()

    def hole_record(h, other=False):
        center, axis = np.asarray(h["center"]), np.asarray(h["axis"])
        radius = h["edge_diameter"] / 2
        margin = _edge_margin(_circle(center, axis, radius), region)
        if margin < 0:
            status = "partial" if _edge_margin(center[None], region) > -radius else None
        else:
            status = "full" if margin >= BORDER_PITCHES * pitch else "border"
        roundness = 0.5 * (h["edge_circumdiameter"] - h["edge_indiameter"])
        # The least-squares circle of the edge polygon (its sides, not only its vertices): the mean
        # distance of the sides' points from the centre, r_in * mean sqrt(1 + x^2) over x in [0, tan(pi/N)].
        a = math.tan(math.pi / max(int(h["segments"]), 3))
        polygon_diameter = h["edge_indiameter"] * (a * math.sqrt(1 + a * a) + math.asinh(a)) / (2 * a)
        return status, {"kind": "hole", "type": _TYPES.get(h["kind"], h["kind"]), "center": point(center),
                        "edge_diameter": float(polygon_diameter),
                        "edge_diameter_vertices": float(h["edge_diameter"]), "edge_roundness": float(roundness),
                        "edge_segments": int(h["segments"]), "bore_diameter": h["bore_diameter"],
                        "depth": h["depth"], "axis": direction(axis), "surface_normal": direction(h["normal"]),
                        "countersink_angle_deg": h["countersink_angle_deg"], "status": status,
                        "arc_deg": 360.0 if status != "partial" else None}

    seen = mesh_truth(v, triangles, view=view)
    holes, others = [], []
    # A pocket's loop is a blind hole's to the mesh; the panel says it is none.
    pockets = [(np.asarray(c["center"], float), 0.5 * float(c["diameter"])) for c in not_holes if c.get("kind") == "pocket"]
    for h in seen["holes"]:
        if any(np.linalg.norm(np.asarray(h["center"], float) - at) < radius for at, radius in pockets):
            continue
        status, record = hole_record(h)
        if status is None:
            continue
        holes.append(record)
        if h["kind"] == "counterbored" and h.get("counterbore_depth"):
            floor = np.asarray(h["center"]) - h["counterbore_depth"] * np.asarray(h["axis"])
            others.append(dict(record, type="plain", center=point(floor), edge_diameter=float(h["bore_diameter"]) * record["edge_diameter"] / h["edge_diameter"],
                               edge_roundness=record["edge_roundness"] * h["bore_diameter"] / h["edge_diameter"],
                               note="the bore on the counterbore's floor"))
    if kind != "lattice" and faces != "seen":  # the cloud holds the faces turned away: the holes seen from below
        for h in mesh_truth(v, triangles, view=-view)["holes"]:
            status, record = hole_record(h, other=True)
            if status is not None:
                others.append(dict(record, note="seen from the other side"))
    cutouts = []
    # A panel's own list of its slots, cut-outs and bosses replaces the non-circular loops read off its mesh.
    for c in list(not_holes) or list(seen["cutouts"]):
        if c.get("is_hole"):
            continue
        size = c.get("length") or c.get("diameter") or 0.0
        centroid = np.asarray(c["center"], float)
        if region is not None and _edge_margin(centroid[None], region) < -0.5 * size:
            continue
        cutouts.append({"kind": c["kind"], "centroid": point(centroid), "size": float(size)})
    return {"units": "mm", "view_dir": direction(view), "line_dir": direction(line), "pitch": float(pitch),
            "cloud": kind, "faces": faces, "holes": holes, "holes_on_other_surfaces": others, "cutouts": cutouts,
            "status_margin_mm": BORDER_PITCHES * pitch}
