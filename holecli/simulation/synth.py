"""Synthetic laser scans of a flat panel with drilled holes, with exact ground truth.

The scene is built in a *local surface frame* (the panel is the plane z = 0, the material on z <= 0,
the sensor looking down from +z), then moved into the world by a rotation and a translation, as in
the paper's simulation (section 2.1 and 3): a 3 mm hole at (1, 1) on a rectilinear grid of spacing
h = 0.0908 over [-3, 5]^2, rotated 32 deg about x, 0 about y, 20 about z, translated by (3, 4, 5).
:func:`table1_scene` returns that scene.

Everything here is pure: arrays and dicts out, no files, no printing. Randomness comes only from the
``rng`` argument.

Conventions
-----------
Rotation
    ``rotation_deg = (a, b, c)`` rotates about the world x axis by ``a``, then about the world
    y axis by ``b``, then about the world z axis by ``c`` (extrinsic, counter-clockwise seen from
    the positive axis), so ``R = Rz(c) @ Ry(b) @ Rx(a)`` and a local point ``p`` goes to
    ``R @ p + t``.
Sampling
    The sampling pattern is laid over the whole patch; a sample becomes a *material* point on z = 0
    when it lies inside the (possibly ragged) patch and outside every hole's surface disk, a
    *countersink* point (lifted onto the cone) when it falls in a countersink annulus, a *boss*
    point when it falls under a boss and a *bottom* point (on the floor of a blind hole) when it falls
    in the bore disk of a hole with ``bottom_depth``. The bore wall is sampled separately, on rings.
Truth
    Every length in ``truth`` is already multiplied by ``unit_scale``; normals are oriented by the
    package's sign convention (z > 0; if z == 0 then y > 0; then x > 0), see :mod:`holecli.results`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional, Union

import numpy as np

from holecli.errors import SpecError
from holecli.geometry.kernels import orient_normal

__all__ = [
    "BORE",
    "BOSS",
    "BOTTOM",
    "COUNTERSINK",
    "INSIDE",
    "MATERIAL",
    "MISSING",
    "OUTLIER",
    "PATTERNS",
    "HoleSpec",
    "SceneSpec",
    "SyntheticScan",
    "make_scan",
    "random_rotation",
    "rotation_matrix",
    "table1_scene",
]

PATTERNS = ("grid", "stripes", "jittered", "random")

# Per-point labels of SyntheticScan.labels.
MATERIAL = 0      # the panel surface, z = 0
COUNTERSINK = 1   # on a countersink cone
BORE = 2          # on a bore wall (cylinder)
INSIDE = 3        # reflections scattered inside a hole's disk, at z = 0
BOSS = 4          # on the top of a pin/boss, z = +boss_height
OUTLIER = 5       # gross outlier
BOTTOM = 6        # on the flat floor of a blind hole, z = -bottom_depth
MISSING = -1      # NaN row

TABLE1_SPACING = 0.0908

# Relative slack (in units of the sample step) when testing a lattice point against the patch
# rectangle, so that a point meant to sit on the border (x = xmin + i h) is not lost to rounding.
_EDGE_SLACK = 1e-7
# Angular samples of a hole's circle used to measure the arc that lies inside the patch.
_ARC_SAMPLES = 7200
# Fewest points on one ring of a bore wall, so a tiny bore is still a cylinder.
_MIN_RING_POINTS = 8
# Refuse scenes that would need more candidate samples than this (memory guard, ~1.6 GB of float64).
_MAX_SAMPLES = 100_000_000
# Diameter of a boss relative to the hole it sits in.
_BOSS_DIAMETER_RATIO = 0.9


@dataclass(frozen=True)
class HoleSpec:
    """One hole (or boss) in the local surface frame.

    Attributes
    ----------
    center : (2,) tuple of float
        Center (x, y) on the surface plane z = 0, file units.
    diameter : float
        Bore diameter, > 0.
    countersink_diameter : float or None
        Outer diameter of a countersink cone at the surface, > ``diameter``; None for none.
    countersink_angle_deg : float
        Included angle of the countersink cone, in (0, 180) degrees.
    bore_depth : float
        > 0 adds points on the bore wall from the surface (or the bottom of the countersink) down to
        this depth below the surface.
    inside_points : int
        Random points scattered uniformly in the bore disk at z = 0 (the paper's reflections).
    boss_height : float
        > 0 fills the disk with a pin/boss: a flat disk of diameter ``0.9 * diameter`` sampled with
        the scene's pattern at z = +boss_height. Not a hole; a detector must reject it.
    bottom_depth : float
        > 0 makes a blind hole whose flat floor, the whole bore disk, is seen by the sensor: the
        scene's pattern inside the bore disk is sampled at z = -bottom_depth. Must be deeper than
        the countersink and at least ``bore_depth`` (the wall ends on the floor); no boss with it.
    """

    center: tuple[float, float]
    diameter: float
    countersink_diameter: Optional[float] = None
    countersink_angle_deg: float = 100.0
    bore_depth: float = 0.0
    inside_points: int = 0
    boss_height: float = 0.0
    bottom_depth: float = 0.0

    @property
    def surface_radius(self) -> float:
        """Radius of the visible edge at the surface (countersink radius when countersunk)."""
        if self.countersink_diameter is None:
            return self.diameter / 2.0
        return self.countersink_diameter / 2.0


@dataclass(frozen=True)
class SceneSpec:
    """A scanned patch with holes, its sampling, its pose in the world and its defects.

    Defaults give the paper's Table I scene without noise. Lengths are in file units (before
    ``unit_scale``); see the module docstring for the frames and the rotation convention.

    Attributes
    ----------
    holes : tuple of HoleSpec
        The holes; their surface disks must not overlap.
    extent : (4,) tuple of float
        ``(xmin, xmax, ymin, ymax)`` of the scanned patch in the local frame.
    spacing : float
        Point spacing h along a scan line (and between lines for ``'grid'`` and ``'jittered'``).
    pattern : {'grid', 'stripes', 'jittered', 'random'}
        ``'grid'``: square lattice of step h. ``'stripes'``: lines along the scan direction,
        ``line_pitch`` apart, points every h along them. ``'jittered'``: the grid with each point
        displaced uniformly by +-``jitter * h / 2`` along each lattice axis. ``'random'``: uniform
        Poisson, density 1/h^2 (``scan_angle_deg`` and ``grid_offset`` do not apply).
    line_pitch : float or None
        Distance between scan lines for ``'stripes'``; None means ``3 * spacing``.
    jitter : float
        Jitter amplitude of ``'jittered'``, as a fraction of h.
    scan_angle_deg : float
        Direction of the scan lines / lattice axes, degrees from the local x axis.
    grid_offset : (2,) tuple of float
        Shift (local x, y) of the lattice from the patch corner ``(xmin, ymin)``.
    rotation_deg : (3,) tuple of float
        Rotation of the patch into the world, see :func:`rotation_matrix`.
    translation : (3,) tuple of float
        Translation of the patch into the world.
    noise_world_z : float
        Gaussian sigma added to the world z coordinate after the transform (the paper's noise).
    noise_normal : float
        Gaussian sigma added along the surface normal (local z) before the transform.
    outlier_fraction : float
        Gross outliers, as a fraction of the point count; see :func:`make_scan`.
    ragged_border : float
        Amplitude of an inward random perturbation of the patch border (0 for a clean rectangle).
    nan_points : int
        NaN rows appended, as a profiler writes for missed points.
    unit_scale : float
        Factor applied to every coordinate and length of the output (0.001: the scene in metres).
    """

    holes: tuple[HoleSpec, ...] = (HoleSpec(center=(1.0, 1.0), diameter=3.0),)
    extent: tuple[float, float, float, float] = (-3.0, 5.0, -3.0, 5.0)
    spacing: float = TABLE1_SPACING
    pattern: str = "grid"
    line_pitch: Optional[float] = None
    jitter: float = 0.5
    scan_angle_deg: float = 0.0
    grid_offset: tuple[float, float] = (0.0, 0.0)
    rotation_deg: tuple[float, float, float] = (32.0, 0.0, 20.0)
    translation: tuple[float, float, float] = (3.0, 4.0, 5.0)
    noise_world_z: float = 0.0
    noise_normal: float = 0.0
    outlier_fraction: float = 0.0
    ragged_border: float = 0.0
    nan_points: int = 0
    unit_scale: float = 1.0


@dataclass(frozen=True, eq=False)
class SyntheticScan:
    """A generated cloud and its ground truth.

    Attributes
    ----------
    points : (n, 3) float64
        World coordinates, rows in random order; NaN rows included.
    truth : dict
        JSON-ready ground truth (plain floats, lists); see :func:`make_scan`.
    labels : (n,) int8
        What each row is: MATERIAL, COUNTERSINK, BORE, INSIDE, BOSS, OUTLIER, BOTTOM or MISSING (NaN
        row).
    """

    points: np.ndarray
    truth: dict
    labels: np.ndarray


RngLike = Union[np.random.Generator, int, None]


# --------------------------------------------------------------------------------------------------
# Public helpers


def rotation_matrix(rotation_deg) -> np.ndarray:
    """Rotation matrix of extrinsic x-then-y-then-z rotations.

    Parameters
    ----------
    rotation_deg : (3,) sequence of float
        Angles ``(a, b, c)`` in degrees about the world x, y and z axes, applied in that order,
        each counter-clockwise seen from the positive axis.

    Returns
    -------
    R : (3, 3) float64
        ``Rz(c) @ Ry(b) @ Rx(a)``; a column vector ``p`` maps to ``R @ p``.
    """
    angles = None
    if _sequence_of_numbers(rotation_deg):
        angles = np.asarray(rotation_deg, dtype=np.float64)
    if angles is None or angles.shape != (3,) or not np.all(np.isfinite(angles)):
        raise SpecError(f"rotation_deg must be 3 finite angles in degrees, got {rotation_deg!r}")
    return _rotation_matrix(np.radians(angles))


def random_rotation(rng: RngLike = None) -> np.ndarray:
    """A rotation drawn uniformly (Haar measure) from SO(3).

    Parameters
    ----------
    rng : numpy.random.Generator, int or None
        Random source or seed.

    Returns
    -------
    R : (3, 3) float64
        Proper rotation: ``R @ R.T = I``, ``det R = +1``.
    """
    rng = np.random.default_rng(rng)
    # A normalized 4D Gaussian is a uniform unit quaternion, hence a uniform rotation.
    q = rng.standard_normal(4)
    w, x, y, z = q / np.linalg.norm(q)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


def table1_scene(noise_fraction: float = 0.0, inside_points: int = 0) -> SceneSpec:
    """The paper's Table I scene.

    A 3 mm hole at (1, 1) on a square grid of spacing h = 0.0908 mm over [-3, 5]^2 (about 7,000
    points), rotated by (32, 0, 20) degrees and translated by (3, 4, 5) mm.

    Parameters
    ----------
    noise_fraction : float
        Gaussian noise on the world z coordinate, as a fraction of h (the paper's 0.1, 0.2, 0.3).
    inside_points : int
        Reflections scattered inside the hole (the paper's Fig. 5 uses 10 and 100).

    Returns
    -------
    SceneSpec
    """
    return SceneSpec(
        holes=(HoleSpec(center=(1.0, 1.0), diameter=3.0, inside_points=inside_points),),
        noise_world_z=noise_fraction * TABLE1_SPACING,
    )


def make_scan(scene: SceneSpec, rng: RngLike = 0) -> SyntheticScan:
    """Sample a scene into a point cloud with its ground truth.

    Parameters
    ----------
    scene : SceneSpec
        What to generate; validated here.
    rng : numpy.random.Generator, int or None
        Random source or seed (default 0, so a scene is reproducible unless asked otherwise).

    Returns
    -------
    SyntheticScan
        ``points`` (n, 3) float64 in shuffled order, ``labels`` (n,) int8 and ``truth``::

            {"holes": [{"center": [x, y, z], "diameter": d, "bore_diameter": d0,
                        "normal": [nx, ny, nz], "partial": bool, "arc_deg": a,
                        "is_hole": bool}, ...],
             "spacing": h, "line_pitch": p or None, "pattern": str,
             "rotation_deg": [a, b, c], "translation": [tx, ty, tz],
             "noise_world_z": s, "noise_normal": s, "points": n,
             "outliers": k, "nan_points": m, "unit_scale": f}

        ``diameter`` is the visible edge at the surface (the countersink diameter when countersunk);
        ``arc_deg`` is the part of that circle inside the patch (to 0.05 deg) and ``partial`` is
        True when the disk is not entirely inside the patch. ``line_pitch`` is the distance
        between scan lines (h for the grids, None for ``'random'``).

    Raises
    ------
    holecli.errors.SpecError
        (a ValueError) when a parameter is out of range.

    Notes
    -----
    Outliers: ``round(outlier_fraction * n_clean)`` points, uniform over the local (x, y) bounding
    box of the clean points enlarged by 20 % (10 % of its size on each side), at local heights
    uniform in +-max(extent width, height) / 4 along the normal. ``noise_normal`` is not added to
    them; ``noise_world_z`` is added to every finite point.
    """
    _validate(scene)
    rng = np.random.default_rng(rng)
    patch = _make_patch(scene, rng)

    x, y = _sample_pattern(scene, rng)
    x, y = _keep(patch.contains(x, y), x, y)
    z, labels = _carve_holes(scene.holes, x, y)
    keep = labels >= 0
    parts = [(np.column_stack([x[keep], y[keep], z[keep]]), labels[keep])]

    for hole in scene.holes:
        if hole.bore_depth > 0:
            parts.append(_bore_wall(hole, scene.spacing, patch, rng))
        if hole.inside_points > 0:
            parts.append(_inside_points(hole, patch, rng))

    local = np.concatenate([p for p, _ in parts])
    labels = np.concatenate([lab for _, lab in parts]).astype(np.int8)

    if scene.noise_normal > 0:
        local[:, 2] += rng.normal(0.0, scene.noise_normal, len(local))

    n_outliers = int(round(scene.outlier_fraction * len(local)))
    if n_outliers:
        local = np.concatenate([local, _outliers(scene, local, n_outliers, rng)])
        labels = np.concatenate([labels, np.full(n_outliers, OUTLIER, dtype=np.int8)])

    rot = rotation_matrix(scene.rotation_deg)
    shift = np.asarray(scene.translation, dtype=np.float64)
    world = local @ rot.T + shift
    if scene.noise_world_z > 0:
        world[:, 2] += rng.normal(0.0, scene.noise_world_z, len(world))

    if scene.nan_points:
        world = np.concatenate([world, np.full((scene.nan_points, 3), np.nan)])
        labels = np.concatenate([labels, np.full(scene.nan_points, MISSING, dtype=np.int8)])

    world *= scene.unit_scale
    order = rng.permutation(len(world))
    points = np.ascontiguousarray(world[order])
    labels = labels[order]

    truth = _truth(scene, patch, rot, shift, len(points), n_outliers)
    return SyntheticScan(points=points, truth=truth, labels=labels)


# --------------------------------------------------------------------------------------------------
# Validation


def _fail(name, expected, value):
    raise SpecError(f"{name} must be {expected}, got {value!r}")


def _finite(value) -> bool:
    try:
        return math.isfinite(float(value))
    except (TypeError, ValueError):
        return False


def _is_count(value) -> bool:
    return isinstance(value, (int, np.integer)) and not isinstance(value, bool) and value >= 0


def _vector(name, value, size):
    arr = np.asarray(value, dtype=np.float64) if _sequence_of_numbers(value) else None
    if arr is None or arr.shape != (size,) or not np.all(np.isfinite(arr)):
        _fail(name, f"{size} finite numbers", value)


def _sequence_of_numbers(value) -> bool:
    try:
        return all(_finite(v) for v in value)
    except TypeError:
        return False


def _validate(scene: SceneSpec) -> None:
    if not isinstance(scene, SceneSpec):
        _fail("scene", "a SceneSpec", scene)
    h = scene.spacing
    if not (_finite(h) and h > 0):
        _fail("spacing", "a finite number > 0", h)
    _vector("extent", scene.extent, 4)
    xmin, xmax, ymin, ymax = scene.extent
    if not (xmin < xmax and ymin < ymax):
        _fail("extent", "(xmin, xmax, ymin, ymax) with xmin < xmax and ymin < ymax", scene.extent)
    if scene.pattern not in PATTERNS:
        _fail("pattern", f"one of {', '.join(PATTERNS)}", scene.pattern)
    if scene.line_pitch is not None and not (_finite(scene.line_pitch) and scene.line_pitch > 0):
        _fail("line_pitch", "None or a finite number > 0", scene.line_pitch)
    if not (_finite(scene.jitter) and scene.jitter >= 0):
        _fail("jitter", "a finite number >= 0 (fraction of the spacing)", scene.jitter)
    if not _finite(scene.scan_angle_deg):
        _fail("scan_angle_deg", "a finite angle in degrees", scene.scan_angle_deg)
    _vector("grid_offset", scene.grid_offset, 2)
    _vector("rotation_deg", scene.rotation_deg, 3)
    _vector("translation", scene.translation, 3)
    for name in ("noise_world_z", "noise_normal"):
        value = getattr(scene, name)
        if not (_finite(value) and value >= 0):
            _fail(name, "a finite sigma >= 0", value)
    if not (_finite(scene.outlier_fraction) and 0 <= scene.outlier_fraction <= 1):
        _fail("outlier_fraction", "in [0, 1]", scene.outlier_fraction)
    half_side = min(xmax - xmin, ymax - ymin) / 4.0
    if not (_finite(scene.ragged_border) and 0 <= scene.ragged_border < half_side):
        _fail("ragged_border", f"in [0, {half_side:g}) (a quarter of the patch's smaller side)",
              scene.ragged_border)
    if not _is_count(scene.nan_points):
        _fail("nan_points", "an integer >= 0", scene.nan_points)
    if not (_finite(scene.unit_scale) and scene.unit_scale > 0):
        _fail("unit_scale", "a finite number > 0", scene.unit_scale)

    try:
        holes = tuple(scene.holes)
    except TypeError:
        _fail("holes", "a sequence of HoleSpec", scene.holes)
    for k, hole in enumerate(holes):
        _validate_hole(f"holes[{k}]", hole)
    _check_overlaps(holes)

    pitch = _line_pitch(scene)
    step_v = h if pitch is None else pitch
    # The lattice is laid over the patch's bounding box in the scan frame: up to twice its area.
    estimate = 2.0 * (xmax - xmin + 2 * h) * (ymax - ymin + 2 * h) / (h * step_v)
    if estimate > _MAX_SAMPLES:
        _fail("spacing", f"large enough for at most {_MAX_SAMPLES:,} samples of the extent", h)


def _validate_hole(name, hole):
    if not isinstance(hole, HoleSpec):
        _fail(name, "a HoleSpec", hole)
    _vector(f"{name}.center", hole.center, 2)
    if not (_finite(hole.diameter) and hole.diameter > 0):
        _fail(f"{name}.diameter", "a finite number > 0", hole.diameter)
    if hole.countersink_diameter is not None:
        cs = hole.countersink_diameter
        if not (_finite(cs) and cs > hole.diameter):
            _fail(f"{name}.countersink_diameter", f"None or a finite number > diameter "
                  f"({hole.diameter!r})", cs)
    angle = hole.countersink_angle_deg
    if not (_finite(angle) and 0 < angle < 180):
        _fail(f"{name}.countersink_angle_deg", "in (0, 180) degrees", angle)
    if not (_finite(hole.bore_depth) and hole.bore_depth >= 0):
        _fail(f"{name}.bore_depth", "a finite number >= 0", hole.bore_depth)
    if not _is_count(hole.inside_points):
        _fail(f"{name}.inside_points", "an integer >= 0", hole.inside_points)
    if not (_finite(hole.boss_height) and hole.boss_height >= 0):
        _fail(f"{name}.boss_height", "a finite number >= 0", hole.boss_height)
    bottom = hole.bottom_depth
    if not (_finite(bottom) and bottom >= 0):
        _fail(f"{name}.bottom_depth", "a finite number >= 0", bottom)
    if bottom > 0:
        if bottom <= _countersink_depth(hole):
            _fail(f"{name}.bottom_depth", f"0 or deeper than the countersink ({_countersink_depth(hole):g})", bottom)
        if hole.bore_depth > bottom:
            _fail(f"{name}.bottom_depth", f"0 or at least bore_depth ({hole.bore_depth!r})", bottom)
        if hole.boss_height > 0:
            _fail(f"{name}.bottom_depth", "0 when the hole holds a boss", bottom)


def _check_overlaps(holes):
    if len(holes) < 2:
        return
    centers = np.array([h.center for h in holes], dtype=np.float64)
    radii = np.array([h.surface_radius for h in holes])
    dist = np.linalg.norm(centers[:, None, :] - centers[None, :, :], axis=2)
    overlap = dist < radii[:, None] + radii[None, :]
    np.fill_diagonal(overlap, False)
    if overlap.any():
        i, j = np.argwhere(overlap)[0]
        raise SpecError(
            f"holes[{i}] and holes[{j}] must not overlap: center distance must be >= "
            f"{radii[i] + radii[j]:g} (sum of surface radii), got {dist[i, j]:g}"
        )


# --------------------------------------------------------------------------------------------------
# Kernels


def _rotation_matrix(angles_rad: np.ndarray) -> np.ndarray:
    a, b, c = angles_rad
    ca, sa, cb, sb, cc, sc = np.cos(a), np.sin(a), np.cos(b), np.sin(b), np.cos(c), np.sin(c)
    rx = np.array([[1.0, 0.0, 0.0], [0.0, ca, -sa], [0.0, sa, ca]])
    ry = np.array([[cb, 0.0, sb], [0.0, 1.0, 0.0], [-sb, 0.0, cb]])
    rz = np.array([[cc, -sc, 0.0], [sc, cc, 0.0], [0.0, 0.0, 1.0]])
    return rz @ ry @ rx


def _line_pitch(scene: SceneSpec) -> Optional[float]:
    if scene.pattern == "random":
        return None
    if scene.pattern == "stripes":
        return 3.0 * scene.spacing if scene.line_pitch is None else float(scene.line_pitch)
    return float(scene.spacing)


def _keep(mask, *arrays):
    return tuple(a[mask] for a in arrays)


@dataclass(frozen=True, eq=False)
class _Patch:
    """The scanned region: a rectangle whose sides are eaten inward by tabulated depth profiles.

    Each side's depth is a function of the position along that side only, so every removed piece
    touches the outer border and no closed void can appear inside the patch.
    """

    xmin: float
    xmax: float
    ymin: float
    ymax: float
    slack: float
    step: float = 1.0
    left: Optional[np.ndarray] = None    # inward depth from xmin, indexed by the bin of y
    right: Optional[np.ndarray] = None   # inward depth from xmax, indexed by the bin of y
    bottom: Optional[np.ndarray] = None  # inward depth from ymin, indexed by the bin of x
    top: Optional[np.ndarray] = None     # inward depth from ymax, indexed by the bin of x

    def contains(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        s = self.slack
        inside = (x >= self.xmin - s) & (x <= self.xmax + s)
        inside &= (y >= self.ymin - s) & (y <= self.ymax + s)
        if self.left is None:
            return inside
        iy = np.clip(((y - self.ymin) / self.step).astype(np.int64), 0, len(self.left) - 1)
        ix = np.clip(((x - self.xmin) / self.step).astype(np.int64), 0, len(self.bottom) - 1)
        inside &= x - self.xmin >= self.left[iy]
        inside &= self.xmax - x >= self.right[iy]
        inside &= y - self.ymin >= self.bottom[ix]
        inside &= self.ymax - y >= self.top[ix]
        return inside


def _make_patch(scene: SceneSpec, rng: np.random.Generator) -> _Patch:
    xmin, xmax, ymin, ymax = (float(v) for v in scene.extent)
    slack = _EDGE_SLACK * scene.spacing
    amplitude = float(scene.ragged_border)
    if amplitude == 0:
        return _Patch(xmin, xmax, ymin, ymax, slack)
    # Bins of one point spacing: along a side each scan line (or grid row) gets its own end.
    step = float(scene.spacing)

    def profile(length):
        n = int(math.ceil(length / step)) + 1
        s = (np.arange(n) + 0.5) * step
        freq = rng.uniform(0.5, 4.0, 3)
        phase = rng.uniform(0.0, 2 * np.pi, 3)
        weight = rng.uniform(0.5, 1.0, 3)
        waves = np.sin(2 * np.pi * np.outer(s / length, freq) + phase) @ weight
        smooth = 0.5 + 0.5 * waves / weight.sum()          # in [0, 1]
        rough = rng.uniform(0.0, 1.0, n)
        return amplitude * (0.5 * smooth + 0.5 * rough)    # in [0, amplitude]

    return _Patch(
        xmin, xmax, ymin, ymax, slack, step,
        left=profile(ymax - ymin), right=profile(ymax - ymin),
        bottom=profile(xmax - xmin), top=profile(xmax - xmin),
    )


def _sample_pattern(scene: SceneSpec, rng: np.random.Generator):
    """Samples of the pattern over the patch's bounding box (local x, y), before any cut."""
    xmin, xmax, ymin, ymax = (float(v) for v in scene.extent)
    h = float(scene.spacing)
    if scene.pattern == "random":
        area = (xmax - xmin) * (ymax - ymin)
        n = rng.poisson(area / (h * h))
        return rng.uniform(xmin, xmax, n), rng.uniform(ymin, ymax, n)

    step_u = h
    step_v = _line_pitch(scene)
    angle = math.radians(scene.scan_angle_deg)
    c, s = math.cos(angle), math.sin(angle)
    ax, ay = xmin + scene.grid_offset[0], ymin + scene.grid_offset[1]
    corners = np.array([[xmin, ymin], [xmax, ymin], [xmin, ymax], [xmax, ymax]]) - (ax, ay)
    u = corners @ (c, s)
    v = corners @ (-s, c)
    # Jittered points may wander in from one step outside the box.
    margin = 1 if scene.pattern == "jittered" else 0
    eps = _EDGE_SLACK
    i = np.arange(math.ceil(u.min() / step_u - eps) - margin,
                  math.floor(u.max() / step_u + eps) + margin + 1)
    j = np.arange(math.ceil(v.min() / step_v - eps) - margin,
                  math.floor(v.max() / step_v + eps) + margin + 1)
    uu, vv = np.meshgrid(i * step_u, j * step_v)
    uu, vv = uu.ravel(), vv.ravel()
    if scene.pattern == "jittered" and scene.jitter > 0:
        half = scene.jitter * h / 2.0
        uu = uu + rng.uniform(-half, half, uu.size)
        vv = vv + rng.uniform(-half, half, vv.size)
    if s == 0.0:
        x, y = ax + c * uu, ay + c * vv
    else:
        x, y = ax + c * uu - s * vv, ay + s * uu + c * vv
    slack = _EDGE_SLACK * h
    box = (x >= xmin - slack) & (x <= xmax + slack) & (y >= ymin - slack) & (y <= ymax + slack)
    return x[box], y[box]


def _carve_holes(holes, x: np.ndarray, y: np.ndarray):
    """Heights and labels of surface samples; label -1 marks a sample that falls into a hole."""
    z = np.zeros_like(x)
    labels = np.full(x.shape, MATERIAL, dtype=np.int8)
    if not holes or x.size == 0:
        return z, labels
    # Sorting by x once lets each hole look only at the slab of samples it can touch.
    order = np.argsort(x)
    xs = x[order]
    for hole in holes:
        cx, cy = (float(v) for v in hole.center)
        big_r = hole.surface_radius
        lo, hi = np.searchsorted(xs, [cx - big_r, cx + big_r], side="left")
        idx = order[lo:hi]
        rho2 = (x[idx] - cx) ** 2 + (y[idx] - cy) ** 2
        inside = rho2 < big_r * big_r
        idx, rho2 = idx[inside], rho2[inside]
        labels[idx] = -1
        if hole.countersink_diameter is not None:
            r = hole.diameter / 2.0
            ring = rho2 >= r * r
            rho = np.sqrt(rho2[ring])
            tan_half = math.tan(math.radians(hole.countersink_angle_deg) / 2.0)
            z[idx[ring]] = -(big_r - rho) / tan_half
            labels[idx[ring]] = COUNTERSINK
        if hole.boss_height > 0:
            boss_r = _BOSS_DIAMETER_RATIO * hole.diameter / 2.0
            top = rho2 < boss_r * boss_r
            z[idx[top]] = hole.boss_height
            labels[idx[top]] = BOSS
        if hole.bottom_depth > 0:
            r = hole.diameter / 2.0
            floor = rho2 < r * r
            z[idx[floor]] = -hole.bottom_depth
            labels[idx[floor]] = BOTTOM
    return z, labels


def _countersink_depth(hole: HoleSpec) -> float:
    if hole.countersink_diameter is None:
        return 0.0
    half = math.radians(hole.countersink_angle_deg) / 2.0
    return (hole.countersink_diameter - hole.diameter) / 2.0 / math.tan(half)


def _bore_wall(hole: HoleSpec, h: float, patch: _Patch, rng: np.random.Generator):
    """Rings on the bore cylinder, about h apart in depth and in arc length.

    The rings start one step below the top of the bore (the surface, or the bottom of the
    countersink) and the last one is exactly at -bore_depth; there is no ring at the top edge
    itself, so the visible edge is made only by surface (or cone) samples.
    """
    top = -_countersink_depth(hole)
    length = hole.bore_depth + top
    if length <= 0:
        return np.empty((0, 3)), np.empty(0, dtype=np.int8)
    n_rings = int(math.ceil(length / h - _EDGE_SLACK))
    depths = top - length * np.arange(1, n_rings + 1) / n_rings
    r = hole.diameter / 2.0
    per_ring = max(_MIN_RING_POINTS, int(math.ceil(2 * np.pi * r / h)))
    phase = rng.uniform(0.0, 2 * np.pi / per_ring, n_rings)
    theta = (phase[:, None] + 2 * np.pi * np.arange(per_ring) / per_ring).ravel()
    z = np.repeat(depths, per_ring)
    x = hole.center[0] + r * np.cos(theta)
    y = hole.center[1] + r * np.sin(theta)
    keep = patch.contains(x, y)
    pts = np.column_stack([x[keep], y[keep], z[keep]])
    return pts, np.full(len(pts), BORE, dtype=np.int8)


def _inside_points(hole: HoleSpec, patch: _Patch, rng: np.random.Generator):
    """Uniform points in the bore disk at z = 0; those outside the patch are dropped."""
    n = hole.inside_points
    rho = hole.diameter / 2.0 * np.sqrt(rng.uniform(0.0, 1.0, n))
    theta = rng.uniform(0.0, 2 * np.pi, n)
    x = hole.center[0] + rho * np.cos(theta)
    y = hole.center[1] + rho * np.sin(theta)
    keep = patch.contains(x, y)
    pts = np.column_stack([x[keep], y[keep], np.zeros(int(keep.sum()))])
    return pts, np.full(len(pts), INSIDE, dtype=np.int8)


def _outliers(scene: SceneSpec, local: np.ndarray, n: int, rng: np.random.Generator) -> np.ndarray:
    xmin, xmax, ymin, ymax = (float(v) for v in scene.extent)
    if len(local):
        lo, hi = local[:, :2].min(axis=0), local[:, :2].max(axis=0)
    else:
        lo, hi = np.array([xmin, ymin]), np.array([xmax, ymax])
    pad = 0.1 * (hi - lo)
    xy = rng.uniform(lo - pad, hi + pad, (n, 2))
    height = max(xmax - xmin, ymax - ymin) / 4.0
    z = rng.uniform(-height, height, n)
    return np.column_stack([xy, z])


def _arc_inside(hole: HoleSpec, patch: _Patch) -> float:
    theta = np.arange(_ARC_SAMPLES) * (2 * np.pi / _ARC_SAMPLES)
    r = hole.surface_radius
    inside = patch.contains(hole.center[0] + r * np.cos(theta), hole.center[1] + r * np.sin(theta))
    return 360.0 * float(inside.mean())


def _truth(scene: SceneSpec, patch: _Patch, rot: np.ndarray, shift: np.ndarray,
           n_points: int, n_outliers: int) -> dict:
    f = float(scene.unit_scale)
    # The package's sign convention (holecli.geometry.kernels.orient_normal): a component below 1e-12
    # counts as zero, so that a wall given as a 90 degree rotation (cos 90 deg = 6e-17) is oriented
    # by y, as its author meant.
    normal = orient_normal(rot[:, 2])
    xmin, xmax, ymin, ymax = scene.extent
    holes = []
    for hole in scene.holes:
        cx, cy = (float(v) for v in hole.center)
        r = hole.surface_radius
        arc = _arc_inside(hole, patch)
        in_box = cx - r >= xmin and cx + r <= xmax and cy - r >= ymin and cy + r <= ymax
        center = (rot @ np.array([cx, cy, 0.0]) + shift) * f
        holes.append({
            "center": [float(v) for v in center],
            "diameter": float(2.0 * r * f),
            "bore_diameter": float(hole.diameter * f),
            "normal": [float(v) for v in normal],
            "partial": bool(not in_box or arc < 360.0),
            "arc_deg": arc,
            "is_hole": bool(hole.boss_height == 0),
        })
    pitch = _line_pitch(scene)
    return {
        "holes": holes,
        "spacing": float(scene.spacing * f),
        "line_pitch": None if pitch is None else float(pitch * f),
        "pattern": scene.pattern,
        "rotation_deg": [float(v) for v in scene.rotation_deg],
        "translation": [float(v) * f for v in scene.translation],
        "noise_world_z": float(scene.noise_world_z * f),
        "noise_normal": float(scene.noise_normal * f),
        "points": int(n_points),
        "outliers": int(n_outliers),
        "nan_points": int(scene.nan_points),
        "unit_scale": f,
    }
