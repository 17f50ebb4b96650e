"""Pictures of a detection for an inspector: :func:`figure` draws the holes of a scan with matplotlib.

Pure: a :class:`holecli.Detection` and the scan's points in, a :class:`matplotlib.figure.Figure`
out (drawn on the Agg canvas: no display is needed, nothing is shown and no file is written; the
command line writes the PNG, see :func:`png_bytes`). matplotlib is the optional extra ``plot``
(``pip install 'holecli[plot]'``); it is imported by these functions only, never by the rest of
holecli.

One row per hole (the first ``max_panels``):

* the points around the hole seen along its normal, in the hole's plane frame (the in-plane
  offsets from its center, within :data:`VIEW_RADII` radii), coloured by their height above the
  surface (along the normal), with the fitted edge circle and its center, the countersink and bore
  circles where they were measured, the rim points used and rejected and the surface points inside
  the hole (:func:`rim_points`: the result does not carry its rim points, they are re-derived from
  the scan), a scale bar of a round length (:func:`scale_length`) and the legend below the view;
* the radial residuals of the edge against the angle (polar): for each angular sector, the
  nearest surface point to the center, minus the fitted radius, the rejected ones marked;
* the countersink gauge reading (with ``--gauge-depth``): the cone's circle at the gauge depth,
  dash-dotted, labelled with its diameter and depth;
* a text box with the hole's values: diameter ± U, center, normal, type, countersink, gauge, bore,
  warnings, notes (when there are), and, last, its conformance and verdict (:func:`verdict_lines`) when the checked record
  is given.
"""

from __future__ import annotations

import io
from dataclasses import dataclass

import numpy as np

from holecli.geometry.kernels import robust_sigma

__all__ = ["PICTURE_UNIT", "VIEW_RADII", "ZONE_CHECKS", "RimPoints", "edge_residuals", "figure", "hole_text",
           "in_unit", "plane_frame", "png_bytes", "rim_points", "scale_length", "tolerance_zones", "verdict_lines",
           "zone_notes"]

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


def _surface_points(points, hole, plane_rms=0.0):
    """The local coordinates ``a, b`` and radii ``r`` of the points around ``hole``, and which of them
    are surface points (within the band of the surface and :data:`VIEW_RADII` radii)."""
    radius = hole.diameter / 2.0
    a, b, h = _local(points, hole)
    r = np.hypot(a, b)
    band = max(SURFACE_BAND_RMS * plane_rms, 0.01 * radius)
    surface = (np.abs(h) <= band) & (r <= VIEW_RADII * radius)
    return a, b, r, surface


def _nearest_per_sector(a, b, r, surface, sectors=EDGE_SECTORS, min_radius=None):
    """The index of each angular sector's surface point nearest to the center (of those at least
    ``min_radius`` from it, when given)."""
    candidates = np.flatnonzero(surface if min_radius is None else surface & (r >= min_radius))
    angle = np.arctan2(b[candidates], a[candidates])
    sector = np.minimum(((angle + np.pi) / (2 * np.pi) * sectors).astype(int), sectors - 1)
    order = np.lexsort((r[candidates], sector))  # by sector, then nearest first
    first = np.ones(order.size, dtype=bool)
    first[1:] = sector[order][1:] != sector[order][:-1]
    return candidates[order[first]]


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
    a, b, r, surface = _surface_points(points, hole, plane_rms)
    chosen = _nearest_per_sector(a, b, r, surface, sectors)
    return np.arctan2(b[chosen], a[chosen]), r[chosen] - hole.diameter / 2.0


# A rim point is "used" when its radial residual is within this many robust standard deviations
# (1.4826 MAD) of the fitted radius.
RIM_ROBUST_SIGMAS = 4.0


