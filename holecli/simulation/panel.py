"""Closed triangle meshes of aircraft-panel test parts with drilled features, and their exact truth.

A panel is a sheet of ``width x height x thickness`` mm, flat or bent into a cylinder of radius
``radius`` about an axis along the sheet's ``v`` direction, with through holes, countersunk and
counterbored holes, blind holes, rounded slots, rectangular cut-outs (rounded corners) and bosses (pins). :func:`build_panel` returns the mesh (arrays in
memory; writing files is another module's job) and, for every feature, its ground truth.

Frames
------
Sheet frame
    ``(u, v)`` are arc-length coordinates on the top surface, the origin at the panel's centre, ``u``
    across the bend and ``v`` along the bend axis; ``w >= 0`` is the depth below the top surface.
World
    Flat: ``(u, v, w) -> (u, v, -w)``: the top face is z = 0 with normal +z, the material on
    z <= 0. Convex: the axis of curvature is the line x = 0, z = -R; a point goes to
    ``(0, v, -R) + (R - w) (sin(u/R), 0, cos(u/R))`` (top outward, material inside the cylinder).
    Concave: the axis is x = 0, z = +R and a point goes to ``(0, v, R) + (R + w) (sin(u/R), 0,
    -cos(u/R))`` (top facing the axis). In all three the top surface passes through the origin
    with normal +z there.

Construction (no CSG)
---------------------
Every feature is drilled through its centre ``c`` (the image of its ``(u, v)`` centre on the top
surface) along its axis ``a``: the top surface's normal ``n`` at ``c``, or for a hole with
``tilt_deg`` = t and ``tilt_direction_deg`` = phi, ``a = cos(t) n + sin(t) (cos(phi) e_u + sin(phi)
e_v)``. Its walls are exact cylinders and cones about ``a`` and its levels (a countersink's lower
edge, a counterbore's step, a blind floor) planes perpendicular to ``a``, every depth measured
along ``a`` from ``c``. The loops where the walls meet the top and bottom surfaces are computed
exactly (a quadratic per vertex along each wall's generator line: ``a`` for a cylinder, ``a +
tan(half angle) e`` for a cone, ``e`` perpendicular to ``a``), so every mesh vertex lies on the true
surface; only the flat facets between vertices deviate from it.
The top and bottom faces are 2D Delaunay triangulations in ``(u, v)`` of: the panel border, each
feature's contour (mapped back into ``(u, v)``; a tilted hole's contours are bounded by circles
through their farthest vertex, about where the axis meets each face, for the gap checks and the
grid), graded offset rings around each contour (spacing growing by ``_RING_GROWTH`` from the
contour's own spacing, so that the contour's edges are Gabriel edges and therefore Delaunay edges;
this is checked) and a background grid. Triangles whose three
vertices lie on one (convex) contour are inside the feature and dropped. Walls are strips between
loops of the same vertex count; floors are annuli or fans; the four sides are strips between the
top and bottom borders.

Accuracy
--------
Circles get ``N`` segments with sagitta ``r (1 - cos(pi / N)) <= chord_error`` (default 0.1 um),
or ``segments`` if given. On a curved sheet the background grid's ``u`` spacing is limited to
``sqrt(8 R chord_error)`` so the grid's facets stay within ``chord_error`` of the cylinder; the
facets where the rings around a feature meet the grid span up to twice that in ``u`` and reach about
4 x ``chord_error`` (0.4 um at R = 500 mm with the default). Every vertex lies on the exact surface
(to ~1e-12 mm).

Truth
-----
``center`` is where the axis pierces the top surface (``c``), ``normal`` the top normal there,
``axis`` the drilling axis ``a`` (equal to ``normal`` unless the hole is tilted) and
``perpendicularity_deg`` the angle between them (``tilt_deg``); ``tilt_deg`` and
``tilt_direction_deg`` repeat the spec. The drilled sizes are the spec's: ``bore_diameter``,
``countersink_diameter`` (in the plane through ``c`` perpendicular to ``a``) and
``countersink_angle_deg``, ``countersink_depth`` = (countersink_diameter - diameter) / 2 /
tan(half angle) along ``a`` from that plane to the cone's lower edge, ``counterbore_diameter`` /
``counterbore_depth`` and ``floor_depth`` (along ``a`` from ``c``).

``diameter`` is what a measurement of the visible edge is scored against: the *chord-mean
diameter* of the edge loop (where the outermost wall meets the top surface), measured in the
tangent plane at ``c`` and projected along the normal ``n``: the mean length of the chords through
``c`` in ``_TRUTH_SAMPLES`` directions evenly spread over that plane, each chord between two exact
points of the loop. A drilled cylinder meets a cylindrical sheet in a saddle-shaped loop, not a
plane circle; untilted, for a plain or blind bore the chord mean is the drilled diameter exactly,
for a countersink it differs from the nominal diameter by about ``tan(half angle) r^2 / (2R)``
and for a counterbore not at all. A bore tilted by ``t`` meets a flat sheet in an ellipse of axes
``d`` (across the lean) and ``d / cos(t)`` (along it), and ``diameter`` is the mean of its chords
through the centre over all directions, between the two (``edge_diameter_min`` and ``_max`` are
the shortest and longest chords). ``edge_axial_offset`` gives how far the loop leaves the tangent
plane (min, mean, max along the normal; all zero on a flat sheet), so a scorer fitting a 3D circle
knows where its centre should be. Because holes are polygons, ``polygon_circumradius`` and
``polygon_inradius`` describe the mesh's own edge polygon projected along the normal.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Optional

import numpy as np
from scipy.spatial import Delaunay

from holecli.errors import SpecError

__all__ = [
    "BOTTOM",
    "CURVATURES",
    "FLOOR",
    "KINDS",
    "NOT_HOLES",
    "SIDE",
    "TOP",
    "WALL",
    "FeatureSpec",
    "Panel",
    "PanelSpec",
    "build_panel",
    "panel_truth",
    "with_backing",
    "parse_panel_toml",
]

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


# --------------------------------------------------------------------------------------------------
# Specifications


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


# --------------------------------------------------------------------------------------------------
# Validation


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


# --------------------------------------------------------------------------------------------------
# The bend


class _Bend:
    """Sheet frame (u, v, w) to world and back; flat when radius is None."""

    def __init__(self, curvature, radius):
        self.flat = curvature == "flat"
        self.R = None if self.flat else float(radius)
        self.sign = {"flat": 0.0, "convex": 1.0, "concave": -1.0}[curvature]

    def to3d(self, u, v, w):
        u, v, w = (np.asarray(a, dtype=np.float64) for a in (u, v, w))
        if self.flat:
            return np.stack(np.broadcast_arrays(u, v, -w), axis=-1)
        s, R = self.sign, self.R
        phi, rho = u / R, R - s * w
        return np.stack(np.broadcast_arrays(rho * np.sin(phi), v, s * rho * np.cos(phi) - s * R), axis=-1)

    def to2d(self, x):
        x = np.asarray(x, dtype=np.float64)
        if self.flat:
            return x[..., 0], x[..., 1], -x[..., 2]
        s, R = self.sign, self.R
        dx, dz = x[..., 0], x[..., 2] + s * R
        return R * np.arctan2(dx, s * dz), x[..., 1], s * (R - np.hypot(dx, dz))

    def frame(self, u):
        """Unit vectors e_u, e_v and the top normal n = e_u x e_v at arc coordinate u."""
        if self.flat:
            return np.array([1.0, 0, 0]), np.array([0, 1.0, 0]), np.array([0, 0, 1.0])
        s, phi = self.sign, u / self.R
        return (np.array([math.cos(phi), 0.0, -s * math.sin(phi)]), np.array([0, 1.0, 0]),
                np.array([s * math.sin(phi), 0.0, math.cos(phi)]))

    def hit(self, a, b, w, guess):
        """Parameters s with a + s b on the surface at depth w, the root nearest ``guess``.

        a, b : (k, 3) float; returns (k,) float.
        """
        if self.flat:
            return (-w - a[:, 2]) / b[:, 2]
        s, R = self.sign, self.R
        p = np.stack([a[:, 0], a[:, 2] + s * R], axis=1)
        q = np.stack([b[:, 0], b[:, 2]], axis=1)
        qa, qb = np.sum(q * q, axis=1), np.sum(p * q, axis=1)
        qc = np.sum(p * p, axis=1) - (R - s * w) ** 2
        root = np.sqrt(np.maximum(qb * qb - qa * qc, 0.0))
        s1, s2 = (-qb - root) / qa, (-qb + root) / qa
        return np.where(np.abs(s1 - guess) < np.abs(s2 - guess), s1, s2)


# --------------------------------------------------------------------------------------------------
# Features: exact loops


def _segments_for(radius, spec) -> int:
    if spec.segments is not None:
        return int(spec.segments)
    ratio = min(1.0, spec.chord_error / radius)
    n = math.ceil(math.pi / math.acos(1.0 - ratio)) if ratio < 1 else 8
    return max(_MIN_SEGMENTS, 8 * math.ceil(n / 8))


def _slot_outline(f, n_arc):
    """Counter-clockwise stadium outline in its own frame (length along x): (k, 2) float."""
    r, half = f.width / 2.0, (f.length - f.width) / 2.0
    step = math.pi * r / n_arc
    n_side = max(1, math.ceil(2 * half / step))
    side = np.linspace(-half, half, n_side, endpoint=False)
    arc = np.linspace(-math.pi / 2, math.pi / 2, n_arc, endpoint=False)
    right = np.stack([half + r * np.cos(arc), r * np.sin(arc)], axis=1)
    top = np.stack([-side, np.full(n_side, r)], axis=1)
    left = np.stack([-half - r * np.cos(arc), -r * np.sin(arc)], axis=1)
    bottom = np.stack([side, np.full(n_side, -r)], axis=1)
    return np.concatenate([bottom, right, top, left])


def _cutout_outline(f, n_quarter):
    """Counter-clockwise outline of a rectangle with rounded corners in its own frame (length along
    x), every edge at most the corners' segment length: (k, 2) float."""
    r = f.corner_radius
    a, b = f.length / 2.0 - r, f.width / 2.0 - r
    step = 0.5 * math.pi * r / n_quarter
    pieces = []
    for k, (cx, cy) in enumerate(((a, -b), (a, b), (-a, b), (-a, -b))):
        start = -0.5 * math.pi + 0.5 * math.pi * k
        arc = start + np.linspace(0.0, 0.5 * math.pi, n_quarter, endpoint=False)
        pieces.append(np.stack([cx + r * np.cos(arc), cy + r * np.sin(arc)], axis=1))
        # the straight side from this corner's end to the next corner's start
        end = np.array([cx + r * math.cos(start + 0.5 * math.pi), cy + r * math.sin(start + 0.5 * math.pi)])
        nx, ny = ((a, b), (-a, b), (-a, -b), (a, -b))[k]
        nstart = start + 0.5 * math.pi
        target = np.array([nx + r * math.cos(nstart), ny + r * math.sin(nstart)])
        length = float(np.linalg.norm(target - end))
        count = math.ceil(length / step) if length > 1e-12 else 0
        if count:
            t = np.arange(count)[:, None] / count
            pieces.append(end + t * (target - end))
    return np.concatenate(pieces)


