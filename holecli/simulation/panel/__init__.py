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

Where each thing happens (every name of ``__all__`` is importable from here):
:mod:`~holecli.simulation.panel.spec` (the specs, the kinds and face labels, validation),
:mod:`~holecli.simulation.panel.bend` (sheet frame to world), :mod:`~holecli.simulation.panel.loops`
(a feature's exact loops and edge truth), :mod:`~holecli.simulation.panel.faces` (the top and bottom
triangulations), :mod:`~holecli.simulation.panel.assembly` (:func:`build_panel`, :func:`panel_truth`,
:func:`with_backing`) and :mod:`~holecli.simulation.panel.toml` (:func:`parse_panel_toml`).
"""

from __future__ import annotations

from holecli.simulation.panel.spec import BOTTOM, CURVATURES, FLOOR, FeatureSpec, KINDS, NOT_HOLES, Panel, PanelSpec, SIDE, TOP, WALL
from holecli.simulation.panel.assembly import build_panel, panel_truth, with_backing
from holecli.simulation.panel.toml import parse_panel_toml

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
