"""A CAD part to scan: loaded from a panel spec or a mesh, with the profiler aimed at it and the frame
it is moved into (``holecli simulate panel`` and ``simulate lot``).

:func:`panel_part` and :func:`mesh_part` give the part's mesh, the truth of its features and a
description of it; :func:`aimed_profiler` the :class:`holecli.simulation.profiler.ProfilerSpec` of the
command line's profiler options, whose lengths and target default to the part's extent and its middle;
:func:`rigid_frame` the 4 x 4 matrix of a rotation and a translation; :func:`cad_scan` a cloud made from the
mesh as engineers make one (:mod:`holecli.simulation.cad_cloud`), with its truth.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from holecli.simulation.cad_cloud import cad_cloud, cad_truth, cloud_pitch
from holecli.simulation.mesh_truth import mesh_truth
from holecli.simulation.panel import build_panel, panel_truth, parse_panel_toml
from holecli.simulation.profiler import ProfilerSpec, load_mesh
from holecli.simulation.synth import rotation_matrix

__all__ = ["Part", "aimed_profiler", "cad_scan", "mesh_part", "panel_part", "rigid_frame"]


@dataclass(frozen=True, eq=False)
class Part:
    """A part to scan.

    Attributes
    ----------
    vertices : numpy.ndarray
        (N, 3) vertices of its mesh, in the part's frame (mm).
    triangles : numpy.ndarray
        (M, 3) vertex indices of its triangles.
    features : list of dict
        The truth of its features (holes, cutouts), in the part's frame.
    description : dict
        What the part is (the panel and its spec file, or the mesh file and its size), for a truth file.
    not_holes : list of dict
        The features of a panel that are not holes (cutouts); none for a mesh.
    """

    vertices: np.ndarray
    triangles: np.ndarray
    features: list
    description: dict
    not_holes: list = field(default_factory=list)


def panel_part(spec, source=None) -> Part:
    """The panel of ``spec`` (a :class:`holecli.simulation.panel.PanelSpec`, or the text of a TOML spec
    read from the file ``source``, named in the description).

    Raises
    ------
    holecli.errors.SpecError
        When the spec is invalid.
    """
    panel = build_panel(parse_panel_toml(spec) if isinstance(spec, str) else spec)
    truth = panel_truth(panel)
    features = truth["features"]
    return Part(panel.vertices, panel.triangles, features, {"panel": truth["panel"], "source": source},
                [f for f in features if not f.get("is_hole", True)])


def mesh_part(path, view) -> Part:
    """The triangle mesh in the file ``path``, its holes found as seen along ``view``; a hole's diameter
    is the edge at the surface (the circle through the edge polygon's vertices).

    Raises
    ------
    holecli.errors.LoadError
        When the file cannot be read as a mesh.
    ValueError
        When its holes cannot be found.
    """
    vertices, triangles = load_mesh(path)
    truth = mesh_truth(vertices, triangles, view=view)
    features = [dict(feature, diameter=feature.get("edge_diameter")) for feature in truth["features"]]
    return Part(vertices, triangles, features, {"mesh": path, "vertices": len(vertices), "triangles": len(triangles)})


def rigid_frame(rotation, translation):
    """The 4 x 4 matrix rotating by ``rotation`` (degrees about x, then y, then z; None: none) and then
    translating by ``translation`` (None: none); None when both are None (the part's own frame)."""
    if rotation is None and translation is None:
        return None
    frame = np.eye(4)
    frame[:3, :3] = rotation_matrix(rotation or (0.0, 0.0, 0.0))
    frame[:3, 3] = translation or (0.0, 0.0, 0.0)
    return frame


def aimed_profiler(vertices, *, view, line, target, line_length, scan_length, rotation, translation, spacing,
                   line_pitch, standoff, parallel_rays, triangulation_deg, max_incidence_deg, range_noise,
                   range_quantum, dropout, jitter, line_width, keep_nan, metres, float64) -> ProfilerSpec:
    """The profiler of ``simulate panel``'s options (named as its parameters) aimed at the part of
    ``vertices``: ``target`` defaults to the middle of the part, on its side facing the sensor (as far
    against ``view`` as its nearest vertex), ``line_length`` and ``scan_length`` to the part's extent
    along the line and along the travel, ``line_pitch`` to ``spacing``.

    Raises
    ------
    ValueError
        When ``view`` or ``line`` is zero, or ``line`` is along ``view``.
    """
    view = np.asarray(view, dtype=np.float64)
    line = np.asarray(line, dtype=np.float64)
    if np.linalg.norm(view) == 0 or np.linalg.norm(line) == 0:
        raise ValueError("--view and --line must not be zero")
    view, line = view / np.linalg.norm(view), line / np.linalg.norm(line)
    motion = np.cross(line, view)
    if np.linalg.norm(motion) < 1e-6:
        raise ValueError("--line must not be along --view")
    motion /= np.linalg.norm(motion)
    low, high = vertices.min(axis=0), vertices.max(axis=0)
    if target is not None:
        target = np.asarray(target, dtype=np.float64)
    else:
        middle = 0.5 * (low + high)
        target = middle + (float(np.min(vertices @ view)) - float(middle @ view)) * view
    line_length = line_length or float(np.ptp(vertices @ line))
    scan_length = scan_length or float(np.ptp(vertices @ motion))
    matrix = rigid_frame(rotation, translation)
    frame = None if matrix is None else tuple(map(tuple, matrix))
    return ProfilerSpec(target=tuple(target), standoff=standoff, view=tuple(view), line=tuple(line),
                        line_length=line_length, scan_length=scan_length, point_pitch=spacing,
                        line_pitch=line_pitch or spacing, fan=not parallel_rays,
                        triangulation_deg=triangulation_deg, max_incidence_deg=max_incidence_deg,
                        range_noise=range_noise, range_quantum=range_quantum, dropout=dropout,
                        jitter=jitter, line_width=line_width, keep_nan=keep_nan, frame=frame,
                        unit_scale=1e-3 if metres else 1.0, float32=not float64)


def cad_scan(part: Part, kind, spacing, *, faces, noise, seed, rotation, translation, view, line, target,
             line_length, scan_length, float64):
    """The cloud of kind ``kind`` (vertices, surface, lattice) made from ``part``'s mesh, in the frame of
    ``rotation`` and ``translation`` (see :func:`rigid_frame`), rounded to single precision unless
    ``float64``, and its truth in the validation suite's format.

    Returns
    -------
    points : numpy.ndarray
        (N, 3) points.
    truth : dict
        :func:`holecli.simulation.cad_cloud.cad_truth` of the cloud.
    pitch : float
        The cloud's point pitch (:func:`holecli.simulation.cad_cloud.cloud_pitch`).

    Raises
    ------
    ValueError
        When the cloud or its truth cannot be made (a :class:`holecli.errors.SpecError` among them).
    """
    frame = rigid_frame(rotation, translation)
    region = dict(view=view, line=line, target=target, line_length=line_length, scan_length=scan_length)
    points = cad_cloud(part.vertices, part.triangles, kind, spacing, faces=faces, noise=noise, rng=seed, **region)
    pitch = cloud_pitch(points, kind, spacing)
    truth = cad_truth(part.vertices, part.triangles, pitch=pitch, faces=faces, kind=kind, frame=frame,
                      not_holes=part.not_holes, **region)
    if frame is not None:
        points = points @ frame[:3, :3].T + frame[:3, 3]
    if not float64:
        points = points.astype(np.float32).astype(np.float64)
    return points, truth, pitch
