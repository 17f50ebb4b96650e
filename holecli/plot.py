"""Pictures of a detection for an inspector: :func:`figure` draws the holes of a scan with matplotlib.

Pure: a :class:`holecli.Detection` and the scan's points in, a :class:`matplotlib.figure.Figure`
out (drawn on the Agg canvas: no display is needed, nothing is shown and no file is written; the
command line writes the PNG, see :func:`png_bytes`). matplotlib is the optional extra ``plot``
(``pip install 'holecli[plot]'``); it is imported by these functions only, never by the rest of
holecli.

One row per hole (the first ``max_panels``):

* the points around the hole seen along its normal, in the hole's plane frame (the in-plane
  offsets from its center, within :data:`VIEW_RADII` radii), coloured by their height above the
  surface (along the normal), with the fitted edge circle and its center, and the countersink and
  bore circles where they were measured;
* the radial residuals of the edge against the angle (polar): for each angular sector, the
  nearest surface point to the center, minus the fitted radius (the rim points themselves are not
  in the result: these are the points that bound the hole);
* a text box with the hole's values: diameter, center, normal, type, countersink, bore, warnings.
"""

from __future__ import annotations

import io

import numpy as np

__all__ = ["VIEW_RADII", "figure", "png_bytes", "plane_frame", "edge_residuals"]

# Points within this many hole radii of its center (in its plane) are drawn.
VIEW_RADII = 2.0
# Angular sectors of the edge residual plot.
EDGE_SECTORS = 180
# Points further from the surface than this many plane rms (and at least 1 % of the radius) are not
# surface points: the edge is where the surface points end.
SURFACE_BAND_RMS = 4.0


