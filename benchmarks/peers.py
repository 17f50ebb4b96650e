"""holecli beside two peers a competent user builds from common libraries, on the same files with truth.

The peers (each about 100 lines below, written from the libraries' documented recipes, scale-free:
every length is a multiple of the cloud's median point spacing h, or of the area spacing
ha = sqrt(plane area / plane points), which is larger on stripes; nothing was tuned to a file but
one round limit, the arc gap, widened from 60 to 90 degrees after an occluded countersink):

* ``open3d``: Open3D's ``segment_plane`` (RANSAC, threshold 3 h) repeated while a plane holds at least
  10 % of the points (at most 3 planes); per plane, ``t.geometry.PointCloud.compute_boundary_points``
  (the angle criterion, radius R = max(3 ha, 2.5 h), the plane's normal), ``cluster_dbscan`` of the
  boundary points (eps R); per cluster a RANSAC circle in the plane (3-point circles, inliers within ha)
  refined by geometric least squares (``scipy.optimize.least_squares``).
* ``pcl``: the PCL recipe (``SACSegmentation`` plane, ``BoundaryEstimation``, ``EuclideanClusterExtraction``,
  a circle fit) in numpy/scipy: a RANSAC plane refined by SVD, the angle criterion on the plane's k
  nearest neighbours within R (a gap of more than 90 degrees between neighbours: boundary), Euclidean
  clustering (``cKDTree.query_pairs`` + connected components), the algebraic circle of Taubin, one
  trimming pass of points off by more than 3 MAD, and a residual check.

Both then keep a cluster as a hole only if it is a hole a user would believe: it does not touch the
scan's outer border (no boundary point within 2 R of the plane's convex hull), its circle is round
(RMS residual <= ha), closed (no gap of more than 90 degrees in its points' angles), at least 2 R
in radius, and empty (at most 1 % of the points the disk of radius r - 2 ha would hold on the plane
lie in it). Then the hole is measured on its own surface (:func:`lift`, the same for both): a plane
and a quadric fitted to the annulus r + R .. 2 r (curved sheets), the points within 3 RMS of it (a
countersink's cone leaves it), the innermost of them per angular sector (the last points of
material), the peer's circle fit to those (least squares / Taubin), the radius reduced by 0.25 ha
(their offset outside the edge on simulated scans), the center and normal on the quadric. The peers
report no partial holes (a hole cut by the border merges with the border's cluster).

Each file is scored with the validation scorer's rules, replicated here from
``../shared/validation/score.py`` (:func:`score`; ``tests/test_benchmark_peers.py`` checks the copy
against the scorer when it is there): a truth hole is found when a reported center lies within
max(0.1 mm, 0.5 p); a file is all right when every full hole is found within the center, diameter and
normal tolerances and nothing else is reported. Per method: truth holes found (of the full ones),
false holes (reported holes the scorer calls extra), files all right, center error (3D) and
|diameter error| median and maximum over the found holes (um), and the CPU (``time.process_time``, all
threads) and wall time per file of the method alone on the points in memory (reading is not
counted; holecli runs :func:`holecli.pipeline.detect` with its defaults, ``--view-dir`` passes each
scan's viewing direction from ``cases.json``).

Suites: any folder holding scans with a ``NAME.truth.json`` beside each ``NAME.ply`` (or .pcd, .csv,
.txt, .xyz, .las, .laz, .e57). The truth, in the scan's frame and units:

* ``units``: ``"mm"`` (default) or ``"m"``;
* ``holes``: each with ``center`` (on the surface, on the axis), ``edge_diameter`` (or ``diameter``: the
  edge at the surface; a countersink's outer edge), ``surface_normal`` (or ``normal``), ``status``
  (``full``, ``border`` or ``partial``; else ``partial: true`` -> ``partial``, otherwise ``full``),
  ``type`` (optional) and ``edge_roundness`` (optional, a CAD polygon's radial spread);
* optional ``holes_on_other_surfaces`` (holes that may be reported, never required), ``cutouts`` (each
  ``centroid``, ``size``, ``kind``) or holecli's ``features`` (slots, bosses: ``center``, ``length`` or
  ``diameter``, ``kind``), named when a false hole lies on one;
* the scan's pitch p and range noise s: ``cases.json`` of the folder (the validation suite's), else
  ``pitch`` and ``noise`` in the truth, else its ``profiler`` (``max(point_pitch, line_pitch)`` and
  ``range_noise``, times ``unit_scale``: what ``holecli simulate panel --mesh/--panel`` writes), else the
  cloud's median nearest-neighbour distance and 0 (said in the output).

Run (from the repository's root; the validation suite takes about 4 minutes on 2 cores):

    python benchmarks/peers.py --suite ../shared/validation/realistic [--suite CAD_FOLDER] [--only TEXT]
                               [--methods holecli,open3d,pcl] [--view-dir] [--json OUT.json] [--quiet] [--docs]

``--docs`` writes the table into its block of docs/validation/peers.md (``--docs-page PATH``: another page).
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
import sys
import time
from pathlib import Path

import numpy as np
from scipy.optimize import least_squares
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import ConvexHull, cKDTree

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from benchmarks._docs_table import VALIDATION, add_docs_options, docs_target  # noqa: E402

SCAN_EXTENSIONS = (".ply", ".pcd", ".csv", ".txt", ".xyz", ".las", ".laz", ".e57")

# ---------------------------------------------------------------------------------------------------
# The validation scorer's rules (a copy of ../shared/validation/score.py: angle_deg, _u, score)
# ---------------------------------------------------------------------------------------------------
FOUND_MM, FOUND_P = 0.1, 0.5
CENTER_MM, CENTER_P, CENTER_S = 0.02, 0.2, 0.5
DIAM_MM, DIAM_P, DIAM_S = 0.03, 0.3, 1.0
NORMAL_DEG = 0.1


def angle_deg(a, b):
    a, b = np.asarray(a, float), np.asarray(b, float)
    c = abs(a @ b) / (np.linalg.norm(a) * np.linalg.norm(b))
    return math.degrees(math.acos(min(1.0, c)))


def _u(q, *keys):
    u = q.get("uncertainty") or {}
    for k in keys:
        v = u.get(k)
        if isinstance(v, (int, float)) and math.isfinite(v) and v > 0:
            return float(v)
    return None


def score(case, truth, doc):
    scale = 1e-3 if truth["units"] == "m" else 1.0
    p = case["pitch"]
    s = case["noise"]
    found_tol = max(FOUND_MM * scale, FOUND_P * p)
    holes = truth["holes"]
    others = truth.get("holes_on_other_surfaces", [])
    cuts = truth.get("cutouts", [])
    rep = doc["holes"] if doc else []
    # associate reported holes with truth holes, closest pairs first (one to one)
    cands = []
    for i, h in enumerate(holes + others):
        r = h["edge_diameter"] / 2
        for j, q in enumerate(rep):
            d = float(np.linalg.norm(np.subtract(q["center"], h["center"])))
            if d <= max(found_tol, 0.5 * r):
                cands.append((d, i, j))
    cands.sort()
    pair, used = {}, set()
    for d, i, j in cands:
        if i in pair or j in used:
            continue
        pair[i] = (j, d)
        used.add(j)
    fails, per_hole = [], []
    for i, h in enumerate(holes):
        st = h["status"]
        rec = {"status": st, "type": h["type"], "edge_diameter": h["edge_diameter"]}
        if i in pair:
            j, d = pair[i]
            q = rep[j]
            n = np.asarray(h["surface_normal"], float)
            off = np.subtract(q["center"], h["center"])
            in_plane = float(np.linalg.norm(off - (off @ n) * n))
            rec.update(reported=True, partial=bool(q.get("partial")), center_err=d, center_in_plane=in_plane,
                       center_along_normal=float(off @ n), diameter=q["diameter"],
                       diameter_err=q["diameter"] - h["edge_diameter"], normal_err=angle_deg(q["normal"], n),
                       found=d <= found_tol, u_diameter=_u(q, "diameter"), u_center=_u(q, "center_in_plane"))
        else:
            rec.update(reported=False, found=False)
        per_hole.append(rec)
        tag = f"{h['type']} d{h['edge_diameter'] / scale:.2f}"
        if st == "full":
            if not rec["reported"]:
                fails.append(f"{tag}: not found")
                continue
            if not rec["found"]:
                fails.append(f"{tag}: center off by {rec['center_err'] / scale:.3f} mm")
                continue
            if rec["partial"]:
                fails.append(f"{tag}: reported partial")
            tc = max(CENTER_MM * scale, CENTER_P * p) + CENTER_S * s
            td = max(DIAM_MM * scale, DIAM_P * p) + DIAM_S * s + h.get("edge_roundness", 0.0) / 2
            rec.update(center_tol=tc, diameter_tol=td)
            if rec["center_err"] > tc:
                fails.append(f"{tag}: center {rec['center_err'] / scale * 1000:.0f} um > {tc / scale * 1000:.0f}")
            if abs(rec["diameter_err"]) > td:
                fails.append(f"{tag}: diameter {rec['diameter_err'] / scale * 1000:+.0f} um, tol {td / scale * 1000:.0f}")
            if rec["normal_err"] > NORMAL_DEG:
                fails.append(f"{tag}: normal {rec['normal_err']:.3f} deg")
        elif st == "partial" and rec["reported"] and not rec["partial"]:
            fails.append(f"{tag}: cut by the border, reported as full")
    extras = []
    for j, q in enumerate(rep):
        if j in used:
            continue
        where = "on plain material"
        for c in cuts:
            if np.linalg.norm(np.subtract(q["center"], c["centroid"])) < c["size"] / 2 + found_tol:
                where = f"on a {c['kind']}"
        extras.append({"center": q["center"], "diameter": q["diameter"], "partial": q.get("partial"), "where": where})
        fails.append(f"extra {'partial ' if q.get('partial') else ''}hole d{q['diameter'] / scale:.2f} {where}")
    return fails, per_hole, extras


# ---------------------------------------------------------------------------------------------------
# Suites: scans, their truth (normalised to the validation suite's form) and their pitch and noise
# ---------------------------------------------------------------------------------------------------
def _normalise_truth(raw):
    """The truth in the validation suite's form (see the module docstring for what is accepted)."""
    def hole(h):
        status = h.get("status") or ("partial" if h.get("partial") else "full")
        return dict(h, center=list(h["center"]), edge_diameter=float(h.get("edge_diameter", h.get("diameter"))),
                    surface_normal=list(h.get("surface_normal", h.get("normal", h.get("axis")))), status=status,
                    type=h.get("type", "hole"), edge_roundness=float(h.get("edge_roundness", 0.0)))

    cutouts = list(raw.get("cutouts", []))
    for f in raw.get("features", []):
        size = f.get("length") or f.get("diameter") or f.get("size") or 0.0
        cutouts.append({"centroid": list(f["center"]), "size": float(size), "kind": f.get("kind", "feature")})
    return {"units": raw.get("units", "mm"), "holes": [hole(h) for h in raw.get("holes", [])],
            "holes_on_other_surfaces": [hole(h) for h in raw.get("holes_on_other_surfaces", [])],
            "cutouts": cutouts}


