"""A feature's exact loops: where its walls meet the top and bottom surfaces, its levels, and the
truth of its edge (the chord-mean diameter and the edge polygon)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional

import numpy as np

from holecli.errors import SpecError
from holecli.simulation.panel.spec import (FLOOR, NOT_HOLES, WALL, _DIRECTION_ITERATIONS, _DIRECTION_TOLERANCE,
                                           _MIN_SEGMENTS, _MIN_WALL, _TRUTH_SAMPLES, _check_gaps, _contour_shape,
                                           _countersink_depth, _shape)


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
