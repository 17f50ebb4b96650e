"""The closed mesh: faces, walls, floors and sides assembled (:func:`build_panel`), its truth
(:func:`panel_truth`), and a backing plate behind it (:func:`with_backing`)."""

from __future__ import annotations

import math

import numpy as np

from holecli.simulation.panel.spec import (BOTTOM, FLOOR, Panel, PanelSpec, SIDE, TOP, _fail, _number,
                                           _ring_limits, _validate)
from holecli.simulation.panel.bend import _Bend
from holecli.simulation.panel.loops import _checked_loops
from holecli.simulation.panel.faces import _border, _face

__all__ = ["build_panel", "panel_truth", "with_backing"]


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