def find_scans(suite, only=None):
    """[(scan path, case dict or None, normalised truth)] of a folder, in cases.json's order if it has one."""
    suite = Path(suite)
    cases = {}
    index = suite / "cases.json"
    if index.exists():
        cases = {c["scan"]: c for c in json.loads(index.read_text())["cases"]}
    scans = []
    for truth_file in sorted(suite.glob("*.truth.json")):
        stem = truth_file.name[: -len(".truth.json")]
        found = [suite / (stem + ext) for ext in SCAN_EXTENSIONS if (suite / (stem + ext)).exists()]
        if not found or (only and only not in stem):
            continue
        raw = json.loads(truth_file.read_text())
        scans.append((found[0], cases.get(found[0].name), raw))
    order = list(cases)
    scans.sort(key=lambda s: (order.index(s[0].name) if s[0].name in cases else len(order), s[0].name))
    return scans


def scan_case(case, raw, points):
    """(pitch, noise, view_dir or None, where they came from) of a scan, in its units."""
    if case is not None:
        return float(case["pitch"]), float(case["noise"]), case.get("view_dir"), "cases.json"
    view = raw.get("view_dir")
    if "pitch" in raw:
        return float(raw["pitch"]), float(raw.get("noise", 0.0)), view, "truth"
    prof = raw.get("profiler")
    if prof and "point_pitch" in prof:
        k = float(prof.get("unit_scale", 1.0))
        return (k * max(prof["point_pitch"], prof.get("line_pitch") or 0.0), k * float(prof.get("range_noise", 0.0)),
                view or prof.get("view"), "profiler")
    return float(median_spacing(points)), 0.0, view, "estimated"


