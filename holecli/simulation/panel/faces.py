"""The top and bottom faces: a 2D Delaunay triangulation in ``(u, v)`` of the border, the feature
contours, the graded rings around them and a background grid."""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial import Delaunay

from holecli.simulation.panel.spec import _RING_GROWTH


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