@dataclass(frozen=True, eq=False)
class _Loops:
    loops: list          # (k, 3) arrays from the top edge down
    strips: list         # kind of the strip between loops[i] and loops[i + 1]: WALL or FLOOR
    floor_center: Optional[np.ndarray]
    through: bool
    top_s: np.ndarray    # axial offsets of the top loop from the plane through the centre perpendicular to the axis
    top_shape: tuple     # capsule in (u, v) of the top loop: _shape untilted, else _contour_shape of its polygon
    bottom_shape: tuple  # the same for the bottom loop (the top's when the feature does not go through)
    truth: dict


def _rotate(vector, axis, angle):
    """``vector`` turned by ``angle`` radians about the unit ``axis`` (right hand; Rodrigues' formula)."""
    cos, sin = math.cos(angle), math.sin(angle)
    return vector * cos + np.cross(axis, vector) * sin + axis * float(axis @ vector) * (1.0 - cos)


def _drill_frame(eu, ev, n, tilt_deg, tilt_direction_deg):
    """Orthonormal frame ``(e1, e2, a)`` of a hole drilled off the normal, ``e1 x e2 = a``.

    Parameters
    ----------
    eu, ev, n : (3,) float
        The sheet's frame at the hole's centre (``n`` the top normal).
    tilt_deg, tilt_direction_deg : float
        Angle between the axis and ``n``; the direction it leans toward, from ``eu`` toward ``ev``.

    Returns
    -------
    tuple of (3,) float
        ``a = cos(tilt) n + sin(tilt) (cos(dir) eu + sin(dir) ev)``, and ``e1``, ``e2``: ``eu`` and
        ``ev`` turned with it by the smallest rotation taking ``n`` to ``a`` (about ``n x lean``).
        Untilted, ``(eu, ev, n)`` themselves, so that such a hole is meshed exactly as before.
    """
    if tilt_deg == 0:
        return eu, ev, n
    phi = math.radians(tilt_direction_deg)
    lean = math.cos(phi) * eu + math.sin(phi) * ev
    hinge = np.cross(n, lean)
    tilt = math.radians(tilt_deg)
    return _rotate(eu, hinge, tilt), _rotate(ev, hinge, tilt), _rotate(n, hinge, tilt)