def plane_frame(normal):
    """Two unit vectors that make a right-handed frame ``(u, v, normal)``.

    Parameters
    ----------
    normal : (3,) float
        The hole's unit normal.

    Returns
    -------
    u, v : (3,) float ndarray
        ``u`` is the world x axis made perpendicular to the normal (y when the normal is along x).
    """
    n = np.asarray(normal, dtype=float)
    n = n / np.linalg.norm(n)
    seed = np.array([1.0, 0.0, 0.0]) if abs(n[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    u = seed - seed.dot(n) * n
    u /= np.linalg.norm(u)
    return u, np.cross(n, u)


def _local(points, hole):
    """The in-plane offsets ``(a, b)`` and heights ``h`` of ``points`` in the frame of ``hole``."""
    u, v = plane_frame(hole.normal)
    d = np.asarray(points, dtype=float) - np.asarray(hole.center, dtype=float)
    return d @ u, d @ v, d @ np.asarray(hole.normal, dtype=float)


def edge_residuals(points, hole, plane_rms=0.0, sectors=EDGE_SECTORS):
    """The edge of a hole as the scan shows it, against its fitted circle.

    Parameters
    ----------
    points : (n, 3) float
        The scan's points.
    hole : holecli.results.Hole
        The hole.
    plane_rms : float
        The plane's rms: points within :data:`SURFACE_BAND_RMS` of it (and within 1 % of the radius)
        from the surface are surface points.
    sectors : int
        Angular sectors.

    Returns
    -------
    angle : (m,) float ndarray
        The angle of each sector's nearest surface point, radians, in the frame of :func:`plane_frame`.
    residual : (m,) float ndarray
        Its distance from the center minus the fitted radius (file units): positive outside the circle.
    """
    radius = hole.diameter / 2.0
    a, b, h = _local(points, hole)
    r = np.hypot(a, b)
    band = max(SURFACE_BAND_RMS * plane_rms, 0.01 * radius)
    keep = (np.abs(h) <= band) & (r <= VIEW_RADII * radius)
    angle, r = np.arctan2(b[keep], a[keep]), r[keep]
    sector = np.minimum(((angle + np.pi) / (2 * np.pi) * sectors).astype(int), sectors - 1)
    order = np.lexsort((r, sector))  # by sector, then nearest first
    first = np.ones(order.size, dtype=bool)
    first[1:] = sector[order][1:] != sector[order][:-1]
    chosen = order[first]
    return angle[chosen], r[chosen] - radius


def _number(value, unit="", digits=4):
    return "-" if value is None else f"{value:.{digits}g}{unit}"


# The coverage factor of the expanded uncertainties the text box gives (value ± k u).
COVERAGE_FACTOR = 2.0


def _with_expanded(label, value, standard, unit):
    """``label: value ± U unit (k=2)``, or without ``± U`` when the uncertainty is not known."""
    if standard is None:
        return f"{label}: {value:.4f}{unit}"
    return f"{label}: {value:.4f} ± {COVERAGE_FACTOR * standard:.2g}{unit} (k={COVERAGE_FACTOR:g})"


def hole_text(hole, unit=None):
    """The text box of a hole: its values, one per line.

    Parameters
    ----------
    hole : holecli.results.Hole
    unit : str or None
        The length unit for the labels.

    Returns
    -------
    str
    """
    u = f" {unit}" if unit else ""
    lines = [
        f"hole {hole.index}" + (" (partial, arc %.0f°)" % hole.arc_deg if hole.partial else ""),
        _with_expanded("diameter", hole.diameter, None if hole.uncertainty is None else hole.uncertainty.diameter, u),
        "center: (" + ", ".join(f"{c:.4f}" for c in hole.center) + f"){u}"
        + ("" if hole.uncertainty is None else f" ± {COVERAGE_FACTOR * hole.uncertainty.center_in_plane:.2g} in plane"),
        "normal: (" + ", ".join(f"{c:.4f}" for c in hole.normal) + ")",
        f"type: {hole.type or '-'}",
        f"fit rms: {hole.fit_rms:.3g}{u}, rim points: {hole.rim_points}",
    ]
    if hole.countersink is not None:
        c = hole.countersink
        lines.append(f"countersink: dia {_number(c.diameter, u)}, angle {_number(c.angle_deg, '°')}, "
                     f"depth {_number(c.depth, u)}")
    if hole.counterbore is not None:
        lines.append(f"counterbore: dia {_number(hole.counterbore.diameter, u)}, "
                     f"depth {_number(hole.counterbore.depth, u)}")
    if hole.bore is not None and hole.bore.diameter is not None:
        lines.append(f"bore: dia {_number(hole.bore.diameter, u)}")
    if hole.perpendicularity_deg is not None:
        lines.append(f"perpendicularity: {hole.perpendicularity_deg:.3f}°")
    codes = [w.code for w in hole.warnings]
    lines.append("warnings: " + (", ".join(codes) if codes else "none"))
    return "\n".join(lines)


def figure(detection, points, max_panels=None, unit=None, title=None):
    """Draw the holes of a detection.

    Parameters
    ----------
    detection : holecli.Detection
        What :func:`holecli.detect` (or :func:`holecli.detect_file`) found in ``points``.
    points : (n, 3) float
        The scan's points (file units, as the detection).
    max_panels : int, optional
        Draw the first this many holes only (by default all of them).
    unit : str, optional
        The unit of the coordinates, for the labels (by default ``detection.units``, else "units").
    title : str, optional
        The figure's title (by default the file, its points and the holes found).

    Returns
    -------
    matplotlib.figure.Figure
        On the Agg canvas. The axes of each hole's view have ``gid`` ``"hole N"`` (its
        :class:`matplotlib.patches.Circle` of the edge has ``gid`` ``"edge N"``); its polar axes
        ``"edge N"``, its text axes ``"text N"``. Without a hole, one axes shows the scan from above
        the plane with "no hole found".
    """
    from matplotlib.figure import Figure
    from matplotlib.patches import Circle

    unit = unit or detection.units
    label_unit = unit or "units"
    points = np.asarray(points, dtype=float)
    holes = list(detection.holes if max_panels is None else detection.holes[:max_panels])
    rows = max(len(holes), 1)
    fig = Figure(figsize=(14, 4.6 * rows), dpi=100, layout="constrained")
    if title is None:
        name = detection.file or "points"
        shown = "" if len(holes) == len(detection.holes) else f", first {len(holes)} shown"
        title = (f"{name}: {detection.points} points, {len(detection.holes)} hole"
                 f"{'' if len(detection.holes) == 1 else 's'} (method {detection.method}{shown})")
    fig.suptitle(title, fontsize=12)
    if not holes:
        ax = fig.add_subplot(1, 1, 1, gid="no hole")
        plane = detection.plane
        u, v = plane_frame(plane.normal)
        d = points - np.asarray(plane.point)
        ax.scatter(d @ u, d @ v, s=1, c="0.4", rasterized=True)
        ax.set_aspect("equal")
        ax.set_xlabel(f"u [{label_unit}]")
        ax.set_ylabel(f"v [{label_unit}]")
        ax.set_title("no hole found (the scan seen along the plane's normal)")
        return fig
    grid = fig.add_gridspec(rows, 3, width_ratios=[1.25, 0.9, 0.85])
    for row, hole in enumerate(holes):
        radius = hole.diameter / 2.0
        a, b, h = _local(points, hole)
        near = np.hypot(a, b) <= VIEW_RADII * radius
        # the view along the normal: points near the hole coloured by height
        ax = fig.add_subplot(grid[row, 0], gid=f"hole {hole.index}")
        order = np.argsort(h[near])  # the highest on top
        scatter = ax.scatter(a[near][order], b[near][order], c=h[near][order], s=4, cmap="viridis",
                             linewidths=0, rasterized=True)
        bar = fig.colorbar(scatter, ax=ax, shrink=0.9)
        bar.set_label(f"height above the surface [{label_unit}]")
        ax.add_patch(Circle((0, 0), radius, fill=False, color="red", lw=1.8, gid=f"edge {hole.index}",
                            label=f"edge Ø {hole.diameter:.4f}"))
        ax.plot([0], [0], "+", color="red", ms=12, mew=2, label="center")
        countersink = hole.countersink.diameter if hole.countersink is not None else None
        if countersink is not None and abs(countersink - hole.diameter) > 1e-9 * hole.diameter:
            ax.add_patch(Circle((0, 0), countersink / 2.0, fill=False, color="orange", lw=1.4, ls="--",
                                gid=f"countersink {hole.index}", label=f"countersink Ø {countersink:.4f}"))
        bore = hole.bore.diameter if hole.bore is not None else None
        if bore is not None:
            ax.add_patch(Circle((0, 0), bore / 2.0, fill=False, color="magenta", lw=1.4, ls=":",
                                gid=f"bore {hole.index}", label=f"bore Ø {bore:.4f}"))
        extent = VIEW_RADII * radius
        ax.set_xlim(-extent, extent)
        ax.set_ylim(-extent, extent)
        ax.set_aspect("equal")
        ax.set_xlabel(f"in-plane offset u [{label_unit}]")
        ax.set_ylabel(f"in-plane offset v [{label_unit}]")
        ax.set_title(f"hole {hole.index}: seen along its normal")
        ax.legend(loc="upper right", fontsize=7, framealpha=0.8)
        ax.grid(True, lw=0.3, alpha=0.5)
        # the edge's radial residuals
        polar = fig.add_subplot(grid[row, 1], projection="polar", gid=f"edge {hole.index}")
        # about one sector per rim point: a thinner sector of a coarse scan holds no edge point
        angle, residual = edge_residuals(points, hole, detection.plane.rms,
                                         sectors=int(np.clip(hole.rim_points, 24, EDGE_SECTORS)))
        if angle.size:
            order = np.argsort(angle)
            polar.plot(angle[order], residual[order], ".-", ms=3, lw=0.6, color="tab:blue")
            span = max(1.2 * float(np.percentile(np.abs(residual), 98)), 1e-12)
            polar.set_ylim(-span, span)
        polar.plot(np.linspace(0, 2 * np.pi, 361), np.zeros(361), color="red", lw=1)
        polar.set_title(f"edge: nearest surface point − fitted radius [{label_unit}]\n"
                        f"(red: the fitted circle; angle in the u, v frame)", fontsize=9)
        polar.tick_params(labelsize=7)
        # the values
        text = fig.add_subplot(grid[row, 2], gid=f"text {hole.index}")
        text.axis("off")
        text.text(0.02, 0.98, hole_text(hole, unit), transform=text.transAxes, va="top", ha="left",
                  family="monospace", fontsize=8.5,
                  bbox={"boxstyle": "round", "facecolor": "#fff8e0", "edgecolor": "0.5"}, gid=f"values {hole.index}")
    return fig


def png_bytes(fig, dpi=None, palette=True):
    """The PNG of a figure (Agg).

    Parameters
    ----------
    fig : matplotlib.figure.Figure
    dpi : float, optional
        Default: the figure's.
    palette : bool
        Write a 256-colour palette PNG (Pillow, a dependency of matplotlib): a third to a quarter of
        the bytes of a true-colour one, which the colour maps and antialiased lines fill with
        distinct colours.

    Returns
    -------
    bytes
    """
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=dpi)
    if not palette:
        return buffer.getvalue()
    from PIL import Image

    buffer.seek(0)
    with Image.open(buffer) as image:
        quantized = image.convert("RGB").quantize(256, dither=Image.Dither.NONE)
    out = io.BytesIO()
    quantized.save(out, format="PNG", optimize=True)
    return out.getvalue()