@dataclass(frozen=True)
class RimPoints:
    """The rim of a hole re-derived from the scan (the result does not carry its rim points).

    Attributes
    ----------
    offsets : (m, 2) float ndarray
        In-plane offsets ``(u, v)`` from the hole's center of each sector's surface point nearest to
        the center (file units, the frame of :func:`plane_frame`).
    residual : (m,) float ndarray
        Their distance from the center minus the fitted radius.
    used : (m,) bool ndarray
        Within :data:`RIM_ROBUST_SIGMAS` robust standard deviations of the fitted radius.
    inside : (k, 2) float ndarray
        The other surface points within the fitted radius (outliers inside the hole).
    limit : float
        The largest ``|residual|`` of a used point.
    """

    offsets: np.ndarray
    residual: np.ndarray
    used: np.ndarray
    inside: np.ndarray
    limit: float

    @property
    def angle(self):
        """The angle of each rim point, radians."""
        return np.arctan2(self.offsets[:, 1], self.offsets[:, 0])


def rim_points(points, hole, plane_rms=0.0, sectors=EDGE_SECTORS):
    """The rim points of a hole, used and rejected, and the surface points inside it.

    The result does not carry the points its edge was fitted to; they are re-derived here. For each
    of ``sectors`` angular sectors, the surface point nearest to the center (as
    :func:`edge_residuals`) gives the residuals ``r - R``; their robust spread is
    ``sigma = 1.4826 * median(|r - R|)`` (the MAD about the fitted radius; of the sectors' nearest
    points beyond ``R - 4 fit_rms``, since outliers inside the hole may be the nearest point of most
    sectors) and the limit ``4 sigma`` (:data:`RIM_ROBUST_SIGMAS`; at least
    1e-9 R). A sector's nearest point inside ``R - limit`` is *rejected* (an outlier inside the hole)
    and the sector's rim is its nearest point beyond ``R - limit``, *used* when ``r - R <= limit``,
    *rejected* otherwise (a gap). The other surface points inside ``R - limit`` are ``inside``.

    Parameters
    ----------
    points : (n, 3) float
        The scan's points.
    hole : holecli.results.Hole
        The hole.
    plane_rms : float
        The plane's rms (see :func:`edge_residuals`).
    sectors : int
        Angular sectors.

    Returns
    -------
    RimPoints
    """
    radius = hole.diameter / 2.0
    a, b, r, surface = _surface_points(points, hole, plane_rms)
    nearest = _nearest_per_sector(a, b, r, surface, sectors)
    # the spread from the sectors' nearest points not far inside (by the fit's own rms): outliers
    # inside the hole may be the nearest point of most sectors
    window = RIM_ROBUST_SIGMAS * max(hole.fit_rms, 1e-3 * radius)
    near_edge = _nearest_per_sector(a, b, r, surface, sectors, min_radius=radius - window)
    spread = robust_sigma(r[near_edge] - radius) if near_edge.size else 0.0
    limit = max(RIM_ROBUST_SIGMAS * spread, 1e-9 * radius)
    first = r[nearest] - radius
    rim = _nearest_per_sector(a, b, r, surface, sectors, min_radius=radius - limit)
    outliers = nearest[first < -limit]
    chosen = np.concatenate([rim, outliers])
    residual = r[chosen] - radius
    used = np.zeros(chosen.size, dtype=bool)
    used[:rim.size] = residual[:rim.size] <= limit
    inside = surface & (r < radius - limit)
    inside[outliers] = False
    return RimPoints(offsets=np.column_stack([a[chosen], b[chosen]]), residual=residual, used=used,
                     inside=np.column_stack([a[inside], b[inside]]), limit=limit)


