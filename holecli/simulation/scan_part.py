"""A CAD part scanned by the simulated laser profiler, with the ground truth of what the scan shows.

:mod:`holecli.simulation.profiler` turns a mesh into points; :mod:`holecli.simulation.panel` (built parts) and
:mod:`holecli.simulation.mesh_truth` (any mesh) say where the mesh's holes are. This module puts the two
together: the truth of every feature is carried into the frame and units of the scan's points, and
each feature says whether its edge lies wholly in the scanned region (``inside_scan``), partly
(``partial``) or not at all (left out of ``holes``).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from holecli.simulation.profiler import ProfilerScan, ProfilerSpec, scan_mesh, transform_to_frame

__all__ = ["PartScan", "scan_part"]

# Truth keys that hold a length (scaled with the points), a point (moved with them) or a direction
# (turned with them).
_LENGTHS = ("diameter", "bore_diameter", "nominal_diameter", "countersink_diameter", "countersink_depth",
            "counterbore_diameter", "counterbore_depth", "floor_depth", "depth", "height", "width", "length",
            "edge_diameter_min", "edge_diameter_max", "polygon_circumradius", "polygon_inradius",
            "bore_polygon_inradius")
_POINTS = ("center",)
_DIRECTIONS = ("axis", "normal", "direction")
# Angles (perpendicularity_deg, tilt_deg, tilt_direction_deg, direction_deg, countersink_angle_deg) are
# left as they are: a rigid motion and a change of unit keep them (the directions are the sheet's).


@dataclass(frozen=True, eq=False)
class PartScan:
    """A simulated scan of a part.

    Attributes
    ----------
    scan : ProfilerScan
        The points and what the profiler saw (see :func:`holecli.simulation.profiler.scan_mesh`).
    truth : dict
        JSON-ready: ``holes`` (the features that are holes and whose edge the scanned region
        reaches, in the scan's frame and units, each with ``inside_scan`` and ``partial``),
        ``features`` (the other features there: slots, bosses, with ``is_hole`` false), ``profiler``
        (the spec) and ``info`` (the profiler's counts).
    """

    scan: ProfilerScan
    truth: dict


def scan_part(vertices, triangles, features, spec: ProfilerSpec, rng=0) -> PartScan:
    """Scan a mesh with the profiler and carry its features' truth into the scan's frame.

    Parameters
    ----------
    vertices : (n, 3) array_like of float
        Mesh vertices (mm, the part's frame).
    triangles : (m, 3) array_like of int
        Mesh faces.
    features : sequence of dict
        The part's features in the part's frame, as :func:`holecli.simulation.panel.panel_truth` or
        :func:`holecli.simulation.mesh_truth.mesh_truth` give them: ``center``, ``normal`` (and ``axis``),
        ``is_hole``, and ``diameter`` (the edge at the surface) or, for a slot, ``length``.
    spec : ProfilerSpec
        The sensor and its path.
    rng : int or numpy.random.Generator
        Random source of the profiler's noise.

    Returns
    -------
    PartScan
        The scan's points and the features' truth in the scan's frame.

    Raises
    ------
    holecli.errors.SpecError
        As for :func:`holecli.simulation.profiler.scan_mesh`: an invalid mesh or ``spec``.
    """
    scan = scan_mesh(vertices, triangles, spec, rng=rng)
    target = np.asarray(spec.target, dtype=np.float64)
    line = _unit(spec.line)
    view = _unit(spec.view)
    motion = _unit(spec.motion) if spec.motion is not None else _unit(np.cross(line, view))
    holes, others = [], []
    for feature in features:
        size = feature.get("diameter") or feature.get("length") or 0.0
        offset = np.asarray(feature["center"], dtype=np.float64) - target
        along_line, along_motion = abs(float(offset @ line)), abs(float(offset @ motion))
        half_line, half_scan = 0.5 * spec.line_length, 0.5 * spec.scan_length
        reach = 0.5 * float(size)
        if along_line - reach > half_line or along_motion - reach > half_scan:
            continue  # the scanned region does not reach it
        inside = along_line + reach <= half_line and along_motion + reach <= half_scan
        moved = _in_scan_frame(feature, spec)
        moved["inside_scan"] = bool(inside)
        moved["partial"] = bool(feature.get("partial", False)) or not inside
        (holes if feature.get("is_hole") else others).append(moved)
    profiler = {key: (list(value) if isinstance(value, tuple) else value) for key, value in asdict(spec).items()}
    truth = {"holes": holes, "features": others, "profiler": profiler, "info": dict(scan.info)}
    return PartScan(scan=scan, truth=truth)


def _unit(vector):
    vector = np.asarray(vector, dtype=np.float64)
    return vector / np.linalg.norm(vector)


def _in_scan_frame(feature, spec):
    """``feature`` with its points, directions and lengths in the frame and units of the scan."""
    matrix = None if spec.frame is None else np.asarray(spec.frame, dtype=np.float64)
    out = dict(feature)
    for key in _POINTS:
        if out.get(key) is not None:
            out[key] = transform_to_frame(np.asarray([out[key]], dtype=np.float64), matrix, spec.unit_scale)[0].tolist()
    for key in _DIRECTIONS:
        if out.get(key) is not None and matrix is not None:
            turned = matrix[:3, :3] @ np.asarray(out[key], dtype=np.float64)
            out[key] = (turned / np.linalg.norm(turned)).tolist()
    for key in _LENGTHS:
        if isinstance(out.get(key), (int, float)) and not isinstance(out.get(key), bool):
            out[key] = float(out[key]) * spec.unit_scale
    if isinstance(out.get("edge_axial_offset"), list):
        out["edge_axial_offset"] = [float(v) * spec.unit_scale for v in out["edge_axial_offset"]]
    return out