def _checked_loops(spec, bend, label):
    """The exact loops of every feature, after checking that their contours keep their distances.

    Parameters
    ----------
    spec : PanelSpec
        A spec that passed :func:`_validate`.
    bend : _Bend
        Its sheet.
    label : str
        How messages name the features (``features`` or ``feature``).

    Returns
    -------
    list of _Loops
        One per feature.

    Raises
    ------
    SpecError
        A step or floor out of the sheet (from :func:`_feature_loops`), or contours within
        ``_MIN_GAP`` of each other or of the border on the top or the bottom face.
    """
    features = tuple(spec.features)
    loops = [_feature_loops(k, f, spec, bend, label) for k, f in enumerate(features)]
    _check_gaps(features, spec, label, [fl.top_shape for fl in loops])
    if any(f.tilt_deg != 0 for f in features):
        # Untilted, the bottom contours are the top's (nominal) ones, checked above.
        _check_gaps(features, spec, label, [fl.bottom_shape for fl in loops], " on the bottom face")
    return loops


def _feature_loops(k, f, spec, bend, label):
    t = spec.thickness
    uc, vc = float(f.center[0]), float(f.center[1])
    eu, ev, n = bend.frame(uc)
    e1, e2, a = _drill_frame(eu, ev, n, f.tilt_deg, f.tilt_direction_deg)
    c = bend.to3d(uc, vc, 0.0)
    name = f"{label}[{k}]"

    def ring(radius, count):
        theta = np.arange(count) * (2 * np.pi / count)
        return np.cos(theta)[:, None] * e1 + np.sin(theta)[:, None] * e2

    def on_surface(base, direction, w, guess):
        s = bend.hit(base, direction, w, guess)
        return base + s[:, None] * direction, s

    def drilled(radius, count, w, guess):
        e = ring(radius, count)
        return on_surface(c + radius * e, np.broadcast_to(a, e.shape), w, guess)

    def level(radius, count, depth):
        return c - depth * a + radius * ring(radius, count)

    perpendicularity = math.degrees(math.atan2(float(np.linalg.norm(np.cross(a, n))), float(a @ n)))
    truth = {"index": k, "name": f.name if f.name is not None else f"{f.kind}{k}", "kind": f.kind,
             "is_hole": f.kind not in NOT_HOLES, "center": [float(v) for v in c],
             "center_uv": [uc, vc], "axis": [float(v) for v in a], "normal": [float(v) for v in n],
             "perpendicularity_deg": perpendicularity, "tilt_deg": float(f.tilt_deg),
             "tilt_direction_deg": float(f.tilt_direction_deg), "partial": False, "arc_deg": 360.0}
    floor_center, strips = None, []
    if f.kind in ("slot", "cutout"):
        if f.kind == "slot":
            n_arc = _segments_for(f.width / 2.0, spec) // 2
            outline = _slot_outline(f, n_arc)
        else:
            n_arc = max(2, _segments_for(f.corner_radius, spec) // 4)
            outline = _cutout_outline(f, n_arc)
        angle = math.radians(f.direction_deg)
        d3 = math.cos(angle) * eu + math.sin(angle) * ev
        b3 = np.cross(n, d3)
        base = c + outline[:, :1] * d3 + outline[:, 1:] * b3
        dirs = np.broadcast_to(n, base.shape)
        top, top_s = on_surface(base, dirs, 0.0, 0.0)
        bottom, _ = on_surface(base, dirs, t, -t)
        loops, strips, segments = [top, bottom], [WALL], (2 if f.kind == "slot" else 4) * n_arc
        truth.update({"diameter": None, "bore_diameter": None, "width": float(f.width),
                      "length": float(f.length), "direction": [float(v) for v in d3],
                      "direction_deg": float(f.direction_deg), "through": True})
        if f.kind == "cutout":
            truth["corner_radius"] = float(f.corner_radius)
    else:
        r = f.diameter / 2.0
        count = _segments_for(f.outer_radius, spec)
        segments = count
        truth.update({"bore_diameter": float(f.diameter), "nominal_diameter": 2.0 * f.outer_radius,
                      "through": f.kind not in ("blind", "boss", "pocket")})
        if f.kind == "countersunk":
            rc, half = f.countersink_diameter / 2.0, math.radians(f.countersink_angle_deg) / 2.0
            h = _countersink_depth(f)
            e = ring(rc, count)
            top, top_s = on_surface(c + rc * e, a + math.tan(half) * e, 0.0, 0.0)
            bottom, bottom_s = drilled(r, count, t, -t)
            loops, strips = [top, level(r, count, h), bottom], [WALL, WALL]
            _check_level(name, "countersink_diameter", f.countersink_diameter, h, top_s, bottom_s)
            truth.update({"countersink_angle_deg": float(f.countersink_angle_deg),
                          "countersink_diameter": float(f.countersink_diameter),
                          "countersink_depth": float(h)})
        elif f.kind == "counterbored":
            rb, h = f.counterbore_diameter / 2.0, f.counterbore_depth
            top, top_s = drilled(rb, count, 0.0, 0.0)
            bottom, bottom_s = drilled(r, count, t, -t)
            loops = [top, level(rb, count, h), level(r, count, h), bottom]
            strips = [WALL, FLOOR, WALL]
            # The step spans r to rb: on a tilted axis (or a concave sheet) its outer rim may come
            # nearer the bottom, and its inner rim nearer the top, than the loops that bound its walls.
            _, inner_top_s = drilled(r, count, 0.0, 0.0)
            _, outer_bottom_s = drilled(rb, count, t, -t)
            _check_level(name, "counterbore_depth", h, h, np.minimum(top_s, inner_top_s),
                         np.maximum(bottom_s, outer_bottom_s))
            truth.update({"counterbore_diameter": float(f.counterbore_diameter),
                          "counterbore_depth": float(h)})
        elif f.kind == "boss":
            top, top_s = drilled(r, count, 0.0, 0.0)
            loops, strips, floor_center = [top, level(r, count, -f.height)], [WALL], c + f.height * a
            if f.height < np.max(top_s) + _MIN_WALL:
                raise SpecError(f"{name}.height must stand at least {_MIN_WALL:g} above the edge on the "
                                f"surface (up to {np.max(top_s):.4g} above the tangent plane), got {f.height!r}")
            truth["height"] = float(f.height)
        elif f.kind in ("blind", "pocket"):
            top, top_s = drilled(r, count, 0.0, 0.0)
            _, bottom_s = drilled(r, count, t, -t)
            loops = [top, level(r, count, f.depth)]
            strips, floor_center = [WALL], c - f.depth * a
            _check_level(name, "depth", f.depth, f.depth, top_s, bottom_s)
            truth["floor_depth"] = float(f.depth)
        else:
            top, top_s = drilled(r, count, 0.0, 0.0)
            bottom, _ = drilled(r, count, t, -t)
            loops, strips = [top, bottom], [WALL]
        truth["bore_polygon_inradius"] = float(r * math.cos(math.pi / count))
        truth.update(_edge_truth(f, bend, c, (e1, e2, a), (eu, ev, n), top))
    truth["segments"] = int(segments)
    through = f.kind not in ("blind", "boss", "pocket")
    if f.tilt_deg == 0:
        top_shape = bottom_shape = _shape(f)
    else:
        top_shape = _contour_shape((uc, vc), np.stack(bend.to2d(loops[0])[:2], axis=1))
        bottom_shape = top_shape
        if through:
            pierce = c + bend.hit(c[None, :], a[None, :], t, -t)[0] * a
            pierce_u, pierce_v, _ = bend.to2d(pierce)
            bottom_shape = _contour_shape((float(pierce_u), float(pierce_v)),
                                          np.stack(bend.to2d(loops[-1])[:2], axis=1))
    return _Loops(loops=loops, strips=strips, floor_center=floor_center, through=through, top_s=top_s,
                  top_shape=top_shape, bottom_shape=bottom_shape, truth=truth)


def _check_level(name, key, value, depth, top_s, bottom_s):
    # A step or floor at `depth` along the axis below the centre must stay below the visible edge
    # and above the bottom surface all round; on a curved sheet or a tilted axis both surfaces leave
    # the plane through the centre perpendicular to the axis.
    if -depth > np.min(top_s) - _MIN_WALL or -depth < np.max(bottom_s) + _MIN_WALL:
        raise SpecError(f"{name}.{key} must put the step or floor (at depth {depth:.4g} along the axis) "
                        f"at least {_MIN_WALL:g} below the top edge (down to {-np.min(top_s):.4g}) and "
                        f"above the bottom (from {-np.max(bottom_s):.4g}), got {value!r}")


def _directions_on_loop(exact_loop, c, eu, ev, directions):
    """Loop parameters whose points, seen along the normal, lie in the given directions from ``c``.

    Parameters
    ----------
    exact_loop : callable
        ``theta (k,) -> (k, 3)`` points of the loop, ``theta`` the angle about the drilling axis.
    c : (3,) float
        The centre.
    eu, ev : (3,) float
        The tangent plane's axes at ``c``.
    directions : (k,) float
        Polar angles in the tangent plane, radians from ``eu`` toward ``ev``.

    Returns
    -------
    (k,) float
        ``theta`` with the projected point of ``exact_loop(theta)`` at polar angle ``directions``
        (Newton's method to ``_DIRECTION_TOLERANCE``; the loop is star-shaped about ``c``).
    """
    def polar(theta):
        rel = exact_loop(theta) - c
        return np.arctan2(rel @ ev, rel @ eu)

    def wrapped(angle):
        return (angle + np.pi) % (2 * np.pi) - np.pi

    theta = np.array(directions, dtype=np.float64)
    step = 1e-6
    for _ in range(_DIRECTION_ITERATIONS):
        miss = wrapped(polar(theta) - directions)
        if np.max(np.abs(miss)) <= _DIRECTION_TOLERANCE:
            return theta
        slope = wrapped(polar(theta + step) - polar(theta - step)) / (2 * step)
        theta = theta - miss / slope
    raise RuntimeError("panel: the edge loop's directions did not converge (a bug)")


def _edge_truth(f, bend, c, drill_frame, sheet_frame, top_polygon) -> dict:
    """Chord-mean diameter etc. of the exact edge loop, and radii of the mesh's edge polygon.

    Everything is measured in the tangent plane at ``c``, projected along the normal: the chords
    through ``c`` at ``_TRUTH_SAMPLES`` directions evenly spread in that plane, the loop's offsets
    from it along the normal, and the mesh polygon's radii about ``c``.
    """
    e1, e2, a = drill_frame
    eu, ev, n = sheet_frame
    rc = f.outer_radius
    slope = math.tan(math.radians(f.countersink_angle_deg) / 2.0) if f.kind == "countersunk" else None

    def exact_loop(theta):
        e = np.cos(theta)[:, None] * e1 + np.sin(theta)[:, None] * e2
        direction = np.broadcast_to(a, e.shape) if slope is None else a + slope * e
        base = c + rc * e
        s = bend.hit(base, direction, 0.0, 0.0)
        return base + s[:, None] * direction

    directions = np.arange(_TRUTH_SAMPLES) * (2 * np.pi / _TRUTH_SAMPLES)
    # Untilted, the loop's point at angle theta about the axis lies in direction theta (seen along n).
    theta = directions if f.tilt_deg == 0 else _directions_on_loop(exact_loop, c, eu, ev, directions)
    loop = exact_loop(theta)
    rel = loop - c
    axial = rel @ n
    plane = rel - axial[:, None] * n
    half = _TRUTH_SAMPLES // 2
    chords = np.linalg.norm(plane[:half] - plane[half:], axis=1)
    # The mesh's own polygon, projected along the normal.
    prel = top_polygon - c
    pplane = prel - (prel @ n)[:, None] * n
    radii = np.linalg.norm(pplane, axis=1)
    nxt = np.roll(pplane, -1, axis=0)
    edge = nxt - pplane
    # Distance from the axis to each polygon edge's line: |p x edge| / |edge| (in the plane).
    inr = np.linalg.norm(np.cross(pplane, edge), axis=1) / np.linalg.norm(edge, axis=1)
    return {"diameter": float(np.mean(chords)), "edge_diameter_min": float(np.min(chords)),
            "edge_diameter_max": float(np.max(chords)),
            "edge_axial_offset": [float(np.min(axial)), float(np.mean(axial)), float(np.max(axial))],
            "polygon_circumradius": float(np.max(radii)), "polygon_inradius": float(np.min(inr))}


# --------------------------------------------------------------------------------------------------
# Faces: 2D triangulation of the top and bottom


def _resample(closed, spacing):
    pts = np.vstack([closed, closed[:1]])
    seg = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    cum = np.concatenate([[0.0], np.cumsum(seg)])
    count = max(8, math.ceil(cum[-1] / spacing))
    at = np.linspace(0.0, cum[-1], count, endpoint=False)
    return np.stack([np.interp(at, cum, pts[:, 0]), np.interp(at, cum, pts[:, 1])], axis=1)


def _rings(contour, limit, max_spacing):
    """Graded offset rings outside a convex counter-clockwise contour: points (k, 2), zone width."""
    tangent = np.roll(contour, -1, axis=0) - np.roll(contour, 1, axis=0)
    normal = np.stack([tangent[:, 1], -tangent[:, 0]], axis=1)
    normal /= np.linalg.norm(normal, axis=1)[:, None]
    spacing = float(np.mean(np.linalg.norm(np.roll(contour, -1, axis=0) - contour, axis=1)))
    offset, out = 0.0, []
    while spacing < max_spacing:
        spacing = min(spacing * _RING_GROWTH, max_spacing)
        if offset + 1.5 * spacing > limit:
            break
        offset += spacing
        out.append(_resample(contour + offset * normal, spacing))
    zone = offset + 0.5 * spacing
    return (np.concatenate(out) if out else np.empty((0, 2))), zone


def _capsule_distance(uv, shape):
    c, d, half, r = shape
    rel = uv - c
    along = np.clip(rel @ d, -half, half)
    return np.linalg.norm(rel - along[:, None] * d, axis=1) - r


def _face(spec, border, contours, shapes, limits, du, dv):
    """Triangulate a face. contours: list of (k, 2) uv loops. Returns uv of the extra points and
    triangles indexing [border, contours..., extra] (counter-clockwise in uv)."""
    pieces, zones = [], []
    max_spacing = min(du, dv)
    for contour, limit in zip(contours, limits):
        pts, zone = _rings(contour, limit, max_spacing)
        pieces.append(pts)
        zones.append(zone)
    nu = max(1, math.ceil(spec.width / du))
    nv = max(1, math.ceil(spec.height / dv))
    gu = np.linspace(-spec.width / 2, spec.width / 2, nu + 1)[1:-1]
    gv = np.linspace(-spec.height / 2, spec.height / 2, nv + 1)[1:-1]
    grid = np.stack(np.meshgrid(gu, gv, indexing="ij"), axis=-1).reshape(-1, 2)
    keep = np.ones(len(grid), dtype=bool)
    for shape, zone in zip(shapes, zones):
        keep &= _capsule_distance(grid, shape) > zone
    extra = np.concatenate(pieces + [grid[keep]]) if pieces else grid[keep]
    uv = np.concatenate([border] + list(contours) + [extra])
    owner = np.full(len(uv), -1)
    start = len(border)
    bounds = []
    for j, contour in enumerate(contours):
        owner[start:start + len(contour)] = j
        bounds.append(start)
        start += len(contour)
    tri = Delaunay(uv).simplices.astype(np.int64)
    p = uv[tri]
    area = (p[:, 1, 0] - p[:, 0, 0]) * (p[:, 2, 1] - p[:, 0, 1]) \
        - (p[:, 1, 1] - p[:, 0, 1]) * (p[:, 2, 0] - p[:, 0, 0])
    tri[area < 0] = tri[area < 0][:, [0, 2, 1]]
    o = owner[tri]
    inside = (o[:, 0] >= 0) & (o[:, 0] == o[:, 1]) & (o[:, 1] == o[:, 2])
    tri = tri[~inside]
    if len(np.unique(tri)) != len(uv):
        raise RuntimeError("panel: the face triangulation lost points (a bug)")
    # Every contour edge must be an edge of the triangulation (else a triangle crosses the contour).
    m = len(uv)
    edges = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    have = set((edges[:, 0] * m + edges[:, 1]).tolist())
    for j, contour in enumerate(contours):
        a = bounds[j] + np.arange(len(contour))
        b = np.roll(a, -1)
        # The face lies outside the contour, so it runs the contour clockwise: edge b -> a.
        if not all(x in have for x in (b * m + a).tolist()):
            raise RuntimeError(f"panel: contour {j} is not followed by the face triangulation (a bug)")
    return extra, tri


def _border(spec, du, dv):
    nu = max(1, math.ceil(spec.width / du))
    nv = max(1, math.ceil(spec.height / dv))
    u = np.linspace(-spec.width / 2, spec.width / 2, nu + 1)
    v = np.linspace(-spec.height / 2, spec.height / 2, nv + 1)
    w2, h2 = spec.width / 2, spec.height / 2
    return np.concatenate([
        np.stack([u[:-1], np.full(nu, -h2)], axis=1),
        np.stack([np.full(nv, w2), v[:-1]], axis=1),
        np.stack([u[::-1][:-1], np.full(nu, h2)], axis=1),
        np.stack([np.full(nv, -w2), v[::-1][:-1]], axis=1),
    ])


# --------------------------------------------------------------------------------------------------
# Assembly


def _strip(a, b):
    """Triangles joining two closed index loops of the same length."""
    a1, b1 = np.roll(a, -1), np.roll(b, -1)
    return np.concatenate([np.stack([a, b, b1], axis=1), np.stack([a, b1, a1], axis=1)])


def _orient(tri, vertices, expected):
    """Flip the triangles if their area-weighted normals point against ``expected`` (k, 3) on the whole."""
    p = vertices[tri]
    normals = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    if np.sum(normals * expected) < 0:
        return tri[:, [0, 2, 1]]
    return tri


def build_panel(spec: PanelSpec) -> Panel:
    """Mesh a panel and compute each feature's truth.

    Parameters
    ----------
    spec : PanelSpec
        The panel; validated here.

    Returns
    -------
    Panel
        Closed, consistently oriented mesh. ``features[k]`` is a dict with ``index``, ``name``,
        ``kind``, ``is_hole`` (False for a slot, a cut-out or a boss), ``center`` (3D, mm: the axis on the top surface),
        ``center_uv``, ``axis`` (unit, the drilling axis, out of the material), ``normal`` (unit,
        the top normal at the centre, out of the material; equal to ``axis`` unless tilted),
        ``perpendicularity_deg`` (the angle between them), ``tilt_deg`` and ``tilt_direction_deg``
        (as specified), ``partial`` (False) and ``arc_deg`` (360), ``through``, ``segments``; for holes
        ``diameter`` (chord-mean diameter of the visible edge in the tangent plane, projected along
        the normal, mm; see the module docstring), ``nominal_diameter``, ``edge_diameter_min`` / ``_max``,
        ``edge_axial_offset`` ([min, mean, max] along the normal, mm), ``bore_diameter``,
        ``polygon_circumradius``, ``polygon_inradius`` (the mesh's edge polygon seen along the
        normal), ``bore_polygon_inradius``; and
        ``countersink_angle_deg``, ``countersink_diameter``, ``countersink_depth`` (along the axis, from
        the centre to the start of the bore) / ``counterbore_diameter``, ``counterbore_depth`` /
        ``floor_depth`` / ``height`` (boss) where they apply; for slots and cut-outs ``width``, ``length``, ``direction``
        (3D unit) and ``direction_deg``, for a cut-out also ``corner_radius``.

    Raises
    ------
    SpecError
        An invalid spec; the message names the field, its value and what was expected.
    """
    _validate(spec)
    return _build(spec, "features")


def _build(spec, label):
    bend = _Bend(spec.curvature, spec.radius)
    t = spec.thickness
    features = tuple(spec.features)
    loops = _checked_loops(spec, bend, label)
    top_shapes = [fl.top_shape for fl in loops]
    bottom_shapes = [fl.bottom_shape for fl in loops]

    # Each feature's rings stay within half the gap to its neighbours and inside the border, on each
    # face with that face's contours (a tilted bore leaves the bottom away from its centre).
    limits = {TOP: _ring_limits(spec, top_shapes), BOTTOM: _ring_limits(spec, bottom_shapes)}
    shapes = {TOP: top_shapes, BOTTOM: bottom_shapes}

    du = dv = spec.grid_spacing
    if not bend.flat:
        smallest = min(bend.R, bend.R - bend.sign * t)
        # Across the bend a facet's sagitta is du^2 / (8 R); along v the sheet is straight.
        du = min(du, math.sqrt(8.0 * smallest * spec.chord_error))
    border = _border(spec, du, dv)
    nb = len(border)

    verts, tris, parts, owners, edge_loops = [], [], [], [], []
    count = 0

    def add(points):
        nonlocal count
        points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        verts.append(points)
        idx = np.arange(count, count + len(points))
        count += len(points)
        return idx

    def emit(tri, part, owner):
        tris.append(tri)
        parts.append(np.full(len(tri), part, dtype=np.int8))
        owners.append(np.full(len(tri), owner, dtype=np.int64))

    top_border = add(bend.to3d(border[:, 0], border[:, 1], 0.0))
    bottom_border = add(bend.to3d(border[:, 0], border[:, 1], t))
    top_ids, bottom_ids = [], []
    for k, fl in enumerate(loops):
        ids = [add(loop) for loop in fl.loops]
        edge_loops.append(ids[0])
        top_ids.append(ids[0])
        for j, kind in enumerate(fl.strips):
            tri = _strip(ids[j], ids[j + 1])
            allv = np.concatenate(verts)
            cen = allv[tri].mean(axis=1)
            n = np.asarray(fl.truth["axis"])
            c = np.asarray(fl.truth["center"])
            if kind == FLOOR:
                expected = np.broadcast_to(n, cen.shape)
            else:
                rel = c - cen
                # Hole walls face their axis, a boss's wall faces away from it.
                expected = (rel - (rel @ n)[:, None] * n) * (-1.0 if features[k].kind == "boss" else 1.0)
            emit(_orient(tri, allv, expected), kind, k)
        if fl.floor_center is not None:
            centre = add(fl.floor_center)[0]
            last = ids[-1]
            tri = np.stack([np.full(len(last), centre), last, np.roll(last, -1)], axis=1)
            allv = np.concatenate(verts)
            emit(_orient(tri, allv, np.asarray(fl.truth["axis"])[None, :]), FLOOR, k)
        if fl.through:
            bottom_ids.append(ids[-1])

    allv = np.concatenate(verts)
    for w, border_ids, feature_ids, part in ((0.0, top_border, top_ids, TOP),
                                            (t, bottom_border, bottom_ids, BOTTOM)):
        contours, contour_shapes, contour_limits = [], [], []
        through = [k for k, fl in enumerate(loops) if fl.through] if part == BOTTOM else range(len(loops))
        for k, ids in zip(through, feature_ids):
            u, v, _ = bend.to2d(allv[ids])
            contours.append(np.stack([u, v], axis=1))
            contour_shapes.append(shapes[part][k])
            contour_limits.append(limits[part][k])
        extra, tri = _face(spec, border, contours, contour_shapes, contour_limits, du, dv)
        extra_ids = add(bend.to3d(extra[:, 0], extra[:, 1], w))
        mapping = np.concatenate([border_ids] + list(feature_ids) + [extra_ids]).astype(np.int64)
        tri = mapping[tri]
        if part == BOTTOM:
            tri = tri[:, [0, 2, 1]]
        emit(tri, part, -1)

    allv = np.concatenate(verts)
    side = _strip(top_border, bottom_border)
    cen = allv[side].mean(axis=1)
    mid = bend.to3d(0.0, 0.0, t / 2)
    emit(_orient(side, allv, cen - mid), SIDE, -1)

    return Panel(vertices=allv, triangles=np.concatenate(tris).astype(np.int64),
                 parts=np.concatenate(parts), triangle_feature=np.concatenate(owners),
                 edge_loops=tuple(edge_loops), features=tuple(fl.truth for fl in loops), spec=spec)


def panel_truth(panel: Panel) -> dict:
    """JSON-ready truth of a panel: the panel's description and its features.

    Parameters
    ----------
    panel : Panel
        From :func:`build_panel`.

    Returns
    -------
    dict
        ``{"panel": {width, height, thickness, curvature, radius, chord_error, segments,
        grid_spacing}, "features": [...], "holes": [the features with is_hole], "vertices": n,
        "triangles": m}``; the feature dicts are those of :func:`build_panel`.
    """
    s = panel.spec
    features = [dict(f) for f in panel.features]
    return {
        "panel": {"width": float(s.width), "height": float(s.height), "thickness": float(s.thickness),
                  "curvature": s.curvature, "radius": None if s.radius is None else float(s.radius),
                  "chord_error": float(s.chord_error),
                  "segments": None if s.segments is None else int(s.segments),
                  "grid_spacing": float(s.grid_spacing)},
        "features": features,
        "holes": [f for f in features if f["is_hole"]],
        "vertices": int(len(panel.vertices)),
        "triangles": int(len(panel.triangles)),
    }


# --------------------------------------------------------------------------------------------------
# TOML

_PANEL_KEYS = ("width", "height", "thickness", "curvature", "radius", "chord_error", "segments",
               "grid_spacing")
_TILT_KEYS = ("tilt_deg", "tilt_direction_deg")
_FEATURE_KEYS = {
    "through": ("diameter",) + _TILT_KEYS,
    "countersunk": ("diameter", "countersink_diameter", "countersink_angle_deg") + _TILT_KEYS,
    "counterbored": ("diameter", "counterbore_diameter", "counterbore_depth") + _TILT_KEYS,
    "blind": ("diameter", "depth") + _TILT_KEYS,
    "slot": ("width", "length", "direction_deg"),
    "cutout": ("width", "length", "direction_deg", "corner_radius"),
    "boss": ("diameter", "height"),
    "pocket": ("diameter", "depth"),
}
_OPTIONAL_FEATURE_KEYS = {"countersink_angle_deg", "direction_deg"} | set(_TILT_KEYS)


def parse_panel_toml(text) -> PanelSpec:
    """A panel spec from the text of a TOML file.

    The file may declare the unit of its lengths at its top, ``units = "in"`` (``"mm"``, ``"m"``): they
    are converted into millimetres, the simulator's unit (without it they are millimetres). It holds
    one ``[panel]`` table (``width``, ``height``, ``thickness``; optional
    ``curvature`` = "flat" | "convex" | "concave", ``radius`` (required when curved),
    ``chord_error``, ``segments``, ``grid_spacing``) and any number of ``[[feature]]`` tables
    (``kind``, ``center = [u, v]``, optional ``name``, and the keys of that kind: ``diameter``;
    ``countersink_diameter``, ``countersink_angle_deg`` (default 100); ``counterbore_diameter``,
    ``counterbore_depth``; ``depth``; ``height`` (boss); for a slot ``width``, ``length``, ``direction_deg``
    (default 0), for a cut-out those and ``corner_radius``; for a hole (not a slot, a cut-out or a boss) ``tilt_deg`` and ``tilt_direction_deg`` (default
    0: drilled along the normal)).

    Parameters
    ----------
    text : str
        The TOML text.

    Returns
    -------
    PanelSpec
        The panel and its features, in the file's order.

    Raises
    ------
    SpecError
        Invalid TOML, an unknown or missing key, a value of the wrong type or out of range. The
        message names the table (``panel`` or ``feature[k]``, counting from 0) and the key.
    """
    from holecli.tolerance import load_toml  # a BOM skipped, integers no float holds refused

    from holecli.units import declared_units

    data = load_toml(text, "panel", first_index=0)
    try:
        units = declared_units(data, "panel")
    except ValueError as error:
        raise SpecError(str(error)) from None
    unknown = sorted(set(data) - {"panel", "feature"})
    if unknown:
        raise SpecError(f"unknown top-level key {unknown[0]!r} (expected units, [panel] and [[feature]] tables)")
    if units is not None:
        _in_millimetres(data, units)
    panel = data.get("panel")
    if not isinstance(panel, dict):
        raise SpecError("expected a [panel] table")
    unknown = sorted(set(panel) - set(_PANEL_KEYS))
    if unknown:
        raise SpecError(f"panel: unknown key {unknown[0]!r} (expected {', '.join(_PANEL_KEYS)})")
    for key in ("width", "height", "thickness"):
        if key not in panel:
            raise SpecError(f"panel: missing key {key!r}")
    for key in ("width", "height", "thickness", "radius", "chord_error", "grid_spacing"):
        if key in panel and not _number(panel[key]):
            raise SpecError(f"panel.{key} must be a number, got {panel[key]!r}")
    if "segments" in panel and (isinstance(panel["segments"], bool) or not isinstance(panel["segments"], int)):
        raise SpecError(f"panel.segments must be an integer, got {panel['segments']!r}")
    curvature = panel.get("curvature", "flat")
    if curvature not in CURVATURES:
        raise SpecError(f"panel.curvature must be one of {', '.join(CURVATURES)}, got {curvature!r}")
    if curvature != "flat" and "radius" not in panel:
        raise SpecError(f"panel: missing key 'radius' (needed by curvature = {curvature!r})")
    tables = data.get("feature", [])
    if not isinstance(tables, list) or not all(isinstance(tb, dict) for tb in tables):
        raise SpecError("expected [[feature]] tables (an array of tables)")
    features = []
    for k, table in enumerate(tables):
        where = f"feature[{k}]"
        kind = table.get("kind")
        if kind not in _FEATURE_KEYS:
            raise SpecError(f"{where}.kind must be one of {', '.join(KINDS)}, got {kind!r}")
        allowed = ("kind", "center", "name") + _FEATURE_KEYS[kind]
        unknown = sorted(set(table) - set(allowed))
        if unknown:
            raise SpecError(f"{where}: unknown key {unknown[0]!r} for a {kind} feature "
                            f"(expected {', '.join(allowed)})")
        required = ("center",) + tuple(key for key in _FEATURE_KEYS[kind] if key not in _OPTIONAL_FEATURE_KEYS)
        missing = [key for key in required if key not in table]
        if missing:
            raise SpecError(f"{where}: missing key {missing[0]!r}")
        center = table["center"]
        if not (isinstance(center, list) and len(center) == 2 and all(_number(v) for v in center)):
            raise SpecError(f"{where}.center must be 2 finite numbers [u, v], got {center!r}")
        values = {}
        for key in _FEATURE_KEYS[kind]:
            if key in table:
                if not _number(table[key]):
                    raise SpecError(f"{where}.{key} must be a number, got {table[key]!r}")
                values[key] = float(table[key])
        features.append(FeatureSpec(kind=kind, center=(float(center[0]), float(center[1])),
                                    name=table.get("name"), **values))
    values = {key: (float(panel[key]) if key != "segments" else panel[key])
              for key in _PANEL_KEYS if key in panel and key != "curvature"}
    spec = PanelSpec(curvature=curvature, features=tuple(features), **values)
    _validate(spec, label="feature")
    # The gap and depth checks that need the exact loops run here too, so that a file is refused on reading.
    _checked_loops(spec, _Bend(spec.curvature, spec.radius), "feature")
    return spec


# The keys of a panel file that are not lengths: the shape's word, a count, and the angles (``..._deg``).
_NOT_LENGTHS = ("curvature", "segments", "kind", "name")


def _in_millimetres(data, units):
    """Multiply every length of a panel file's data (``[panel]`` and ``[[feature]]``: every number but
    ``segments`` and the angles, ``..._deg``; both coordinates of ``center``) from ``units`` into mm, the
    unit the simulator works in, in place. A value that is not a number is left for the checks to refuse."""
    from holecli.units import scale_factor

    factor = scale_factor(units, "mm")
    tables = [data.get("panel")] + list(data.get("feature") or [])
    for table in tables:
        if not isinstance(table, dict):
            continue
        for key, value in table.items():
            if key in _NOT_LENGTHS or key.endswith("_deg"):
                continue
            if _number(value):
                table[key] = float(value) * factor
            elif key == "center" and isinstance(value, list) and all(_number(v) for v in value):
                table[key] = [float(v) * factor for v in value]


def with_backing(panel, gap, margin=5.0):
    """The panel's mesh with a flat backing plate ``gap`` mm behind its bottom face, as
    ``(vertices, triangles)``: what a sensor sees through the panel's holes when the part lies on a
    fixture, or when the face is one leg of a bracket with the other behind it.

    The plate is one thin box (0.5 mm) parallel to a flat panel's top face, its top at ``z =
    -(thickness + gap)`` and reaching ``margin`` mm beyond the panel's border; only flat panels.
    Together with :class:`holecli.simulation.profiler.ProfilerSpec`'s ``view`` (an inclined face)
    and ``frame`` (a part turned over in the file's frame) it makes the scans of issue 24's
    "surfaces facing away from +z": floors seen through holes behind a surface whose normal points
    anywhere.

    Parameters
    ----------
    panel : Panel
        A flat panel (:func:`build_panel`).
    gap : float
        Distance from the panel's bottom face to the plate's top, mm, > 0.
    margin : float
        How far the plate reaches beyond the panel's border, mm, >= 0.

    Returns
    -------
    vertices : (n, 3) float64
    triangles : (m, 3) int64
    """
    spec = panel.spec
    if spec.curvature != "flat":
        _fail("curvature", "'flat' for a backing plate", spec.curvature)
    if not (_number(gap) and gap > 0):
        _fail("gap", "a positive number (mm)", gap)
    if not (_number(margin) and margin >= 0):
        _fail("margin", "a number >= 0 (mm)", margin)
    half_u, half_v = 0.5 * spec.width + margin, 0.5 * spec.height + margin
    top, bottom = -(spec.thickness + gap), -(spec.thickness + gap + 0.5)
    corners = np.array([[-half_u, -half_v], [half_u, -half_v], [half_u, half_v], [-half_u, half_v]])
    box = np.vstack([np.column_stack([corners, np.full(4, top)]), np.column_stack([corners, np.full(4, bottom)])])
    # Counter-clockwise seen from outside: the top up, the bottom down, the four sides out.
    faces = [(0, 1, 2), (0, 2, 3), (4, 6, 5), (4, 7, 6)]
    for a in range(4):
        b = (a + 1) % 4
        faces += [(a, a + 4, b + 4), (a, b + 4, b)]
    offset = len(panel.vertices)
    return (np.vstack([panel.vertices, box]),
            np.vstack([panel.triangles, np.asarray(faces, dtype=np.int64) + offset]))