# ---------------------------------------------------------------------------------------------------
# What the two peers share: spacing, plane frames, the checks a user would make on a circle
# ---------------------------------------------------------------------------------------------------
MAX_PLANES = 3            # planes segmented, largest first
MIN_PLANE_SHARE = 0.10    # a plane must hold this share of the points
PLANE_T = 3.0             # plane inlier threshold, in h
RADIUS_HA, RADIUS_H = 3.0, 2.5  # boundary search radius R = max(3 ha, 2.5 h)
BORDER_R = 2.0            # a cluster within 2 R of the plane's convex hull is the scan's border
MIN_RADIUS_R = 2.0        # a hole's radius is at least 2 R
MAX_GAP_DEG = 90.0        # largest gap in a hole's boundary points' angles (was 60: a tilted scan's occluded
                          # countersink left 61; three quarters closed is what a user would ask)
MAX_RMS_HA = 1.0          # a round circle's RMS residual, in ha
MAX_FILL = 0.01           # share of the disk's expected points that may lie in it
MIN_CLUSTER = 8
BIAS_HA = 0.25            # the innermost points' mean offset outside the edge, in ha (see lift)


def median_spacing(points):
    d, _ = cKDTree(points).query(points, k=2)
    return float(np.median(d[:, 1]))


def plane_frame(normal):
    n = np.asarray(normal, float) / np.linalg.norm(normal)
    a = np.array([1.0, 0.0, 0.0]) if abs(n[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    u = np.cross(n, a)
    u /= np.linalg.norm(u)
    return n, u, np.cross(n, u)


class Plane:
    """A plane's points in its own 2D frame, with the scales and the hull the checks need."""

    def __init__(self, points, normal, h):
        self.points = points
        self.origin = points.mean(axis=0)
        self.n, self.u, self.v = plane_frame(normal)
        self.uv = (points - self.origin) @ np.column_stack([self.u, self.v])
        self.hull = ConvexHull(self.uv)
        self.h = h
        self.ha = max(h, math.sqrt(self.hull.volume / len(points)))  # volume of a 2D hull: its area
        self.R = max(RADIUS_HA * self.ha, RADIUS_H * h)
        self.tree = cKDTree(self.uv)

    def hull_distance(self, uv):
        eq = self.hull.equations  # a x + b <= 0 inside
        return np.min(-(uv @ eq[:, :2].T + eq[:, 2]), axis=1)


def arc_gap_deg(uv, center):
    a = np.sort(np.arctan2(uv[:, 1] - center[1], uv[:, 0] - center[0]))
    gaps = np.diff(np.concatenate([a, a[:1] + 2 * math.pi]))
    return math.degrees(float(gaps.max()))


def circle_rms(uv, center, r):
    return float(np.sqrt(np.mean((np.linalg.norm(uv - center, axis=1) - r) ** 2)))


def believe_hole(plane, uv, center, r):
    """None when a user would take the circle as a hole, else why not."""
    if r < MIN_RADIUS_R * plane.R:
        return "small"
    if circle_rms(uv, center, r) > MAX_RMS_HA * plane.ha:
        return "not round"
    if arc_gap_deg(uv, center) > MAX_GAP_DEG:
        return "not closed"
    inner = r - 2 * plane.ha
    if inner > 0:
        inside = len(plane.tree.query_ball_point(center, inner))
        if inside > MAX_FILL * math.pi * inner**2 / plane.ha**2:
            return "not empty"
    return None


def lift(plane, center, r, fit):
    """The hole in 3D, measured again on its own surface: ``fit(uv, center, r) -> (center, radius)``.

    The surface around the hole is refitted on the plane's points of the annulus r + R .. 2 r: a plane
    (SVD), then heights over it as a quadric (curved sheets); its RMS residual s says which points lie
    on it (within max(3 s, 0.1 h): a countersink's cone leaves it, though the segmentation's 3 h kept
    its top). In each angular sector (about 2 ha wide at the rim) the point nearest the center is the
    last point of material, and the circle is fitted to those. They lie outside the edge: by 0.32 to
    0.52 ha on exact lattices of aspect 1 to 5 (holes of 1.5-4 mm at random positions), by 0.18 ha on
    holecli's profiler simulator (a 5 mm through hole, 0.1 mm pitch), so the radius is reduced by
    ``BIAS_HA`` = 0.25 ha, a user's calibration on simulated scans. The center is lifted onto the
    quadric, the normal is the quadric's there.
    """
    near = np.asarray(plane.tree.query_ball_point(center, 2 * r), int)
    dist = np.linalg.norm(plane.uv[near] - center, axis=1)
    ring = near[dist >= r + plane.R]
    if len(ring) < 20:
        return None
    origin = plane.points[ring].mean(axis=0)
    n, u, v = plane_frame(np.linalg.svd(plane.points[ring] - origin, full_matrices=False)[2][2])
    frame = np.column_stack([u, v, n])

    def design(ab):
        a, b = ab[:, 0], ab[:, 1]
        return np.column_stack([np.ones_like(a), a, b, a * a, a * b, b * b])

    local_ring = (plane.points[ring] - origin) @ frame
    q = np.linalg.lstsq(design(local_ring[:, :2]), local_ring[:, 2], rcond=None)[0]
    s = float(np.sqrt(np.mean((local_ring[:, 2] - design(local_ring[:, :2]) @ q) ** 2)))
    disk = (plane.points[near[dist <= r + 2 * plane.R]] - origin) @ frame
    local = disk[np.abs(disk[:, 2] - design(disk[:, :2]) @ q) <= max(3 * s, 0.1 * plane.h), :2]
    c0 = ((plane.origin + center[0] * plane.u + center[1] * plane.v - origin) @ frame)[:2]
    sectors = int(np.clip(2 * math.pi * r / (2 * plane.ha), 16, 360))
    angle = np.arctan2(local[:, 1] - c0[1], local[:, 0] - c0[0])
    sector = ((angle + math.pi) / (2 * math.pi) * sectors).astype(int) % sectors
    order = np.lexsort((np.linalg.norm(local - c0, axis=1), sector))
    first = np.r_[True, sector[order][1:] != sector[order][:-1]]
    rim = local[order][first]
    if len(rim) < MIN_CLUSTER:
        return None
    (a0, b0), r2 = fit(rim, c0, r)
    w0 = float((design(np.array([[a0, b0]])) @ q)[0])
    normal = n - (q[1] + 2 * q[3] * a0 + q[4] * b0) * u - (q[2] + q[4] * a0 + 2 * q[5] * b0) * v
    return {"center": (origin + a0 * u + b0 * v + w0 * n).tolist(),
            "diameter": float(2 * (r2 - BIAS_HA * plane.ha)),
            "normal": (normal / np.linalg.norm(normal)).tolist(), "partial": False}


def lsq_circle(uv, center, r):
    res = least_squares(lambda x: np.linalg.norm(uv - x[:2], axis=1) - x[2], [center[0], center[1], r])
    return res.x[:2], float(res.x[2])


# ---------------------------------------------------------------------------------------------------
# Peer A: Open3D plane segmentation, boundary points, DBSCAN, RANSAC circle + least squares
# ---------------------------------------------------------------------------------------------------
def _ransac_circle(uv, tol, rng, iterations=300):
    best = (None, None, np.zeros(len(uv), bool))
    for _ in range(iterations):
        a, b, c = uv[rng.choice(len(uv), 3, replace=False)]
        d = 2 * (a[0] * (b[1] - c[1]) + b[0] * (c[1] - a[1]) + c[0] * (a[1] - b[1]))
        if abs(d) < 1e-12 * max(1.0, float(np.abs(uv).max())) ** 2:
            continue
        ux = ((a @ a) * (b[1] - c[1]) + (b @ b) * (c[1] - a[1]) + (c @ c) * (a[1] - b[1])) / d
        uy = ((a @ a) * (c[0] - b[0]) + (b @ b) * (a[0] - c[0]) + (c @ c) * (b[0] - a[0])) / d
        center = np.array([ux, uy])
        r = float(np.linalg.norm(a - center))
        inl = np.abs(np.linalg.norm(uv - center, axis=1) - r) <= tol
        if inl.sum() > best[2].sum():
            best = (center, r, inl)
    return best


def peer_open3d(points, seed=0):
    """Holes (dicts: center, diameter, normal, partial) by the Open3D recipe."""
    import open3d as o3d

    o3d.utility.random.seed(seed)
    shift = points.mean(axis=0)
    pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points - shift))
    h = float(np.median(np.asarray(pcd.compute_nearest_neighbor_distance())))
    total, holes = len(points), []
    for _ in range(MAX_PLANES):
        if len(pcd.points) < MIN_PLANE_SHARE * total:
            break
        model, inliers = pcd.segment_plane(distance_threshold=PLANE_T * h, ransac_n=3, num_iterations=1000)
        if len(inliers) < MIN_PLANE_SHARE * total:
            break
        plane = Plane(np.asarray(pcd.select_by_index(inliers).points), model[:3], h)
        pcd = pcd.select_by_index(inliers, invert=True)
        tpc = o3d.t.geometry.PointCloud(o3d.core.Tensor(plane.points))
        tpc.point.normals = o3d.core.Tensor(np.tile(plane.n, (len(plane.points), 1)))
        _, mask = tpc.compute_boundary_points(plane.R, max_nn=60, angle_threshold=90.0)
        edge = np.flatnonzero(mask.numpy())
        if len(edge) < MIN_CLUSTER:
            continue
        bpcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(plane.points[edge]))
        labels = np.asarray(bpcd.cluster_dbscan(eps=plane.R, min_points=3))
        for label in range(labels.max() + 1):
            uv = plane.uv[edge[labels == label]]
            if len(uv) < MIN_CLUSTER or plane.hull_distance(uv).min() < BORDER_R * plane.R:
                continue
            # a fresh generator per cluster: DBSCAN's labels come in no fixed order (it runs in threads)
            center, r, inl = _ransac_circle(uv, plane.ha, np.random.default_rng(seed))
            if center is None:
                continue
            center, r = lsq_circle(uv[inl], center, r)  # refine, take the inliers again, refine
            inl = np.abs(np.linalg.norm(uv - center, axis=1) - r) <= plane.ha
            if inl.sum() < max(MIN_CLUSTER, 0.7 * len(uv)):
                continue
            center, r = lsq_circle(uv[inl], center, r)
            if believe_hole(plane, uv[inl], center, r) is None:
                holes.append(lift(plane, center, r, lambda p, c, r0: lsq_circle(p, c, r0)))
    holes = [hole for hole in holes if hole is not None]
    for hole in holes:
        hole["center"] = (np.asarray(hole["center"]) + shift).tolist()
    return holes


