"""What a panel is: :class:`FeatureSpec`, :class:`PanelSpec`, :class:`Panel`, the kinds and face labels, and the
validation of a spec (sizes, gaps between features, the rings that grade the mesh around them)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Optional

import numpy as np

from holecli.errors import SpecError

__all__ = ["BOTTOM", "CURVATURES", "FLOOR", "KINDS", "NOT_HOLES", "SIDE", "TOP", "WALL", "FeatureSpec", "Panel", "PanelSpec"]


KINDS = ("through", "countersunk", "counterbored", "blind", "slot", "cutout", "boss", "pocket")
# Kinds that are not holes: a detector must report nothing on them.
NOT_HOLES = ("slot", "cutout", "boss", "pocket")
CURVATURES = ("flat", "convex", "concave")

# Per-triangle part labels of Panel.parts.
TOP = 0       # the top face, the one a profiler sees
BOTTOM = 1    # the bottom face
SIDE = 2      # the four outer side walls
WALL = 3      # a feature's bore, cone, counterbore or slot wall
FLOOR = 4     # a counterbore's annulus, a blind hole's floor or a boss's top

# Smallest gap (mm) between two features' outer contours, and between a contour and the border:
# the graded rings need room to keep each contour's edges Delaunay.
_MIN_GAP = 0.5
# Ratio between the spacings (and widths) of successive offset rings around a contour.
_RING_GROWTH = 1.3
# Fewest segments of a circle, whatever the chord error.
_MIN_SEGMENTS = 32
# Exact points of an edge loop used for the truth's diameters and offsets.
_TRUTH_SAMPLES = 4096
# Largest half-angle of the panel's arc, u / R (radians): beyond it the sheet is more tube than panel.
_MAX_HALF_ARC = math.pi / 4
# Radius of curvature at least this many thicknesses.
_MIN_RADIUS_THICKNESSES = 10.0
# Countersink included angles accepted (degrees); 82, 90, 100 and 110 are the standard ones.
_COUNTERSINK_ANGLE_RANGE = (30.0, 150.0)
# Smallest wall height (mm) between two loops at different depths, and from a loop to a surface.
_MIN_WALL = 0.01
# Drilling axes accepted: tilt from the surface normal in [0, _MAX_TILT_DEG) degrees.
_MAX_TILT_DEG = 30.0
# Smallest angle (degrees) between a countersink's steepest generator and the surface normal's
# plane: tilt + half the included angle may reach at most 90 minus this, or the cone grazes the surface.
_MIN_CONE_CLEARANCE_DEG = 5.0
# Hole kinds that may be drilled off the normal.
_TILTABLE = ("through", "countersunk", "counterbored", "blind")
# Newton iterations (at most) and tolerance (radians) that find the loop point in a given direction.
_DIRECTION_ITERATIONS = 20
_DIRECTION_TOLERANCE = 1e-13


@dataclass(frozen=True)
class FeatureSpec:
    """One feature of a panel, in the sheet frame.

    Attributes
    ----------
    kind : {'through', 'countersunk', 'counterbored', 'blind', 'slot', 'cutout', 'boss', 'pocket'}
        ``'through'``: a cylindrical bore through the sheet. ``'countersunk'``: a cone of
        ``countersink_angle_deg`` from ``countersink_diameter`` at the surface down to the bore, then
        the bore through. ``'counterbored'``: a step of ``counterbore_diameter`` and
        ``counterbore_depth``, then the bore through. ``'blind'``: a bore to a flat floor at
        ``depth``. ``'slot'``: a rounded slot cut through, ``width`` by ``length`` (overall, end
        to end) along ``direction_deg``; not a hole. ``'cutout'``: a rectangular window cut through,
        ``width`` by ``length`` along ``direction_deg``, its corners rounded to ``corner_radius`` (a
        milled window; ``corner_radius`` = width / 2 is a slot); not a hole. ``'boss'``: a cylindrical pin of ``diameter``
        standing ``height`` above the tangent plane at the centre, flat-topped; not a hole. ``'pocket'``:
        a round recess of ``diameter`` milled to a flat floor at ``depth`` (built as a blind bore), so
        shallow that no drill made it (a spot face); not a hole.
    center : (2,) tuple of float
        ``(u, v)`` of the feature's axis on the top surface, mm (arc length on a curved sheet): the
        centre point ``c``.
    diameter : float or None
        Bore diameter, mm, > 0, perpendicular to the axis; None (omitted) for a slot or a cut-out.
    countersink_diameter : float or None
        Outer diameter of the cone in the plane perpendicular to the axis through the centre (the
        tangent plane when the hole is not tilted), > ``diameter``.
    countersink_angle_deg : float
        Included angle of the cone, degrees (82, 90, 100, 110 are standard).
    counterbore_diameter, counterbore_depth : float or None
        Diameter (> ``diameter``) and depth (0 < depth < thickness, along the axis from the centre)
        of the step, which is flat and perpendicular to the axis.
    depth : float or None
        Depth of a blind hole's floor along the axis from the centre; the floor is perpendicular to
        the axis.
    height : float or None
        A boss's height above the tangent plane at the centre, along the axis, > 0.
    width, length, direction_deg : float or None
        A slot's or cut-out's width, overall length (> width) and the direction of its length, degrees
        from +u towards +v.
    corner_radius : float or None
        A cut-out's corner radius, in (0, width / 2].
    tilt_deg : float
        Angle between the drilling axis and the top surface's normal ``n`` at the centre, degrees,
        in [0, 30) (and at most 85 - half the included angle for a countersink). Holes only
        (through, countersunk, counterbored, blind); 0 (omitted) for a slot, a cut-out or a boss.
    tilt_direction_deg : float
        Direction the axis leans toward, degrees from ``+u`` toward ``+v`` in the tangent plane:
        the axis (pointing out of the material) is ``a = cos(tilt) n + sin(tilt) (cos(dir) e_u +
        sin(dir) e_v)``, so the bore runs toward ``-dir`` as it goes down. Holes only.
    name : str or None
        A label copied into the truth.

    Notes
    -----
    A tilted hole is drilled along ``a`` through ``c``: its bore, cone and counterbore are exact
    cylinders and cones about ``a``, and its levels (the cone's lower edge, the counterbore's step,
    the blind floor) are planes perpendicular to ``a``, every depth measured along ``a`` from ``c``.
    """

    kind: str
    center: tuple[float, float]
    diameter: Optional[float] = None
    countersink_diameter: Optional[float] = None
    countersink_angle_deg: float = 100.0
    counterbore_diameter: Optional[float] = None
    counterbore_depth: Optional[float] = None
    depth: Optional[float] = None
    height: Optional[float] = None
    width: Optional[float] = None
    length: Optional[float] = None
    direction_deg: float = 0.0
    corner_radius: Optional[float] = None
    tilt_deg: float = 0.0
    tilt_direction_deg: float = 0.0
    name: Optional[str] = None

    @property
    def outer_radius(self) -> float:
        """Radius of the outer contour at the surface (nominal, tangent plane), mm; slot: width / 2.

        Returns
        -------
        float
            The countersink's or counterbore's radius, half a slot's width, else half the diameter.
        """
        if self.kind == "countersunk":
            return self.countersink_diameter / 2.0
        if self.kind == "counterbored":
            return self.counterbore_diameter / 2.0
        if self.kind in ("slot", "cutout"):
            return self.width / 2.0
        return self.diameter / 2.0


@dataclass(frozen=True)
class PanelSpec:
    """A panel and its features.

    Attributes
    ----------
    width, height : float
        Extent along ``u`` (across the bend; arc length when curved) and ``v``, mm.
    thickness : float
        Sheet thickness, mm (2-6 is typical).
    curvature : {'flat', 'convex', 'concave'}
        Flat, or bent about an axis along ``v`` with the top face outward (convex) or facing the
        axis (concave).
    radius : float or None
        Radius of the top surface, mm (500-2000 is typical); required unless flat, None when flat.
    features : tuple of FeatureSpec
        Features; their outer contours must stay ``_MIN_GAP`` apart and inside the border.
    chord_error : float
        Largest sagitta of a polygon segment (and of a facet across the bend), mm.
    segments : int or None
        Segments per circle for every feature, overriding ``chord_error`` for the contours.
    grid_spacing : float
        Spacing of the background grid of the top and bottom faces, mm.
    """

    width: float
    height: float
    thickness: float
    curvature: str = "flat"
    radius: Optional[float] = None
    features: tuple[FeatureSpec, ...] = ()
    chord_error: float = 1e-4
    segments: Optional[int] = None
    grid_spacing: float = 2.0


@dataclass(frozen=True, eq=False)
class Panel:
    """A panel's mesh and truth.

    Attributes
    ----------
    vertices : (n, 3) float64
        Vertex coordinates, mm, in the world frame of the module docstring.
    triangles : (m, 3) int64
        Vertex indices, counter-clockwise seen from outside (normals point out of the material).
    parts : (m,) int8
        Part of each triangle: :data:`TOP`, :data:`BOTTOM`, :data:`SIDE`, :data:`WALL`, :data:`FLOOR`.
    triangle_feature : (m,) int64
        Index of the feature a WALL or FLOOR triangle belongs to, -1 for the others.
    edge_loops : tuple of (k,) int64
        For each feature, the vertex indices of its visible edge on the top surface, in order
        (counter-clockwise about the axis).
    features : tuple of dict
        Truth per feature, JSON-ready; see :func:`build_panel`.
    spec : PanelSpec
        The specification built.
    """

    vertices: np.ndarray
    triangles: np.ndarray
    parts: np.ndarray
    triangle_feature: np.ndarray
    edge_loops: tuple
    features: tuple
    spec: PanelSpec = field(repr=False)


def _fail(name, expected, value):
    raise SpecError(f"{name} must be {expected}, got {value!r}")


def _number(value) -> bool:
    return not isinstance(value, bool) and isinstance(value, (int, float, np.integer, np.floating)) \
        and math.isfinite(float(value))


def _positive(name, value):
    if not (_number(value) and value > 0):
        _fail(name, "a finite number > 0", value)


def _validate(spec, label="features") -> None:
    if not isinstance(spec, PanelSpec):
        _fail("spec", "a PanelSpec", spec)
    for name in ("width", "height", "thickness", "chord_error", "grid_spacing"):
        _positive(name, getattr(spec, name))
    if spec.curvature not in CURVATURES:
        _fail("curvature", f"one of {', '.join(CURVATURES)}", spec.curvature)
    if spec.curvature == "flat":
        if spec.radius is not None:
            _fail("radius", "None (omitted) for a flat panel", spec.radius)
    else:
        low = _MIN_RADIUS_THICKNESSES * spec.thickness
        if not (_number(spec.radius) and spec.radius >= low):
            _fail("radius", f"a finite number >= {low:g} ({_MIN_RADIUS_THICKNESSES:g} thicknesses) "
                  f"for a {spec.curvature} panel", spec.radius)
        if spec.width / 2.0 > _MAX_HALF_ARC * spec.radius:
            _fail("width", f"at most {2 * _MAX_HALF_ARC * spec.radius:g} (a quarter turn of radius "
                  f"{spec.radius:g})", spec.width)
    if spec.segments is not None and not (isinstance(spec.segments, (int, np.integer))
                                          and not isinstance(spec.segments, bool)
                                          and spec.segments >= 8 and spec.segments % 4 == 0):
        _fail("segments", "None or an integer >= 8 divisible by 4", spec.segments)
    try:
        features = tuple(spec.features)
    except TypeError:
        _fail("features", "a sequence of FeatureSpec", spec.features)
    for k, feature in enumerate(features):
        _validate_feature(f"{label}[{k}]", feature, spec)
    # The gaps between the contours and the checks that need the exact loops (on a curved sheet or
    # for a tilted hole) are made in _checked_loops.


def _validate_feature(name, f, spec) -> None:
    if not isinstance(f, FeatureSpec):
        _fail(name, "a FeatureSpec", f)
    if f.kind not in KINDS:
        _fail(f"{name}.kind", f"one of {', '.join(KINDS)}", f.kind)
    try:
        ok = len(f.center) == 2 and all(_number(v) for v in f.center)
    except TypeError:
        ok = False
    if not ok:
        _fail(f"{name}.center", "2 finite numbers (u, v)", f.center)
    if f.name is not None and not (isinstance(f.name, str) and f.name.strip() and f.name.isprintable()):
        _fail(f"{name}.name", "None or a non-empty printable string", f.name)
    t = spec.thickness
    allowed = {"through": set(), "countersunk": {"countersink_diameter", "countersink_angle_deg"},
               "counterbored": {"counterbore_diameter", "counterbore_depth"}, "blind": {"depth"}, "pocket": {"depth"},
               "slot": {"width", "length", "direction_deg"},
               "cutout": {"width", "length", "direction_deg", "corner_radius"}, "boss": {"height"}}[f.kind]
    if f.kind in _TILTABLE:
        allowed = allowed | {"tilt_deg", "tilt_direction_deg"}
    defaults = FeatureSpec(kind=f.kind, center=f.center)
    for key in ("diameter", "countersink_diameter", "countersink_angle_deg", "counterbore_diameter",
                "counterbore_depth", "depth", "height", "width", "length", "direction_deg", "corner_radius",
                "tilt_deg", "tilt_direction_deg"):
        if key == "diameter" and f.kind not in ("slot", "cutout"):
            continue
        if key not in allowed and getattr(f, key) != getattr(defaults, key):
            _fail(f"{name}.{key}", f"omitted for a {f.kind} feature", getattr(f, key))
    if f.kind not in ("slot", "cutout"):
        _positive(f"{name}.diameter", f.diameter)
    if f.kind in _TILTABLE:
        if not (_number(f.tilt_deg) and 0.0 <= f.tilt_deg < _MAX_TILT_DEG):
            _fail(f"{name}.tilt_deg", f"an angle in degrees from 0 to less than {_MAX_TILT_DEG:g} "
                  "(from the surface normal)", f.tilt_deg)
        if not _number(f.tilt_direction_deg):
            _fail(f"{name}.tilt_direction_deg", "a finite angle in degrees", f.tilt_direction_deg)
    if f.kind == "countersunk":
        if not (_number(f.countersink_diameter) and f.countersink_diameter > f.diameter):
            _fail(f"{name}.countersink_diameter", f"a finite number > diameter ({f.diameter:g})",
                  f.countersink_diameter)
        low, high = _COUNTERSINK_ANGLE_RANGE
        if not (_number(f.countersink_angle_deg) and low <= f.countersink_angle_deg <= high):
            _fail(f"{name}.countersink_angle_deg", f"an angle in degrees from {low:g} to {high:g} "
                  "(82, 90, 100, 110 are standard)", f.countersink_angle_deg)
        depth = _countersink_depth(f)
        if depth >= t - _MIN_WALL:
            _fail(f"{name}.countersink_diameter", f"small enough for the cone's depth ({depth:g}) to "
                  f"stay above the bottom (thickness {t:g})", f.countersink_diameter)
        steepest = 90.0 - _MIN_CONE_CLEARANCE_DEG - f.countersink_angle_deg / 2.0
        if f.tilt_deg > steepest:
            _fail(f"{name}.tilt_deg", f"at most {steepest:g} for a {f.countersink_angle_deg:g} degree "
                  f"countersink (its flattest generator must stay {_MIN_CONE_CLEARANCE_DEG:g} degrees "
                  "off the tangent plane)", f.tilt_deg)
    if f.kind == "counterbored":
        if not (_number(f.counterbore_diameter) and f.counterbore_diameter > f.diameter):
            _fail(f"{name}.counterbore_diameter", f"a finite number > diameter ({f.diameter:g})",
                  f.counterbore_diameter)
        if not (_number(f.counterbore_depth) and 0 < f.counterbore_depth < t):
            _fail(f"{name}.counterbore_depth", f"a number in (0, thickness = {t:g})", f.counterbore_depth)
    if f.kind in ("blind", "pocket"):
        if not (_number(f.depth) and 0 < f.depth < t):
            _fail(f"{name}.depth", f"a number in (0, thickness = {t:g})", f.depth)
    if f.kind == "boss":
        _positive(f"{name}.height", f.height)
    if f.kind in ("slot", "cutout"):
        if f.diameter is not None:
            _fail(f"{name}.diameter", f"omitted for a {f.kind} (give width and length)", f.diameter)
        _positive(f"{name}.width", f.width)
        if not (_number(f.length) and f.length > f.width):
            _fail(f"{name}.length", f"a finite number > width ({f.width:g}), the overall length", f.length)
        if not _number(f.direction_deg):
            _fail(f"{name}.direction_deg", "a finite angle in degrees", f.direction_deg)
    if f.kind == "cutout" and not (_number(f.corner_radius) and 0 < f.corner_radius <= f.width / 2.0):
        _fail(f"{name}.corner_radius", f"a number in (0, width / 2 = {f.width / 2.0:g}]", f.corner_radius)


def _shape(f):
    """The feature's nominal outer contour in (u, v) as a capsule: centre, unit direction, half-length, radius.

    This is the contour of a feature drilled along the normal; a tilted hole's contours are bounded
    by :func:`_contour_shape` of its exact loops instead.
    """
    c = np.array([float(f.center[0]), float(f.center[1])])
    if f.kind == "slot":
        a = math.radians(f.direction_deg)
        return c, np.array([math.cos(a), math.sin(a)]), (f.length - f.width) / 2.0, f.width / 2.0
    if f.kind == "cutout":
        # the capsule about the rectangle's axis that holds its corners (conservative for the gaps)
        a = math.radians(f.direction_deg)
        inner = f.width / 2.0 - f.corner_radius
        return (c, np.array([math.cos(a), math.sin(a)]), (f.length - f.width) / 2.0,
                math.sqrt(2.0) * inner + f.corner_radius)
    return c, np.array([1.0, 0.0]), 0.0, f.outer_radius


def _segment_distance(p0, p1, q0, q1) -> float:
    def point_segment(p, a, b):
        ab = b - a
        den = float(ab @ ab)
        s = 0.0 if den == 0 else min(1.0, max(0.0, float((p - a) @ ab) / den))
        return float(np.hypot(*(p - a - s * ab)))

    d1, d2 = p1 - p0, q1 - q0
    cross = d1[0] * d2[1] - d1[1] * d2[0]
    if cross != 0:
        r = q0 - p0
        s = (r[0] * d2[1] - r[1] * d2[0]) / cross
        u = (r[0] * d1[1] - r[1] * d1[0]) / cross
        if 0 <= s <= 1 and 0 <= u <= 1:
            return 0.0
    return min(point_segment(p0, q0, q1), point_segment(p1, q0, q1),
               point_segment(q0, p0, p1), point_segment(q1, p0, p1))


def _contour_shape(center_uv, contour_uv):
    """A circle about ``center_uv`` (as a capsule of no length) holding every point of ``contour_uv``.

    Parameters
    ----------
    center_uv : (2,) float
        Where the feature's axis meets the face, in (u, v).
    contour_uv : (k, 2) float
        The polygon of the feature's loop on that face, in (u, v).

    Returns
    -------
    tuple
        ``(centre, unit direction, half-length 0, radius)``, the radius the farthest vertex's
        distance (the polygon is convex, so it lies within the circle).
    """
    center_uv = np.asarray(center_uv, dtype=np.float64)
    radius = float(np.max(np.linalg.norm(contour_uv - center_uv, axis=1)))
    return center_uv, np.array([1.0, 0.0]), 0.0, radius


def _check_gaps(features, spec, label, shapes, face="") -> None:
    """Refuse contours (capsules ``shapes``, one per feature) too near the border or each other.

    ``face`` is appended to the messages (e.g. " on the bottom face"); empty for the top face.
    """
    for k, (c, d, half, r) in enumerate(shapes):
        ends = (c - half * d, c + half * d)
        room = min(min(spec.width / 2.0 - abs(e[0]), spec.height / 2.0 - abs(e[1])) for e in ends) - r
        if room < _MIN_GAP:
            _fail(f"{label}[{k}].center", f"at least {_MIN_GAP:g} mm from the border with its contour{face} "
                  f"(it comes within {room:.4g})", tuple(features[k].center))
    for i in range(len(shapes)):
        for j in range(i + 1, len(shapes)):
            ci, di, hi, ri = shapes[i]
            cj, dj, hj, rj = shapes[j]
            gap = _segment_distance(ci - hi * di, ci + hi * di, cj - hj * dj, cj + hj * dj) - ri - rj
            if gap < _MIN_GAP:
                _fail(f"{label}[{j}].center", f"at least {_MIN_GAP:g} mm from {label}[{i}]'s contour{face} "
                      f"(the gap is {gap:.4g})", tuple(features[j].center))


def _ring_limits(spec, shapes):
    """How far each feature's graded rings may reach: 0.9 x half the room to its neighbours and the border."""
    limits = []
    for k, (c, d, half, r) in enumerate(shapes):
        ends = (c - half * d, c + half * d)
        room = min(min(spec.width / 2 - abs(e[0]), spec.height / 2 - abs(e[1])) for e in ends) - r
        for j, (cj, dj, hj, rj) in enumerate(shapes):
            if j != k:
                gap = _segment_distance(c - half * d, c + half * d, cj - hj * dj, cj + hj * dj) - r - rj
                room = min(room, gap / 2)
        limits.append(0.9 * room)
    return limits


def _countersink_depth(f) -> float:
    half = math.radians(f.countersink_angle_deg) / 2.0
    return (f.countersink_diameter - f.diameter) / 2.0 / math.tan(half)