def scale_length(span):
    """A round length (1, 2 or 5 times a power of ten) of about a quarter of ``span``.

    Parameters
    ----------
    span : float
        The width of the view (> 0).

    Returns
    -------
    float
        The largest round length not above ``span / 4``.

    Examples
    --------
    >>> scale_length(12.0), scale_length(4.0), scale_length(0.03)
    (2.0, 1.0, 0.005)
    """
    target = span / 4.0
    power = 10.0 ** np.floor(np.log10(target))
    for step in (5.0, 2.0, 1.0):
        if step * power <= target * (1 + 1e-9):
            return float(f"{step * power:.3g}")
    return float(f"{power:.3g}")


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
        if c.gauge_depth is not None:
            lines.append(f"gauge: dia {_number(c.diameter_at_depth, u)} at depth {_number(c.gauge_depth, u)}")
    if hole.counterbore is not None:
        lines.append(f"counterbore: dia {_number(hole.counterbore.diameter, u)}, "
                     f"depth {_number(hole.counterbore.depth, u)}")
    if hole.bore is not None and hole.bore.diameter is not None:
        lines.append(f"bore: dia {_number(hole.bore.diameter, u)}")
    if hole.perpendicularity_deg is not None:
        lines.append(f"perpendicularity: {hole.perpendicularity_deg:.3f}°")
    codes = [w.code for w in hole.warnings]
    lines.append("warnings: " + (", ".join(codes) if codes else "none"))
    if hole.notes:
        lines.append("notes: " + ", ".join(note.code for note in hole.notes))
    return "\n".join(lines)


def _conformance_line(check, entry):
    """One check of a hole's ``conformance``: ``diameter -0.0031 in [+0, +0.036] U 0.011: fail``."""
    band = entry.get("lower") is not None
    value = entry.get("value")
    value_text = "not measured" if value is None else (f"{value:+.4g}" if band else f"{value:.4g}")
    limits = f"in [{entry['lower']:+.4g}, {entry['upper']:+.4g}]" if band else f"<= {entry['upper']:.4g}"
    expanded = entry.get("expanded_uncertainty")
    return f"  {check} {value_text} {limits} U {'-' if expanded is None else f'{expanded:.2g}'}: {entry['decision']}"


def verdict_lines(checked_hole, unit=None):
    """The tolerance lines of a hole's text box, the verdict last.

    Parameters
    ----------
    checked_hole : dict or None
        The hole of a record checked by :func:`holecli.tolerance.check` (with ``in_tolerance``,
        ``failed_checks``, ``undecided_checks`` and ``conformance``); None, or a hole without
        ``in_tolerance``, when no tolerance was given.
    unit : str, optional
        The unit of the record's values (the deviations and limits), for the header line.

    Returns
    -------
    list of str
        ``"verdict: no tolerance given"`` alone; else ``"tolerance (in UNIT):"``, one line per check
        (value, limits, U, decision) and ``"verdict: pass"``, ``"verdict: fail: CHECK, ..."`` (with
        ``"; undecided: CHECK, ..."`` when some are) or ``"verdict: undecided: CHECK, ..."``;
        ``"verdict: not checked (no nominal applies)"`` for a hole that no nominal applies to.
    """
    if checked_hole is None or "in_tolerance" not in checked_hole:
        return ["verdict: no tolerance given"]
    if checked_hole["in_tolerance"] is None:
        return ["verdict: not checked (no nominal applies)"]
    lines = ["tolerance" + (f" (in {unit}):" if unit else ":")]
    lines.extend(_conformance_line(check, entry) for check, entry in (checked_hole.get("conformance") or {}).items())
    failed = list(checked_hole.get("failed_checks") or ())
    undecided = list(checked_hole.get("undecided_checks") or ())
    if checked_hole["in_tolerance"]:
        lines.append("verdict: pass")
    elif failed:
        lines.append("verdict: fail: " + ", ".join(failed) + ("; undecided: " + ", ".join(undecided) if undecided else ""))
    else:
        lines.append("verdict: undecided: " + ", ".join(undecided))
    return lines


# The text box's colour by verdict.
_VERDICT_COLOURS = {"pass": "#e3f5e1", "fail": "#fbe0e0", "undecided": "#fdf0d0"}


# The fields of a detection's dataclasses (Plane, Hole, Countersink, ..., Uncertainty) that are lengths:
# scaled into the picture's unit (:func:`in_unit`); every other number (angles, counts) is kept.
_LENGTH_FIELDS = frozenset({"point", "rms", "center", "diameter", "fit_rms", "max_residual", "roundness",
                            "bias_correction", "depth", "diameter_at_depth", "gauge_depth", "floor_depth", "floor_rms",
                            "depth_range", "center_in_plane", "center_along_normal"})