# ---------------------------------------------------------------------------------------------------
# Peer B: PCL-style: RANSAC plane, angle-criterion boundary, Euclidean clustering, Taubin circle
# ---------------------------------------------------------------------------------------------------
def _ransac_plane(points, threshold, rng, iterations=500):
    best = np.zeros(len(points), bool)
    for _ in range(iterations):
        a, b, c = points[rng.choice(len(points), 3, replace=False)]
        n = np.cross(b - a, c - a)
        if np.linalg.norm(n) == 0:
            continue
        inl = np.abs((points - a) @ (n / np.linalg.norm(n))) <= threshold
        if inl.sum() > best.sum():
            best = inl
    origin = points[best].mean(axis=0)  # refine on the inliers (SVD), then take the inliers again
    n = np.linalg.svd(points[best] - origin, full_matrices=False)[2][2]
    return n, np.abs((points - origin) @ n) <= threshold


def boundary_angle_criterion(uv, radius, k=30, threshold_deg=90.0):
    """PCL's BoundaryEstimation in the plane: a point whose neighbours leave an angular gap > threshold."""
    d, idx = cKDTree(uv).query(uv, k=k + 1, distance_upper_bound=radius)
    nb = idx[:, 1:]
    ok = np.isfinite(d[:, 1:])
    safe = np.where(ok, nb, 0)
    ang = np.sort(np.where(ok, np.arctan2(uv[safe, 1] - uv[:, 1:2], uv[safe, 0] - uv[:, :1]), np.inf), axis=1)
    count = ok.sum(axis=1)
    valid = np.arange(k)[None, :] < count[:, None]
    ang = np.where(valid, ang, 0.0)
    gaps = np.where(valid[:, 1:], np.diff(ang, axis=1), 0.0).max(axis=1)
    wrap = ang[:, 0] + 2 * math.pi - ang[np.arange(len(uv)), np.maximum(count - 1, 0)]
    return (np.maximum(gaps, wrap) > math.radians(threshold_deg)) | (count < 3)


