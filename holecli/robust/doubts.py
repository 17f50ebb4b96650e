"""What makes a measured hole doubtful: warnings from numbers the robust method already knows.

The method (:mod:`holecli.robust.assemble`) gathers the numbers of one hole into a :class:`Doubts`;
:func:`doubt_warnings` compares them with their thresholds (``doubt_*`` fields of
:class:`holecli.settings.RobustSettings`, each with why its value) and returns the warnings, each a
short stable code (:data:`holecli.vocabulary.DOUBT_CODES`) and a sentence with the numbers. Pure: no
points, no scene.

These warnings do not make a value null: the hole is measured, but its result deserves a look. The
other warnings, :data:`holecli.vocabulary.WARNING_CODES`, say that the points below the edge
contradict the hole's type; the reasons a value is null are notes, not warnings
(:data:`holecli.vocabulary.NOTE_CODES`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional

from holecli.results import HoleWarning
from holecli.settings import DEFAULT_SETTINGS
from holecli.vocabulary import DOUBT_CODES

@dataclass(frozen=True)
class Doubts:
    """The numbers of one hole that its warnings are judged on (lengths in the scan's unit).

    Attributes
    ----------
    rim_points : int
        Rim points the circle was fitted to.
    rim_gap_deg : float
        Largest angular gap between those rim points, seen from the center (degrees).
    inside_points : int
        Surface-band points within the fitted circle, deeper than the margin below its edge.
    inside_expected : float
        The surface points that disk would hold at the scan's density.
    surface_rms : float or None
        Rms residual of the surface around the hole to its local plane (or quadric, on a curved
        surface); None when the ring holds too few points.
    height_noise : float
        The scan's robust sd of the surface heights.
    arc_deg : float
        Degrees of the circle with scanned material just outside it.
    border_gap : float
        Distance from the circle to the scan's outside (0 when the hole is open to it).
    radius : float
        The hole's radius.
    bias_correction : float or None
        The diameter's sampling-bias correction; None when the edge is a countersink's (no sampling
        correction).
    spacing : float
        The point spacing h.
    fit_rms : float
        Rms radial residual of the rim fit.
    gap : float
        The gap scale g.
    hidden_fringe : float
        Mean radial width of the fringe of mixed points seen off the surface band at the edge when the
        band hides most of it (``holecli.robust.measure._edge_fringe``); 0 otherwise.
    bias_measured : bool
        False when the diameter's sampling-bias correction was wanted and could not be measured.
    facing_conflict : bool
        The data say the sensor saw the other side of the surface than ``--view-dir``
        (:class:`holecli.robust.facing.Facing`).
    """

    rim_points: int
    rim_gap_deg: float
    inside_points: int
    inside_expected: float
    surface_rms: Optional[float]
    height_noise: float
    arc_deg: float
    border_gap: float
    radius: float
    bias_correction: Optional[float]
    spacing: float
    fit_rms: float
    gap: float
    hidden_fringe: float = 0.0
    bias_measured: bool = True
    facing_conflict: bool = False


def _warning(code, detail):
    return HoleWarning(code=code, message=f"{DOUBT_CODES[code]} ({detail})")


def doubt_warnings(doubts, settings=DEFAULT_SETTINGS):
    """The warnings of one hole, in the order of :data:`DOUBT_CODES`.

    Parameters
    ----------
    doubts : Doubts
    settings : holecli.settings.RobustSettings
        Its ``doubt_*`` thresholds.

    Returns
    -------
    tuple of HoleWarning
    """
    d, s = doubts, settings
    out = []
    if d.rim_points < s.doubt_min_rim_points:
        out.append(_warning("few_rim_points", f"{d.rim_points} < {s.doubt_min_rim_points}"))
    if d.rim_gap_deg > s.doubt_max_rim_gap_deg:
        out.append(_warning("rim_gap", f"largest gap {d.rim_gap_deg:.0f} > {s.doubt_max_rim_gap_deg:g} degrees"))
    allowed_inside = max(s.doubt_max_inside_fraction * d.inside_expected, float(s.doubt_min_inside_points))
    if d.inside_points > allowed_inside:
        out.append(_warning("points_inside", f"{d.inside_points} points > {allowed_inside:.0f} "
                            f"({s.doubt_max_inside_fraction:g} of the {d.inside_expected:.0f} the disk would hold)"))
    if d.surface_rms is not None:
        limit = s.doubt_surface_sigmas * d.height_noise + s.doubt_surface_floor_spacings * d.spacing
        if d.surface_rms > limit:
            out.append(_warning("surface_not_flat", f"rms {d.surface_rms:.3g} > {limit:.3g}: "
                                                    f"{s.doubt_surface_sigmas:g} noise sigmas of {d.height_noise:.3g}"))
    border_limit = s.doubt_border_radii * d.radius
    if d.arc_deg < 360.0:
        out.append(_warning("near_border", f"material around {d.arc_deg:.0f} of 360 degrees"))
    elif d.border_gap < border_limit:
        out.append(_warning("near_border", f"{d.border_gap:.4g} from the scan's edge < "
                                           f"{s.doubt_border_radii:g} radii = {border_limit:.4g}"))
    if d.bias_correction is not None:
        limit = min(s.doubt_max_bias_spacings * d.spacing, s.doubt_max_bias_diameter * 2.0 * d.radius)
        if abs(d.bias_correction) > limit:
            out.append(_warning("large_bias_correction",
                                f"{d.bias_correction:.4g} > {limit:.4g}: {s.doubt_max_bias_spacings:g} spacings "
                                f"or {s.doubt_max_bias_diameter:g} of the diameter"))
    limit = s.doubt_max_fit_rms_gaps * d.gap
    if d.fit_rms > limit:
        out.append(_warning("high_fit_rms", f"rms {d.fit_rms:.3g} > {limit:.3g} = "
                                            f"{s.doubt_max_fit_rms_gaps:g} gaps"))
    limit = s.doubt_max_hidden_fringe_gaps * d.gap
    if d.hidden_fringe > limit:
        out.append(_warning("blurred_edge", f"{d.hidden_fringe:.3g} of mixed points seen off the band > {limit:.3g} = "
                                            f"{s.doubt_max_hidden_fringe_gaps:g} gaps"))
    if not d.bias_measured:
        out.append(_warning("bias_not_measured", f"the rim fit's diameter {2.0 * d.radius:.6g}"))
    if d.facing_conflict:
        out.append(_warning("view_dir_contradicted", "the heights are read toward the sensor --view-dir gives"))
    return tuple(out)


def edge_bore_warning(edge_diameter, u_edge, bore_diameter, u_bore, settings=DEFAULT_SETTINGS):
    """The ``edge_bore_mismatch`` warning of a plain through hole, or None.

    A through hole's edge is where its bore wall meets the surface: the two diameters agree unless the
    edge is broken (a chamfer or a burr too small for a countersink's cone) or the surface's sampling
    stops short of it. They disagree when they differ by more than ``doubt_edge_bore_sigmas`` times
    their combined standard uncertainty.

    Parameters
    ----------
    edge_diameter, u_edge : float
        The hole's diameter and its standard uncertainty.
    bore_diameter, u_bore : float
        The bore wall's cylinder diameter and its standard uncertainty.
    settings : holecli.settings.RobustSettings

    Returns
    -------
    HoleWarning or None
    """
    combined = math.hypot(float(u_edge), float(u_bore))
    difference = float(edge_diameter) - float(bore_diameter)
    limit = settings.doubt_edge_bore_sigmas * combined
    if not abs(difference) > limit:
        return None
    return _warning("edge_bore_mismatch", f"edge {edge_diameter:.6g}, bore {bore_diameter:.6g}: {difference:+.4g}, "
                                          f"{abs(difference) / combined:.0f} times their combined u {combined:.3g} "
                                          f"> {settings.doubt_edge_bore_sigmas:g}")