# The unit a picture's lengths are drawn in when the scan's unit is known.
PICTURE_UNIT = "mm"

# The band checks drawn as a nominal circle and a tolerance zone in the view along the normal: check ->
# the path of its measured diameter in a checked hole (the nominal is that value minus the check's
# deviation). A new diameter check shows in the picture by its entry here.
ZONE_CHECKS = {"diameter": ("diameter",), "countersink_diameter": ("countersink", "diameter"),
               "bore_diameter": ("bore", "diameter"), "countersink_gauge": ("countersink", "diameter_at_depth")}


def in_unit(value, factor):
    """A detection (or any of its parts) with every length multiplied by ``factor``.

    Parameters
    ----------
    value : holecli.Detection, dataclass, tuple or float
    factor : float

    Returns
    -------
    The same kind of value; the very object when ``factor`` is 1.
    """
    from dataclasses import fields, is_dataclass, replace

    if factor == 1.0:
        return value
    if is_dataclass(value):
        changes = {}
        for field in fields(value):
            item = getattr(value, field.name)
            if field.name in _LENGTH_FIELDS and item is not None and not is_dataclass(item):
                changes[field.name] = _times(item, factor)
            elif is_dataclass(item) or (isinstance(item, tuple) and item and is_dataclass(item[0])):
                changes[field.name] = (in_unit(item, factor) if is_dataclass(item)
                                       else tuple(in_unit(part, factor) for part in item))
        return replace(value, **changes)
    return value


def _times(value, factor):
    if isinstance(value, (tuple, list, np.ndarray)):
        return tuple(float(part) * factor for part in value)
    return value * factor if isinstance(value, (int, float)) and not isinstance(value, bool) else value


def tolerance_zones(checked_hole, factor=1.0):
    """The nominal diameters and tolerance zones of a checked hole's diameter checks (:data:`ZONE_CHECKS`).

    Parameters
    ----------
    checked_hole : dict or None
        A hole of a checked record.
    factor : float
        Multiplies the record's lengths into the picture's unit.

    Returns
    -------
    list of (str, float, float, float, bool)
        ``(check, nominal, smallest, largest, exceeded)`` diameters; ``exceeded``: the check's U is wider
        than its zone (:func:`holecli.tolerance.uncertainty_exceeds_zone`). A check whose value is not
        measured has no nominal here (the record does not hold it) and is left out.

    Examples
    --------
    >>> hole = {"diameter": 3.99, "conformance": {"diameter": {"value": -0.01, "lower": -0.02, "upper": 0.02,
    ...                                                       "expanded_uncertainty": 0.046}}}
    >>> [(check, round(nominal, 6), round(low, 6), round(high, 6), exceeded)
    ...  for check, nominal, low, high, exceeded in tolerance_zones(hole)]
    [('diameter', 4.0, 3.98, 4.02, True)]
    """
    from holecli.tolerance import uncertainty_exceeds_zone

    zones = []
    for check, entry in ((checked_hole or {}).get("conformance") or {}).items():
        path = ZONE_CHECKS.get(check)
        if path is None or entry.get("value") is None or entry.get("lower") is None:
            continue
        measured = checked_hole
        for key in path:
            measured = (measured or {}).get(key)
        if measured is None:
            continue
        nominal = measured - entry["value"]
        zones.append((check, nominal * factor, (nominal + entry["lower"]) * factor, (nominal + entry["upper"]) * factor,
                      uncertainty_exceeds_zone(entry)))
    return zones