def euclidean_clusters(uv, tolerance):
    pairs = cKDTree(uv).query_pairs(tolerance, output_type="ndarray")
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(len(uv), len(uv)))
    return connected_components(graph, directed=False)[1]


def taubin_circle(uv):
    """The algebraic circle of Taubin (1991), by the SVD route of Chernov's ``TaubinSVD``."""
    mean = uv.mean(axis=0)
    x, y = (uv - mean).T
    z = x * x + y * y
    zmean = z.mean()
    z0 = (z - zmean) / (2 * math.sqrt(zmean))
    v = np.linalg.svd(np.column_stack([z0, x, y]), full_matrices=False)[2][2]
    a = np.array([v[0] / (2 * math.sqrt(zmean)), v[1], v[2], -zmean * v[0] / (2 * math.sqrt(zmean))])
    center = -a[1:3] / (2 * a[0])
    r = math.sqrt(a[1] ** 2 + a[2] ** 2 - 4 * a[0] * a[3]) / (2 * abs(a[0]))
    return center + mean, r


def _trimmed_taubin(uv):
    center, r = taubin_circle(uv)
    res = np.linalg.norm(uv - center, axis=1) - r
    mad = 1.4826 * np.median(np.abs(res - np.median(res)))
    keep = np.abs(res - np.median(res)) <= 3 * mad if mad > 0 else np.ones(len(uv), bool)
    if keep.sum() >= MIN_CLUSTER:
        center, r = taubin_circle(uv[keep])
    return center, r, keep


