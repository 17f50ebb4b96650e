"""A simulated laser line profiler (Gocator / Keyence class) carried over a triangle mesh by a robot.

The sensor projects a laser *sheet* (spanned by the view direction and the line direction) onto the
part and a camera, offset from the laser along the direction of travel, images the line from the
triangulation angle. The robot moves the sensor along the motion direction and the sensor writes one
profile every ``line_pitch``. Each laser ray is cast against the mesh with open3d's
``RaycastingScene``; a hit becomes a point only if

1. the surface is not too steep for the laser (``max_incidence_deg``),
2. the camera sees it: the line of sight from the camera to the hit is not blocked by the part and
   the hit face is turned toward the camera (camera occlusion: the shadow behind a step, the far
   side of a hole's rim, most of a bore wall),
3. it survives the random dropout,

and its range along the ray then gets Gaussian noise and quantization. This reproduces the data
defects that real profiler clouds of drilled holes have, on any CAD model.

Everything here is pure (arrays in, :class:`ProfilerScan` out) apart from :func:`load_mesh`.
open3d is imported inside the functions that use it (importing it costs over a second).

Conventions
-----------
Sensor frame
    ``line`` (the laser line, sensor X), ``motion`` (robot travel, sensor Y) and ``-view`` (sensor
    Z, pointing from the part toward the sensor) form a right-handed frame: the default motion is
    ``line x view``, +y for the default line +x and view -z.
Lattice
    Profile j is taken with the laser origin at ``target - standoff * view + s_j * motion`` and
    column i aims at ``u_i`` along the line from the target line, with
    ``s_j = (j - (n_profiles - 1) / 2) * line_pitch`` and ``u_i = (i - (n_columns - 1) / 2) *
    point_pitch``: the lattice is centred on the target, ``n = floor(length / pitch) + 1``.
Fan and parallel rays
    ``fan=True``: every ray of a profile leaves the laser origin, aimed at ``target + s_j * motion +
    u_i * line`` (so the pitch along the line is ``point_pitch`` at the standoff, larger farther
    away), and the camera is one point, ``origin + baseline``. ``fan=False``: the idealized uniform-X
    output of a profiler, parallel rays along ``view`` from ``origin + u_i * line``, each seen by its
    own camera ray from ``baseline`` beside it (a telecentric camera).
Triangulation
    ``baseline = camera_side * standoff * tan(triangulation_deg) * motion``: the camera's line of
    sight meets the central laser ray at the target at ``triangulation_deg``.
Ranges
    Distance from the ray's origin to the point along the ray, in the units of the mesh (times
    ``unit_scale``); noise and quantization act on it.
Line width
    ``line_width > 0``: the laser sheet is that thick along ``motion``, and each sample is the
    centroid of ``line_subrays`` sub-rays spread evenly across it (each sub-ray the ray translated by
    its offset along ``motion``). The camera sees each lit, unoccluded sub-ray's hit and the sensor
    triangulates it as if it lay on the nominal ray: its range is where the camera's line of sight to
    the hit passes the nominal ray (closest approach; with ``triangulation_deg`` 0, the hit's
    distance along the ray). The sample's range is the mean of those of its visible sub-rays. On a
    flat face this is the range of the nominal ray; where the footprint straddles an edge (a hole's
    rim) only part of it returns light and the centroid moves: a *mixed pixel*, off the surface by
    up to ``line_width / 2 / tan(triangulation)``, toward or away from the sensor depending on the
    side of the hole.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from typing import Optional, Union

import numpy as np

from holecli.errors import LoadError, SpecError

__all__ = [
    "MESH_EXTENSIONS",
    "ProfilerScan",
    "ProfilerSpec",
    "load_mesh",
    "scan_mesh",
    "transform_to_frame",
]

MESH_EXTENSIONS = (".stl", ".ply", ".obj", ".off")

RngLike = Union[np.random.Generator, int, None]

# Two directions are perpendicular when the cosine of their angle is below this (after
# normalization); the line direction is then made exactly perpendicular to the view.
_PERPENDICULAR_COS = 1e-6
# A 4x4 frame is rigid when R @ R.T is the identity to this tolerance.
_RIGID_TOL = 1e-9
# Slack, in units of a pitch, when counting lattice steps in a length (10 / 0.1 is 99.99999...).
_COUNT_SLACK = 1e-9
# A camera ray that hits the mesh no nearer than (distance to the point - tolerance) sees the
# point; the tolerance is this fraction of (camera distance + mesh size): open3d casts in float32
# (relative resolution 6e-8), so hits on the point's own face land well inside it.
_OCCLUSION_REL = 1e-5
# Rays cast per open3d call (memory: a few hundred bytes per ray in flight).
_CHUNK_RAYS = 1 << 18
# Refuse scans that would cast more rays than this.
_MAX_RAYS = 50_000_000


@dataclass(frozen=True)
class ProfilerSpec:
    """A line profiler, its path over the part and its defects.

    Lengths are in the units of the mesh (mm for a CAD model in mm); direction vectors need not be
    unit length (they are normalized) but must not be zero.

    Attributes
    ----------
    target : (3,) tuple of float
        Centre of the scan on the part: the central laser ray of the middle profile aims at it.
    standoff : float
        Distance from the laser origin to the target along ``view``, > 0.
    view : (3,) tuple of float
        Direction of the central laser ray, from the sensor toward the part.
    line : (3,) tuple of float
        Direction of the laser line; perpendicular to ``view``.
    motion : (3,) tuple of float or None
        Direction of robot travel; perpendicular to ``view`` and ``line``. None: ``line x view``.
    line_length : float
        Field of view along the line, >= 0 (0: one point per profile).
    scan_length : float
        Robot travel, >= 0 (0: one profile).
    point_pitch : float
        Spacing of the points along the line (at the standoff for fan rays), > 0.
    line_pitch : float
        Travel between profiles, > 0.
    fan : bool
        True: rays fan out from the laser origin, as from a real line laser. False: parallel rays
        along ``view``, the uniform-X resampled output of a profiler.
    triangulation_deg : float
        Angle between the laser and the camera's line of sight at the target, in [0, 90). 0 puts
        the camera on the laser and so turns camera occlusion off.
    camera_side : int
        +1 or -1: the camera sits at ``+motion`` or ``-motion`` from the laser.
    max_incidence_deg : float
        A hit whose surface normal is more than this from the (reversed) laser ray returns too
        little light and is lost; in (0, 90].
    range_noise : float
        Gaussian sigma of the range along the ray, >= 0.
    range_quantum : float
        Ranges are rounded to multiples of this (the sensor's Z resolution), >= 0; 0: no rounding.
    float32_ranges : bool
        The sensor computes its ranges in single precision: each range is the ray cast's own float32
        hit distance (off the exact one by an ulp or two of the range, 7.6e-6 at 100, varying from
        ray to ray with the arithmetic's rounding) instead of the exact distance refined in float64.
        Noise-free, a face square to parallel rays then holds its points on a few levels an ulp
        apart, most of them on one, as the noise-free output of a real profiler does.
    dropout : float
        Probability that a visible point is lost anyway (speckle, dust), in [0, 1).
    jitter : float
        Gaussian sigma, per axis, of the robot's position error: each profile is taken from a
        sensor displaced by one random 3D vector but reported as if from the nominal pose, >= 0.
    keep_nan : bool
        True: one row per ray in lattice order, NaN for every lost point, as profilers write
        organized output. False: lost points are left out.
    frame : (4, 4) tuple or None
        Rigid transform from the part frame to the output frame (a robot base, say), its
        translation in mesh units; None: the part frame.
    unit_scale : float
        Factor applied to the output coordinates and ranges after ``frame`` (0.001: mm to m), > 0.
    float32 : bool
        Round the output coordinates and ranges through float32, as sensors write them (after
        ``frame`` and ``unit_scale``).
    line_width : float
        Thickness of the laser line along ``motion``, >= 0 (0: an ideal line, one ray per sample);
        see *Line width* in the module docstring (a few tens of um on real sensors).
    line_subrays : int
        Sub-rays per sample across ``line_width`` (used when it is > 0), >= 2.
    """

    target: tuple[float, float, float] = (0.0, 0.0, 0.0)
    standoff: float = 100.0
    view: tuple[float, float, float] = (0.0, 0.0, -1.0)
    line: tuple[float, float, float] = (1.0, 0.0, 0.0)
    motion: Optional[tuple[float, float, float]] = None
    line_length: float = 20.0
    scan_length: float = 20.0
    point_pitch: float = 0.05
    line_pitch: float = 0.05
    fan: bool = True
    triangulation_deg: float = 25.0
    camera_side: int = 1
    max_incidence_deg: float = 75.0
    range_noise: float = 0.0
    range_quantum: float = 0.0
    float32_ranges: bool = False
    dropout: float = 0.0
    jitter: float = 0.0
    keep_nan: bool = False
    frame: Optional[tuple] = None
    unit_scale: float = 1.0
    float32: bool = False
    line_width: float = 0.0
    line_subrays: int = 7


@dataclass(frozen=True, eq=False)
class ProfilerScan:
    """The cloud a simulated profiler writes, with what each point is.

    Attributes
    ----------
    points : (n, 3) float64
        Points in the output frame (``frame``, ``unit_scale``), profile by profile, along the line
        within a profile; NaN rows for lost points when ``keep_nan``.
    profile_index : (n,) int64
        Profile (robot position) of each row, 0-based in travel order.
    column_index : (n,) int64
        Position of each row along the laser line, 0-based.
    triangle_id : (n,) int64
        Triangle of the mesh the point lies on (ground truth for labels); -1 for NaN rows.
    ranges : (n,) float64
        Measured range along the ray (noise and quantization included), times ``unit_scale``.
    info : dict
        JSON-ready counts: ``rays``, ``profiles``, ``columns``, ``hits`` (rays that met the mesh),
        ``missed``, ``beyond_incidence``, ``occluded``, ``dropped`` (each hit is counted under the
        first of these three losses that applies, in that order), ``points`` (kept), ``rows``
        (``points`` plus NaN rows), ``unit_scale``.
    """

    points: np.ndarray
    profile_index: np.ndarray
    column_index: np.ndarray
    triangle_id: np.ndarray
    ranges: np.ndarray
    info: dict


# --------------------------------------------------------------------------------------------------
# Public API


def scan_mesh(vertices, triangles, spec: ProfilerSpec = ProfilerSpec(), rng: RngLike = 0) -> ProfilerScan:
    """Scan a triangle mesh with a simulated laser line profiler.

    Parameters
    ----------
    vertices : (m, 3) array_like of float
        Mesh vertices in the part frame, finite.
    triangles : (k, 3) array_like of int
        Vertex indices of each triangle, in [0, m); k >= 1. Orientation (winding) does not matter.
    spec : ProfilerSpec
        The sensor, its path and its defects; validated here.
    rng : numpy.random.Generator, int or None
        Random source or seed of the noise, dropout and jitter (default 0: reproducible).

    Returns
    -------
    ProfilerScan

    Raises
    ------
    holecli.errors.SpecError
        (a ValueError) when the mesh or a field of ``spec`` is invalid, or the scan would cast more
        than 50 million rays.
    """
    verts, tris = _check_mesh(vertices, triangles)
    geo = _geometry(spec)
    rng = np.random.default_rng(rng)
    return _scan(verts, tris, spec, geo, rng)


def transform_to_frame(points, matrix=None, unit_scale: float = 1.0) -> np.ndarray:
    """Move points into another frame by a rigid transform, then scale them.

    Parameters
    ----------
    points : (n, 3) array_like of float
        Points; NaN rows stay NaN.
    matrix : (4, 4) array_like of float or None
        Rigid transform ``[[R, t], [0, 0, 0, 1]]`` (``R`` a proper rotation), ``t`` in the units of
        ``points``; None: the identity.
    unit_scale : float
        Factor applied after the transform, > 0.

    Returns
    -------
    (n, 3) float64
        ``unit_scale * (points @ R.T + t)``.

    Raises
    ------
    holecli.errors.SpecError
        (a ValueError) when an argument is invalid.
    """
    pts = np.asarray(points, dtype=np.float64)
    if pts.ndim != 2 or pts.shape[1] != 3:
        _fail("points", "an (n, 3) array", f"shape {pts.shape}")
    rigid = None if matrix is None else _rigid_matrix("matrix", matrix)
    if not (_finite(unit_scale) and unit_scale > 0):
        _fail("unit_scale", "a finite number > 0", unit_scale)
    return _transform(pts, rigid, float(unit_scale))


def load_mesh(path):
    """Read the vertices and triangles of an STL, PLY, OBJ or OFF mesh file.

    Parameters
    ----------
    path : str or os.PathLike
        The mesh file; its extension (any case) selects the format.

    Returns
    -------
    vertices : (m, 3) float64
    triangles : (k, 3) int64
        k >= 1, indices in [0, m).

    Raises
    ------
    holecli.errors.LoadError
        When the file is missing, not a regular file, of another format, or holds no triangle or
        non-finite vertices (open3d reports a bad file only as an empty mesh, so that is checked).
    """
    name = os.fspath(path)
    extension = os.path.splitext(name)[1].lower()
    if extension not in MESH_EXTENSIONS:
        raise LoadError(name, f"unsupported mesh extension {extension!r} "
                              f"(expected {', '.join(MESH_EXTENSIONS)})")
    if not os.path.exists(name):
        raise LoadError(name, "no such file")
    if not os.path.isfile(name):
        raise LoadError(name, "not a regular file")
    import open3d as o3d

    # open3d reports a bad file on stdout, which carries data only in this package: silence it,
    # the checks below say what is wrong.
    with o3d.utility.VerbosityContextManager(o3d.utility.VerbosityLevel.Error):
        mesh = o3d.io.read_triangle_mesh(name)
    vertices = np.asarray(mesh.vertices, dtype=np.float64)
    triangles = np.asarray(mesh.triangles, dtype=np.int64)
    if len(triangles) == 0:
        raise LoadError(name, "no triangles read (empty, damaged or not a mesh file)")
    if not np.all(np.isfinite(vertices)):
        raise LoadError(name, "non-finite vertex coordinates")
    if triangles.min() < 0 or triangles.max() >= len(vertices):
        raise LoadError(name, "triangle vertex index out of range")
    return np.ascontiguousarray(vertices), np.ascontiguousarray(triangles)


# --------------------------------------------------------------------------------------------------
# Validation


@dataclass(frozen=True, eq=False)
class _Geometry:
    """The validated, normalized sensor geometry of a spec."""

    target: np.ndarray
    view: np.ndarray
    line: np.ndarray
    motion: np.ndarray
    baseline: np.ndarray
    columns: np.ndarray     # u_i, (n_columns,)
    stations: np.ndarray    # s_j, (n_profiles,)
    frame: Optional[np.ndarray]


def _fail(name, expected, value):
    raise SpecError(f"{name} must be {expected}, got {value!r}")


def _finite(value) -> bool:
    """A real number (not a bool, not a string) that is finite."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer, np.floating)):
        return False
    return math.isfinite(float(value))


def _number(name, value, low=None, high=None, low_open=False, high_open=False, text=None):
    ok = _finite(value)
    if ok and low is not None:
        ok = value > low if low_open else value >= low
    if ok and high is not None:
        ok = value < high if high_open else value <= high
    if not ok:
        _fail(name, text, value)
    return float(value)


def _direction(name, value) -> np.ndarray:
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        arr = None
    if arr is None or arr.shape != (3,) or not np.all(np.isfinite(arr)):
        _fail(name, "3 finite numbers (a direction)", value)
    norm = float(np.linalg.norm(arr))
    if not norm > 0 or not math.isfinite(norm):
        _fail(name, "a non-zero direction", value)
    return arr / norm


def _rigid_matrix(name, value) -> np.ndarray:
    try:
        mat = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        mat = None
    if mat is None or mat.shape != (4, 4) or not np.all(np.isfinite(mat)):
        _fail(name, "a 4x4 matrix of finite numbers", value)
    rot = mat[:3, :3]
    if (not np.allclose(mat[3], [0.0, 0.0, 0.0, 1.0], rtol=0, atol=_RIGID_TOL)
            or not np.allclose(rot @ rot.T, np.eye(3), rtol=0, atol=_RIGID_TOL)
            or np.linalg.det(rot) < 0):
        _fail(name, "a rigid transform [[R, t], [0, 0, 0, 1]] with R a proper rotation "
                    "(R @ R.T = I, det R = +1)", mat.tolist())
    return mat


def _flag(name, value):
    if not isinstance(value, (bool, np.bool_)):
        _fail(name, "True or False", value)


def _lattice(length: float, pitch: float) -> np.ndarray:
    n = int(math.floor(length / pitch + _COUNT_SLACK)) + 1
    return (np.arange(n) - (n - 1) / 2.0) * pitch


def _geometry(spec: ProfilerSpec) -> _Geometry:
    if not isinstance(spec, ProfilerSpec):
        _fail("spec", "a ProfilerSpec", spec)
    try:
        target = np.asarray(spec.target, dtype=np.float64)
    except (TypeError, ValueError):
        target = None
    if target is None or target.shape != (3,) or not np.all(np.isfinite(target)):
        _fail("target", "3 finite numbers (a point on the part)", spec.target)
    standoff = _number("standoff", spec.standoff, 0, low_open=True, text="a finite number > 0")
    view = _direction("view", spec.view)
    line = _direction("line", spec.line)
    cos = float(abs(view @ line))
    if cos > _PERPENDICULAR_COS:
        raise SpecError(f"line must be perpendicular to view, got an angle of "
                        f"{math.degrees(math.acos(min(cos, 1.0))):.6g} deg between them")
    line = line - (line @ view) * view
    line /= np.linalg.norm(line)
    default_motion = np.cross(line, view)
    if spec.motion is None:
        motion = default_motion
    else:
        motion = _direction("motion", spec.motion)
        if abs(abs(float(motion @ default_motion)) - 1.0) > _PERPENDICULAR_COS:
            _fail("motion", "None or perpendicular to both view and line (+-line x view)",
                  spec.motion)
        motion = np.sign(motion @ default_motion) * default_motion
    line_length = _number("line_length", spec.line_length, 0, text="a finite number >= 0")
    scan_length = _number("scan_length", spec.scan_length, 0, text="a finite number >= 0")
    point_pitch = _number("point_pitch", spec.point_pitch, 0, low_open=True,
                          text="a finite number > 0")
    line_pitch = _number("line_pitch", spec.line_pitch, 0, low_open=True, text="a finite number > 0")
    _flag("fan", spec.fan)
    tri = _number("triangulation_deg", spec.triangulation_deg, 0, 90, high_open=True,
                  text="a finite angle in [0, 90) degrees")
    if spec.camera_side not in (1, -1) or isinstance(spec.camera_side, bool):
        _fail("camera_side", "+1 or -1", spec.camera_side)
    _number("max_incidence_deg", spec.max_incidence_deg, 0, 90, low_open=True,
            text="a finite angle in (0, 90] degrees")
    _number("range_noise", spec.range_noise, 0, text="a finite number >= 0")
    _number("range_quantum", spec.range_quantum, 0, text="a finite number >= 0 (0: no rounding)")
    _number("dropout", spec.dropout, 0, 1, high_open=True, text="a probability in [0, 1)")
    _number("jitter", spec.jitter, 0, text="a finite number >= 0")
    _flag("keep_nan", spec.keep_nan)
    _flag("float32", spec.float32)
    _flag("float32_ranges", spec.float32_ranges)
    frame = None if spec.frame is None else _rigid_matrix("frame", spec.frame)
    _number("unit_scale", spec.unit_scale, 0, low_open=True, text="a finite number > 0")
    _number("line_width", spec.line_width, 0, text="a finite number >= 0 (0: an ideal line)")
    if (isinstance(spec.line_subrays, (bool, np.bool_)) or not isinstance(spec.line_subrays, (int, np.integer))
            or spec.line_subrays < 2):
        _fail("line_subrays", "an integer >= 2", spec.line_subrays)

    columns = _lattice(line_length, point_pitch)
    stations = _lattice(scan_length, line_pitch)
    rays = len(columns) * len(stations) * (int(spec.line_subrays) if spec.line_width > 0 else 1)
    if rays > _MAX_RAYS:
        raise SpecError(f"the scan must cast at most {_MAX_RAYS} rays, got {rays} "
                        f"({len(stations)} profiles of {len(columns)} points"
                        f"{f' of {spec.line_subrays} sub-rays' if spec.line_width > 0 else ''}): "
                        f"raise point_pitch or line_pitch")
    baseline = spec.camera_side * standoff * math.tan(math.radians(tri)) * motion
    return _Geometry(target=target, view=view, line=line, motion=motion, baseline=baseline,
                     columns=columns, stations=stations, frame=frame)


def _check_mesh(vertices, triangles):
    try:
        verts = np.asarray(vertices, dtype=np.float64)
    except (TypeError, ValueError):
        verts = None
    if verts is None or verts.ndim != 2 or verts.shape[1] != 3 or len(verts) < 3:
        _fail("vertices", "an (m, 3) array of numbers with m >= 3",
              f"shape {getattr(verts, 'shape', None)}")
    if not np.all(np.isfinite(verts)):
        _fail("vertices", "finite", "non-finite coordinates")
    tris = np.asarray(triangles)
    if tris.ndim != 2 or tris.shape[1] != 3 or len(tris) < 1:
        _fail("triangles", "a (k, 3) array of vertex indices with k >= 1", f"shape {tris.shape}")
    if not np.issubdtype(tris.dtype, np.integer):
        _fail("triangles", "integer vertex indices", f"dtype {tris.dtype}")
    if tris.min() < 0 or tris.max() >= len(verts):
        _fail("triangles", f"indices in [0, {len(verts)})",
              f"indices in [{tris.min()}, {tris.max()}]")
    return np.ascontiguousarray(verts), np.ascontiguousarray(tris, dtype=np.int64)


# --------------------------------------------------------------------------------------------------
# Kernel


def _transform(pts: np.ndarray, frame: Optional[np.ndarray], scale: float) -> np.ndarray:
    if frame is not None:
        pts = pts @ frame[:3, :3].T + frame[:3, 3]
    if scale != 1.0:
        pts = pts * scale
    return pts


def _scan(verts, tris, spec: ProfilerSpec, geo: _Geometry, rng: np.random.Generator) -> ProfilerScan:
    import open3d as o3d

    # Cast in coordinates centred on the mesh so float32 keeps its resolution for a part far from
    # the origin; hit distances are then refined in float64 on the hit triangle's plane.
    lo, hi = verts.min(axis=0), verts.max(axis=0)
    centre = 0.5 * (lo + hi)
    size = float(np.linalg.norm(hi - lo))
    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(o3d.core.Tensor(np.ascontiguousarray(verts - centre, dtype=np.float32)),
                        o3d.core.Tensor(np.ascontiguousarray(tris, dtype=np.uint32)))
    v0 = verts[tris[:, 0]] - centre
    normals = np.cross(verts[tris[:, 1]] - verts[tris[:, 0]], verts[tris[:, 2]] - verts[tris[:, 0]])
    lengths = np.linalg.norm(normals, axis=1)
    cos_limit = math.cos(math.radians(spec.max_incidence_deg))
    occlusion = spec.triangulation_deg > 0
    tolerance = _OCCLUSION_REL * (spec.standoff / math.cos(math.radians(spec.triangulation_deg))
                                  + size)

    n_cols, n_prof = len(geo.columns), len(geo.stations)
    # Drawn up front, so the jitter of a profile does not depend on the chunking.
    shifts = (rng.normal(0.0, spec.jitter, (n_prof, 3)) if spec.jitter > 0
              else np.zeros((n_prof, 3)))
    origins = (geo.target - centre - spec.standoff * geo.view) + geo.stations[:, None] * geo.motion
    if spec.fan:
        aims = spec.standoff * geo.view + geo.columns[:, None] * geo.line
        fan_dirs = aims / np.linalg.norm(aims, axis=1, keepdims=True)

    def trace(actual, dirs):
        """The rays from ``actual`` along ``dirs`` that give a point: their rows, triangles and
        distances along the ray, and the counts (hits, beyond_incidence, occluded) with the rows
        that met the mesh (``"hit_rows"``) and were lit (``"lit_rows"``)."""
        ans = scene.cast_rays(o3d.core.Tensor(np.hstack([actual, dirs]).astype(np.float32)))
        prim = ans["primitive_ids"].numpy().astype(np.int64)
        hit = np.flatnonzero(prim != o3d.t.geometry.RaycastingScene.INVALID_ID)
        lost = dict(hits=len(hit), beyond_incidence=0, occluded=0)
        tid = prim[hit]
        d = dirs[hit]
        n = normals[tid]
        nd = np.einsum("ij,ij->i", n, d)
        with np.errstate(divide="ignore", invalid="ignore"):
            cos_inc = np.abs(nd) / lengths[tid]
            t = np.einsum("ij,ij->i", n, v0[tid] - actual[hit]) / nd
        bad_t = ~np.isfinite(t)
        t[bad_t] = ans["t_hit"].numpy()[hit][bad_t]
        if spec.float32_ranges:
            t = ans["t_hit"].numpy()[hit].astype(np.float64)
        lit = np.isfinite(cos_inc) & (cos_inc > 0) & (cos_inc >= cos_limit)
        lost["beyond_incidence"] = int(np.count_nonzero(~lit))
        hit_rows = hit
        hit, tid, d, n, nd, t = hit[lit], tid[lit], d[lit], n[lit], nd[lit], t[lit]
        lost["hit_rows"], lost["lit_rows"] = hit_rows, hit

        if occlusion:
            point = actual[hit] + t[:, None] * d
            camera = actual[hit] + geo.baseline
            sight = point - camera
            dist = np.linalg.norm(sight, axis=1)
            sight /= dist[:, None]
            cam = scene.cast_rays(o3d.core.Tensor(np.hstack([camera, sight]).astype(np.float32)))
            t_cam = cam["t_hit"].numpy().astype(np.float64)
            # The face must be turned toward the camera as well as toward the laser (nd < 0 after
            # orienting n against the ray): an open sheet seen from behind is not seen.
            facing = -np.sign(nd) * np.einsum("ij,ij->i", n, camera - point) > 0
            seen = facing & ((t_cam >= dist - tolerance) | ~np.isfinite(t_cam))
            lost["occluded"] = int(np.count_nonzero(~seen))
            hit, tid, t = hit[seen], tid[seen], t[seen]
        return hit, tid, t, lost

    counts = dict(hits=0, beyond_incidence=0, occluded=0, dropped=0)
    parts = []
    per_chunk = max(1, _CHUNK_RAYS // n_cols)
    for j0 in range(0, n_prof, per_chunk):
        j1 = min(n_prof, j0 + per_chunk)
        prof = np.repeat(np.arange(j0, j1), n_cols)
        col = np.tile(np.arange(n_cols), j1 - j0)
        nominal = origins[prof]
        if spec.fan:
            dirs = fan_dirs[col]
        else:
            nominal = nominal + geo.columns[col, None] * geo.line
            dirs = np.broadcast_to(geo.view, nominal.shape)
        actual = nominal + shifts[prof]
        if spec.line_width > 0:
            hit, tid, t, lost = _wide_line(trace, actual, dirs, geo, spec)
        else:
            hit, tid, t, lost = trace(actual, dirs)
        d = dirs[hit]
        for key in counts:
            counts[key] += lost.get(key, 0)

        if spec.dropout > 0:
            kept = rng.random(len(hit)) >= spec.dropout
            counts["dropped"] += int(np.count_nonzero(~kept))
            hit, tid, d, t = hit[kept], tid[kept], d[kept], t[kept]

        if spec.range_noise > 0:
            t = t + rng.normal(0.0, spec.range_noise, len(t))
        if spec.range_quantum > 0:
            t = np.round(t / spec.range_quantum) * spec.range_quantum
        # The controller reports the nominal pose: a jittered profile lands displaced.
        pts = nominal[hit] + t[:, None] * d + centre
        if spec.keep_nan:
            rows = len(prof)
            full = np.full((rows, 3), np.nan)
            full[hit] = pts
            full_t = np.full(rows, np.nan)
            full_t[hit] = t
            full_tid = np.full(rows, -1, dtype=np.int64)
            full_tid[hit] = tid
            parts.append((full, prof, col, full_tid, full_t))
        else:
            parts.append((pts, prof[hit], col[hit], tid, t))

    points = np.concatenate([p[0] for p in parts])
    ranges = np.concatenate([p[4] for p in parts])
    points = _transform(points, geo.frame, float(spec.unit_scale))
    ranges = ranges * float(spec.unit_scale)
    if spec.float32:
        points = points.astype(np.float32).astype(np.float64)
        ranges = ranges.astype(np.float32).astype(np.float64)
    n_points = counts["hits"] - counts["beyond_incidence"] - counts["occluded"] - counts["dropped"]
    info = {
        "rays": n_cols * n_prof,
        "profiles": n_prof,
        "columns": n_cols,
        "hits": counts["hits"],
        "missed": n_cols * n_prof - counts["hits"],
        "beyond_incidence": counts["beyond_incidence"],
        "occluded": counts["occluded"],
        "dropped": counts["dropped"],
        "points": n_points,
        "rows": len(points),
        "unit_scale": float(spec.unit_scale),
    }
    return ProfilerScan(
        points=np.ascontiguousarray(points),
        profile_index=np.concatenate([p[1] for p in parts]).astype(np.int64),
        column_index=np.concatenate([p[2] for p in parts]).astype(np.int64),
        triangle_id=np.concatenate([p[3] for p in parts]).astype(np.int64),
        ranges=ranges,
        info=info,
    )


def _wide_line(trace, actual, dirs, geo: _Geometry, spec: ProfilerSpec):
    """The samples of a laser line ``spec.line_width`` thick (module docstring, *Line width*).

    ``trace(origins, dirs)`` casts rays and returns the rows that give a point, their triangles,
    their distances along the ray and the losses counted; here it is called once per sub-ray, each
    the nominal ray translated along ``motion``. Returns the same for the samples: a sample gives a
    point when at least one of its sub-rays does, its triangle that of the visible sub-ray nearest
    the middle of the line. Its range is the centroid of its visible sub-rays' spots as the camera
    sees them, triangulated on the nominal ray: the middle-most visible spot is triangulated
    exactly, and each spot adds its offset from it as seen along that line of sight (linear in the
    offset, as the centroid of an image is: a footprint wholly on a flat face reads the nominal
    range, as a calibrated sensor does). A sample is counted as hit when a sub-ray hit the mesh,
    and lost beyond incidence (occluded) when none of its sub-rays was lit (seen).
    """
    rows = len(actual)
    k = int(spec.line_subrays)
    offsets = ((np.arange(k) + 0.5) / k - 0.5) * float(spec.line_width)
    order = np.argsort(np.abs(offsets), kind="stable")  # the middle sub-ray first
    spots = np.full((k, rows, 3), np.nan)
    tid = np.full(rows, -1, dtype=np.int64)
    hits = np.zeros(rows, dtype=bool)
    lit = np.zeros(rows, dtype=bool)
    for rank, index in enumerate(order):
        origin = actual + offsets[index] * geo.motion
        rows_hit, tri, t, reached = trace(origin, dirs)
        hits[reached["hit_rows"]] = True
        lit[reached["lit_rows"]] = True
        spots[rank, rows_hit] = origin[rows_hit] + t[:, None] * dirs[rows_hit]
        fresh = tid[rows_hit] < 0
        tid[rows_hit[fresh]] = tri[fresh]
    visible = np.isfinite(spots[:, :, 0])
    seen = visible.sum(axis=0)
    hit = np.flatnonzero(seen > 0)
    spots, visible = spots[:, hit], visible[:, hit]
    origin, direction = actual[hit], dirs[hit]
    camera = origin + geo.baseline
    reference = spots[np.argmax(visible, axis=0), np.arange(len(hit))]
    t_ref = _triangulated_range(reference, origin, direction, camera)
    sight = origin + t_ref[:, None] * direction - camera
    norm = np.linalg.norm(sight, axis=1)
    if len(hit) and np.all(norm > 0) and np.any(np.linalg.norm(geo.baseline) > 0):
        sight /= norm[:, None]
        b = np.einsum("ij,ij->i", direction, sight)
        oblique = 1.0 - b * b > 1e-12
    else:
        sight, b, oblique = direction, np.ones(len(hit)), np.zeros(len(hit), dtype=bool)
    shift = np.zeros(len(hit))
    for rank in range(k):
        delta = np.where(visible[rank][:, None], spots[rank] - reference, 0.0)
        along = np.einsum("ij,ij->i", delta, direction)
        across = np.einsum("ij,ij->i", delta, sight)
        with np.errstate(divide="ignore", invalid="ignore"):
            shift += np.where(oblique, (along - b * across) / np.where(oblique, 1.0 - b * b, 1.0), along)
    counts = dict(hits=int(np.count_nonzero(hits)), beyond_incidence=int(np.count_nonzero(hits & ~lit)),
                  occluded=int(np.count_nonzero(lit & (seen == 0))))
    return hit, tid[hit], t_ref + shift / seen[hit], counts


def _triangulated_range(point, origin, direction, camera):
    """Range on the nominal ray ``origin + t direction`` that the sensor reports for a light spot at
    ``point`` seen from ``camera``: where the camera's line of sight to the spot passes closest to
    the ray (the spot's own distance along the ray when the camera sits on it)."""
    sight = point - camera
    norm = np.linalg.norm(sight, axis=1)
    along = np.einsum("ij,ij->i", point - origin, direction)
    baseline = origin - camera
    if len(point) == 0 or not np.any(np.linalg.norm(baseline, axis=1) > 0):
        return along
    e = sight / np.where(norm > 0, norm, 1.0)[:, None]
    b = np.einsum("ij,ij->i", direction, e)
    dd = np.einsum("ij,ij->i", direction, baseline)
    ee = np.einsum("ij,ij->i", e, baseline)
    denominator = 1.0 - b * b
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (b * ee - dd) / denominator
    return np.where(np.isfinite(t) & (denominator > 1e-12), t, along)