def zone_notes(checked_hole):
    """The text box's notes of the checks whose U exceeds their tolerance zone: ``note: diameter: 2U = ...``."""
    from holecli.tolerance import uncertainty_exceeds_zone, uncertainty_zone_message

    import textwrap

    return [line for check, entry in ((checked_hole or {}).get("conformance") or {}).items()
            if uncertainty_exceeds_zone(entry)
            for line in textwrap.wrap("note: " + uncertainty_zone_message(check, entry), 56,
                                      subsequent_indent="  ")]


def _add_gauge_circle(ax, hole, label_unit):
    """The countersink gauge reading in the view along the normal: the cone's circle at the gauge depth
    (``countersink.diameter_at_depth`` at ``gauge_depth`` below the surface), dash-dotted, when measured."""
    from matplotlib.patches import Circle

    countersink = hole.countersink
    if countersink is None or countersink.diameter_at_depth is None:
        return
    ax.add_patch(Circle((0, 0), countersink.diameter_at_depth / 2.0, fill=False, color="darkviolet", lw=1.4,
                        ls="-.", gid=f"gauge {hole.index}",
                        label=f"gauge Ø {countersink.diameter_at_depth:.4f} at depth {countersink.gauge_depth:g} "
                              f"{label_unit}"))


def _add_scale_bar(ax, span, label_unit, gid):
    """A scale bar of a round length (:func:`scale_length`) in the lower left corner of ``ax``."""
    from matplotlib.font_manager import FontProperties
    from mpl_toolkits.axes_grid1.anchored_artists import AnchoredSizeBar

    length = scale_length(span)
    unit_text = "unit" if label_unit == "units" and length == 1 else label_unit
    bar = AnchoredSizeBar(ax.transData, length, f"{length:g} {unit_text}", loc="lower left", pad=0.4,
                          borderpad=0.6, sep=3, color="black", frameon=True, size_vertical=span / 150.0,
                          fontproperties=FontProperties(size=8))
    bar.patch.set_alpha(0.85)
    bar.set_gid(gid)
    ax.add_artist(bar)
    return bar