def peer_pcl(points, seed=0):
    """Holes (dicts: center, diameter, normal, partial) by the PCL-style recipe."""
    rng = np.random.default_rng(seed)
    shift = points.mean(axis=0)
    rest = points - shift
    h = median_spacing(rest)
    total, holes = len(points), []
    for _ in range(MAX_PLANES):
        if len(rest) < MIN_PLANE_SHARE * total:
            break
        normal, inl = _ransac_plane(rest, PLANE_T * h, rng)
        if inl.sum() < MIN_PLANE_SHARE * total:
            break
        plane = Plane(rest[inl], normal, h)
        rest = rest[~inl]
        edge = np.flatnonzero(boundary_angle_criterion(plane.uv, plane.R))
        if len(edge) < MIN_CLUSTER:
            continue
        labels = euclidean_clusters(plane.uv[edge], plane.R)
        for label in np.unique(labels):
            uv = plane.uv[edge[labels == label]]
            if len(uv) < MIN_CLUSTER or plane.hull_distance(uv).min() < BORDER_R * plane.R:
                continue
            center, r, keep = _trimmed_taubin(uv)
            if keep.sum() < 0.7 * len(uv) or believe_hole(plane, uv[keep], center, r) is not None:
                continue
            holes.append(lift(plane, center, r, lambda p, c, r0: _trimmed_taubin(p)[:2]))
    holes = [hole for hole in holes if hole is not None]
    for hole in holes:
        hole["center"] = (np.asarray(hole["center"]) + shift).tolist()
    return holes


# ---------------------------------------------------------------------------------------------------
# holecli, and the harness
# ---------------------------------------------------------------------------------------------------
def run_holecli(points, view_dir=None):
    from holecli.pipeline import detect

    detection = detect(points, view_dir=view_dir)
    return [{"center": list(h.center), "diameter": h.diameter, "normal": list(h.normal), "partial": h.partial}
            for h in detection.holes]


METHODS = {"holecli": run_holecli, "open3d": peer_open3d, "pcl": peer_pcl}


def measure_file(path, case, raw, methods=tuple(METHODS), view_dir=False):
    """One scan measured by each method and scored: a dict per method (see :func:`summarise`)."""
    from holecli.io import read_cloud

    points = np.ascontiguousarray(read_cloud(str(path)).points, dtype=np.float64)
    truth = _normalise_truth(raw)
    pitch, noise, view, source = scan_case(case, raw, points)
    scored = {"pitch": pitch, "noise": noise}
    out = {"scan": path.name, "units": truth["units"], "pitch": pitch, "noise": noise, "pitch_from": source,
           "points": len(points), "methods": {}}
    for name in methods:
        c0, w0 = time.process_time(), time.perf_counter()
        error = None
        try:
            if name == "holecli":
                holes = run_holecli(points, view_dir=view if view_dir and view is not None else None)
            else:
                holes = METHODS[name](points)
        except Exception as exc:  # a method that fails on a file has found nothing there  # noqa: BLE001
            holes, error = [], f"{type(exc).__name__}: {exc}"
        cpu, wall = time.process_time() - c0, time.perf_counter() - w0
        fails, per_hole, extras = score(scored, truth, {"holes": holes})
        if error:
            fails.insert(0, error)
        out["methods"][name] = {"ok": not fails, "fails": fails, "holes": per_hole, "extras": extras,
                                "reported": holes, "cpu_s": cpu, "wall_s": wall}
    return out