def figure(detection, points, max_panels=None, unit=None, title=None, checked=None, checked_unit=None,
           picture_unit=PICTURE_UNIT):
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
    checked : list of dict, optional
        The holes of the record checked against tolerances (:func:`holecli.tolerance.check`), matched
        to the detection's by ``index``: each text box ends with their conformance and verdict
        (:func:`verdict_lines`). None: "verdict: no tolerance given".
    checked_unit : str, optional
        The unit of the checked record's values (``--output-units``), for the text box (the record's
        conformance stays in it) and the tolerance zones (by default ``unit``).
    picture_unit : str or None
        The unit the lengths are drawn and labelled in when ``unit`` is known (default mm); None: the
        file's. Unknown ``unit``: the file's numbers, labelled "units".

    Returns
    -------
    matplotlib.figure.Figure
        On the Agg canvas. The axes of each hole's view have ``gid`` ``"hole N"`` (its
        :class:`matplotlib.patches.Circle` of the edge has ``gid`` ``"edge N"``, its rim points the
        collections ``"rim used N"`` and ``"rim rejected N"``, the surface points inside the radius
        ``"inside N"``, its scale bar ``"scale bar N"``; the legend below it); its polar axes
        ``"edge N"``, its text axes ``"text N"`` (the text ``"values N"``). Without a hole, one axes
        ``"no hole"`` shows the scan from above the plane with "no hole found" (and ``"scale bar"``).
        A checked hole's diameter checks (:data:`ZONE_CHECKS`) add the nominal circle (``gid``
        ``"nominal CHECK N"``, dash-dotted) and the tolerance zone between the smallest and the largest
        diameter (``"tolerance zone CHECK N"``, a shaded ring); a check whose U exceeds its zone is
        said in the text box (``note: ...``) and its zone is hatched.
    """
    from matplotlib.figure import Figure
    from matplotlib.patches import Circle, Wedge

    from holecli.units import scale_factor

    unit = unit or detection.units
    record_unit = checked_unit or unit
    zone_factor = scale_factor(record_unit, unit) if record_unit and unit else 1.0
    if unit and picture_unit and unit != picture_unit:  # the picture in mm: the detection and points scaled
        factor = scale_factor(unit, picture_unit)
        detection, points, unit = in_unit(detection, factor), np.asarray(points, dtype=float) * factor, picture_unit
        zone_factor *= factor
    label_unit = unit or "units"
    points = np.asarray(points, dtype=float)
    holes = list(detection.holes if max_panels is None else detection.holes[:max_panels])
    checked_by_index = None if checked is None else {hole.get("index"): hole for hole in checked}
    rows = max(len(holes), 1)
    fig = Figure(figsize=(14, 4.6 * rows), dpi=100, layout="constrained")
    if title is None:
        name = detection.file or "points"
        shown = "" if len(holes) == len(detection.holes) else f", first {len(holes)} shown"
        title = (f"{name}: {detection.points} points, {len(detection.holes)} hole"
                 f"{'' if len(detection.holes) == 1 else 's'} (method {detection.method}{shown}; "
                 f"lengths in {label_unit})")
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
        if len(points):
            span = float(np.ptp(d @ u)) or 1.0
            _add_scale_bar(ax, span, label_unit, "scale bar")
        return fig
    grid = fig.add_gridspec(rows, 3, width_ratios=[1.25, 0.9, 0.85])
    for row, hole in enumerate(holes):
        radius = hole.diameter / 2.0
        a, b, h = _local(points, hole)
        near = np.hypot(a, b) <= VIEW_RADII * radius
        checked_hole = None if checked_by_index is None else checked_by_index.get(hole.index)
        name = f" ({checked_hole['name']})" if checked_hole and checked_hole.get("name") else ""
        # the view along the normal: points near the hole coloured by height
        ax = fig.add_subplot(grid[row, 0], gid=f"hole {hole.index}")
        order = np.argsort(h[near])  # the highest on top
        scatter = ax.scatter(a[near][order], b[near][order], c=h[near][order], s=4, cmap="viridis",
                             linewidths=0, rasterized=True)
        bar = fig.colorbar(scatter, ax=ax, shrink=0.9)
        bar.set_label(f"height above the surface [{label_unit}]")
        # about one sector per rim point: a thinner sector of a coarse scan holds no edge point
        rim = rim_points(points, hole, detection.plane.rms, sectors=int(np.clip(hole.rim_points, 24, EDGE_SECTORS)))
        used, rejected = rim.offsets[rim.used], rim.offsets[~rim.used]
        ax.scatter(used[:, 0], used[:, 1], s=18, marker="o", facecolors="none", edgecolors="black", linewidths=0.8,
                   label=f"rim points used: {len(used)}", gid=f"rim used {hole.index}")
        ax.scatter(rejected[:, 0], rejected[:, 1], s=28, marker="x", color="crimson", linewidths=1.2,
                   label=f"rim points rejected: {len(rejected)} (|r − R| > {rim.limit:.2g})",
                   gid=f"rim rejected {hole.index}")
        if len(rim.inside):
            ax.scatter(rim.inside[:, 0], rim.inside[:, 1], s=14, marker="D", color="cyan", edgecolors="black",
                       linewidths=0.4, label=f"surface points inside the hole: {len(rim.inside)}",
                       gid=f"inside {hole.index}")
        ax.add_patch(Circle((0, 0), radius, fill=False, color="red", lw=1.8, gid=f"edge {hole.index}",
                            label=f"edge Ø {hole.diameter:.4f} {label_unit}"))
        ax.plot([0], [0], "+", color="red", ms=12, mew=2, label="center")
        countersink = hole.countersink.diameter if hole.countersink is not None else None
        if countersink is not None and abs(countersink - hole.diameter) > 1e-9 * hole.diameter:
            ax.add_patch(Circle((0, 0), countersink / 2.0, fill=False, color="orange", lw=1.4, ls="--",
                                gid=f"countersink {hole.index}",
                                label=f"countersink Ø {countersink:.4f} {label_unit}"))
        _add_gauge_circle(ax, hole, label_unit)
        bore = hole.bore.diameter if hole.bore is not None else None
        if bore is not None:
            ax.add_patch(Circle((0, 0), bore / 2.0, fill=False, color="magenta", lw=1.4, ls=":",
                                gid=f"bore {hole.index}", label=f"bore Ø {bore:.4f} {label_unit}"))
        for check, nominal, smallest, largest, exceeded in tolerance_zones(checked_hole, zone_factor):
            words = check.replace("_", " ")
            ax.add_patch(Wedge((0, 0), largest / 2.0, 0, 360, width=(largest - smallest) / 2.0, color="tab:green",
                               alpha=0.25, lw=0, hatch="xx" if exceeded else None,
                               gid=f"tolerance zone {check} {hole.index}",
                               label=f"{words} zone {smallest:.4g} … {largest:.4g}" + (" (U wider)" if exceeded else "")))
            ax.add_patch(Circle((0, 0), nominal / 2.0, fill=False, color="darkgreen", lw=1.2, ls="-.",
                                gid=f"nominal {check} {hole.index}",
                                label=f"nominal {words} Ø {nominal:.4g}"))
        extent = VIEW_RADII * radius
        ax.set_xlim(-extent, extent)
        ax.set_ylim(-extent, extent)
        ax.set_aspect("equal")
        ax.set_xlabel(f"in-plane offset u [{label_unit}]")
        ax.set_ylabel(f"in-plane offset v [{label_unit}]")
        ax.set_title(f"hole {hole.index}{name}: seen along its normal [{label_unit}]")
        _add_scale_bar(ax, 2 * extent, label_unit, f"scale bar {hole.index}")
        # below the view: it covers nothing
        ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.13), ncol=2, fontsize=7, frameon=False)
        ax.grid(True, lw=0.3, alpha=0.5)
        # the edge's radial residuals
        polar = fig.add_subplot(grid[row, 1], projection="polar", gid=f"edge {hole.index}")
        span = 1.5 * rim.limit
        if rim.used.any():
            angle, residual = rim.angle[rim.used], rim.residual[rim.used]
            order = np.argsort(angle)
            polar.plot(angle[order], residual[order], "o-", ms=2.5, lw=0.6, color="tab:blue")
            span = max(1.2 * float(np.percentile(np.abs(residual), 98)), span)
        # the rejected ones at the edge of the plot when they are beyond it (the center: far inside)
        polar.plot(rim.angle[~rim.used], np.clip(rim.residual[~rim.used], -span, span), "x", ms=5, color="crimson")
        polar.set_ylim(-span, span)
        ring = np.linspace(0, 2 * np.pi, 361)
        polar.plot(ring, np.zeros(361), color="red", lw=1)
        for sign in (-1, 1):
            polar.plot(ring, np.full(361, sign * rim.limit), color="0.5", lw=0.6, ls="--")
        polar.set_title(f"edge: nearest surface point − fitted radius [{label_unit}]\n"
                        f"(red: the fitted circle; dashed: ±{RIM_ROBUST_SIGMAS:g} robust σ; x: rejected; "
                        f"angle in the u, v frame)", fontsize=8.5)
        polar.tick_params(labelsize=7)
        # the values
        text = fig.add_subplot(grid[row, 2], gid=f"text {hole.index}")
        text.axis("off")
        verdict = verdict_lines(checked_hole, checked_unit) + zone_notes(checked_hole)
        state = next(line for line in reversed(verdict) if line.startswith("verdict: ")).removeprefix("verdict: ")
        state = state.split(":")[0]
        text.text(0.02, 0.98, hole_text(hole, unit) + "\n" + "\n".join(verdict), transform=text.transAxes,
                  va="top", ha="left", family="monospace", fontsize=8.5,
                  bbox={"boxstyle": "round", "facecolor": _VERDICT_COLOURS.get(state, "#fff8e0"), "edgecolor": "0.5"},
                  gid=f"values {hole.index}")
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