def summarise(files, methods):
    """Per method: files, files_ok, full, found, false, center/diameter errors (um), cpu_s, wall_s per file."""
    rows = {}
    for name in methods:
        runs = [(f, f["methods"][name]) for f in files if name in f["methods"]]
        ce, de, full, found = [], [], 0, 0
        for f, m in runs:
            scale = 1e-3 if f["units"] == "m" else 1.0
            for h in m["holes"]:
                if h["status"] != "full":
                    continue
                full += 1
                if h.get("found"):
                    found += 1
                    ce.append(h["center_err"] / scale * 1e3)
                    de.append(abs(h["diameter_err"]) / scale * 1e3)
        n = len(runs)
        rows[name] = {
            "files": n, "files_ok": sum(m["ok"] for _, m in runs), "full_holes": full, "found": found,
            "false_holes": sum(len(m["extras"]) for _, m in runs),
            "center_um_median": statistics.median(ce) if ce else None, "center_um_max": max(ce) if ce else None,
            "diameter_um_median": statistics.median(de) if de else None, "diameter_um_max": max(de) if de else None,
            "cpu_s_per_file": sum(m["cpu_s"] for _, m in runs) / n if n else None,
            "wall_s_per_file": sum(m["wall_s"] for _, m in runs) / n if n else None,
        }
    return rows


COLUMNS = ("method", "files ok", "holes found", "false", "center um med/max", "|d| um med/max", "cpu s/file",
           "wall s/file")


def _pair(a, b):
    return "-" if a is None else f"{a:.1f}/{b:.1f}"


def format_table(summaries):
    """One table: a block of rows per suite, a row per method."""
    lines = []
    head = f"{'suite':24s} {COLUMNS[0]:8s} {COLUMNS[1]:>9s} {COLUMNS[2]:>11s} {COLUMNS[3]:>5s} " \
           f"{COLUMNS[4]:>18s} {COLUMNS[5]:>16s} {COLUMNS[6]:>10s} {COLUMNS[7]:>11s}"
    lines += [head, "-" * len(head)]
    for suite, rows in summaries.items():
        for k, (name, r) in enumerate(rows.items()):
            lines.append(f"{(suite if k == 0 else ''):24s} {name:8s} {r['files_ok']:>4d} of {r['files']:<2d} "
                         f"{r['found']:>5d} of {r['full_holes']:<3d} {r['false_holes']:5d} "
                         f"{_pair(r['center_um_median'], r['center_um_max']):>18s} "
                         f"{_pair(r['diameter_um_median'], r['diameter_um_max']):>16s} "
                         f"{r['cpu_s_per_file']:10.2f} {r['wall_s_per_file']:11.2f}")
    return "\n".join(lines)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--suite", action="append", required=True, help="a folder of scans with NAME.truth.json")
    parser.add_argument("--only", help="only the scans whose name holds this text")
    parser.add_argument("--methods", default=",".join(METHODS), help="comma-separated, of " + ", ".join(METHODS))
    parser.add_argument("--view-dir", action="store_true", help="give holecli each scan's viewing direction")
    parser.add_argument("--json", help="write every file's results and the summary here")
    parser.add_argument("--quiet", action="store_true", help="print the table only")
    add_docs_options(parser, VALIDATION / "peers.md")
    args = parser.parse_args(argv)
    docs = docs_target(parser, args, argv, "peers.py", ["peers"])
    methods = [m.strip() for m in args.methods.split(",") if m.strip()]
    unknown = [m for m in methods if m not in METHODS]
    if unknown:
        parser.error(f"unknown method(s) {', '.join(unknown)}; expected {', '.join(METHODS)}")
    summaries, everything = {}, {}
    for suite in args.suite:
        scans = find_scans(suite, args.only)
        if not scans:
            print(f"peers: no scan with a .truth.json in {suite}" + (f" matching {args.only!r}" if args.only else ""),
                  file=sys.stderr)
            continue
        files = []
        for path, case, raw in scans:
            result = measure_file(path, case, raw, methods, view_dir=args.view_dir)
            files.append(result)
            if not args.quiet:
                verdicts = "  ".join(f"{m} {'ok' if r['ok'] else 'FAIL'} {r['cpu_s']:5.2f}s"
                                     for m, r in result["methods"].items())
                print(f"{path.stem[:52]:52s} {verdicts}", flush=True)
                for m, r in result["methods"].items():
                    if r["fails"]:
                        print(f"    {m}: {'; '.join(r['fails'])}", flush=True)
                if result["pitch_from"] == "estimated":
                    print("    (pitch estimated from the cloud, noise taken as 0)", flush=True)
        name = Path(suite).name or str(suite)
        summaries[name] = summarise(files, methods)
        everything[name] = files
    if not summaries:
        return 2
    print()
    table = format_table(summaries)
    print(table)
    if docs:
        docs.write("peers", table)
    if args.json:
        Path(args.json).write_text(json.dumps({"view_dir": args.view_dir, "summary": summaries, "files": everything},
                                              indent=1, default=float))
    return 0


if __name__ == "__main__":
    sys.exit(main())
