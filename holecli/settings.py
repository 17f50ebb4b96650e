"""Tunables of the robust method, in one place, grouped by the step of the method that reads them.

Every length is a multiple of a scale measured on the cloud itself (see :mod:`holecli.robust.sampling`), never
an absolute length, so a cloud in metres gives the same result as the same cloud in millimetres.

The scale ladder
----------------
Each rung is a multiple of the one before, so one measured number (h) sets every length:

``h`` (spacing)
    The median nearest-neighbour distance of the surface points.
``g`` (gap)
    The ``sampling_gap_percentile`` (90th) percentile of the empty-circle radii of their local
    Delaunay triangles: 0.71 h on a square grid, about half the line pitch on stripes, 2.8 h on
    random sampling. The sampling's own holes are this size, so everything that tells a hole from
    the sampling is in gaps.
``alpha`` = ``alpha_gaps`` g
    The empty-circle radius above which a Delaunay triangle belongs to a hole (2.5 g).
``cell`` = ``cell_gaps`` g
    The occupancy grid's cell (2 g), in which candidate voids are found.
``margin`` = ``margin_alphas`` alpha + cell
    The width of the material ring triangulated around a hole.

A few tunables are in other scales, named by their suffix or their comment: the period of a regular
pattern (line pitch or grid spacing), a lattice step, a hole's radius (``_radii``), the height noise
(``_sigmas`` of a robust standard deviation), grid cells (``_cells``), points (counts) and degrees.

The groups
----------
Each step's tunables are one small frozen group (:class:`PlaneSettings`, :class:`SamplingSettings`,
:class:`CandidateSettings`, ...), each field with its allowed range beside it (:func:`number`,
:func:`count`), checked when the group is made. :class:`RobustSettings` holds one of each group and
reads every field by its own (flat) name too, ``settings.cell_gaps`` being ``settings.candidates.cell_gaps``:
the names are unique across the groups, and one map (field name -> group) derives the flat names.
Both spellings make one::

    RobustSettings(cell_gaps=3.0)
    RobustSettings(candidates=CandidateSettings(cell_gaps=3.0))

A step is given the settings (the whole object or its group, which answer the same names) and reads
them; where a step is not given any it reads :data:`DEFAULT_SETTINGS`. No module keeps a copy of a
field's value.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields, replace
from operator import attrgetter

__all__ = [
    "AcceptanceSettings", "BiasSettings", "CandidateSettings", "CountersinkSettings", "CurvedSettings",
    "DEFAULT_SETTINGS", "DoubtSettings", "EmptyCircleSettings", "FringeSettings", "GROUPS", "GROUP_OF",
    "LatticeSettings", "PlaneSettings", "PositiveTuple", "Range", "RimSettings", "RobustSettings", "RunSettings",
    "SamplingSettings", "ShapeSettings", "count", "number",
]

_INF = math.inf


# --- Ranges, beside each field --------------------------------------------------------------------


@dataclass(frozen=True)
class Range:
    """The values a tunable admits.

    Numbers (``integer`` False) lie strictly inside (low, high), or at ``high`` too when ``closed``;
    a ``low`` of -inf admits -inf itself (it turns a check off). Counts (``integer`` True) are integers
    in [low, high]. ``bool`` is neither.
    """

    low: float
    high: float
    integer: bool = False
    closed: bool = False

    def admits(self, value) -> bool:
        if isinstance(value, bool):
            return False
        if self.integer:
            return isinstance(value, int) and self.low <= value <= self.high
        return (isinstance(value, (int, float))
                and (self.low < value < self.high or value == self.low == -_INF
                     or (self.closed and value == self.high)))

    def __str__(self):
        if self.integer:
            return f"an integer in [{self.low}, {self.high}]"
        return f"a number in ({self.low}, {self.high}{']' if self.closed else ')'}"


@dataclass(frozen=True)
class PositiveTuple:
    """A non-empty tuple of finite positive numbers (the offsets of the synthetic holes)."""

    def admits(self, value) -> bool:
        return (isinstance(value, tuple) and bool(value)
                and all(isinstance(k, (int, float)) and not isinstance(k, bool) and 0 < k < _INF for k in value))

    def __str__(self):
        return "a non-empty tuple of positive numbers"


def number(default, low, high, *, closed=False):
    """A real-valued tunable: a dataclass field whose metadata ``"range"`` is its :class:`Range`."""
    return field(default=default, metadata={"range": Range(low, high, closed=closed)})


def count(default, low, high):
    """An integer tunable in [low, high] (points, rounds, cells, threads)."""
    return field(default=default, metadata={"range": Range(low, high, integer=True)})


class _Group:
    """A group of tunables: each field checked against its range when the group is made."""

    def __post_init__(self):
        for item in fields(self):
            value = getattr(self, item.name)
            allowed = item.metadata["range"]
            if not allowed.admits(value):
                raise ValueError(f"RobustSettings.{item.name} must be {allowed}, got {value!r}")


# --- The groups, in the order of the method's steps -----------------------------------------------


@dataclass(frozen=True)
class PlaneSettings(_Group):
    """The plane of the dominant surface (:func:`holecli.geometry.plane.fit_plane_robust`)."""

    # RANSAC hypotheses scored by the 30 % quantile of |residual| (scale-free), then refined by SVD on
    # the points within `plane_clip` robust standard deviations.
    ransac_sample: int = count(1000, 3, 10 ** 9)
    ransac_hypotheses: int = count(64, 1, 10 ** 6)
    ransac_quantile: float = number(0.3, 0.0, 1.0)
    plane_clip: float = number(4.0, 0.0, _INF)
    # At most this many least-squares refits of the plane on its inliers (each refit re-selects the
    # points within plane_clip robust sd); in practice the inlier set settles in a few rounds, the
    # bound only stops an oscillation at the band's edge.
    plane_refine_rounds: int = count(20, 1, 10 ** 6)
    # The refits run on a random subsample of this many points (points), the final inlier set on all
    # of them: a million points need not be refitted twenty times, and 50 000 pin a plane far below
    # any noise.
    plane_refine_sample: int = count(50_000, 3, 10 ** 12)
    # At most this many planar faces are peeled off the RANSAC sample, largest wins (counts): the
    # top, a countersink or bore wall and a floor are the faces a hole scan holds.
    plane_max_faces: int = count(3, 1, 100)
    # A view direction (--view-dir) must make at least this sine of an angle with the plane
    # (dimensionless; 0.05 is 2.9 degrees): a sensor looking along the plane cannot have seen it, so
    # the plane found is not the surface scanned (a wall, a side).
    view_min_sine: float = number(0.05, 0.0, 1.0)


@dataclass(frozen=True)
class SamplingSettings(_Group):
    """Sampling statistics (:func:`holecli.robust.sampling.estimate_sampling`), in spacings h."""

    # Sampling statistics from a few local windows of about this many points each.
    sampling_windows: int = count(3, 1, 1000)
    sampling_window_points: int = count(600, 10, 10 ** 9)
    # g is this percentile of the empty-circle radii (the scale ladder's definition of g): high
    # enough to be the size of the sampling's own largest gaps, low enough that a hole in a window
    # does not move it.
    sampling_gap_percentile: float = number(90.0, 0.0, 100.0)
    # Only triangles whose circumcenter lies within this fraction of the window's extent from its
    # mean count for g (fraction of the window): the hull's slivers at the window's border are not
    # gaps of the sampling.
    sampling_inner_fraction: float = number(0.6, 0.0, _INF)
    # Scan lines: the mean of the nearest-neighbour directions (doubled angles, 1 when all point one
    # way, 0 when spread evenly) must exceed this (dimensionless): stripes give ~1, a square grid ~0.
    sampling_line_coherence: float = number(0.6, 0.0, 1.0)
    # ... and the lines' pitch must exceed this many spacings, else the points are not on separate
    # lines (a pitch of one spacing is a grid).
    sampling_min_pitch_spacings: float = number(1.3, 0.0, _INF)
    # A square grid: the quadrupled angles' mean must exceed this (dimensionless), as for lines.
    sampling_lattice_coherence: float = number(0.6, 0.0, 1.0)
    # The line pitch is read from each point's nearest neighbour on another line among this many
    # nearest neighbours (points): enough to reach the next line on stripes of pitch up to ~4 h.
    sampling_pitch_neighbours: int = count(16, 1, 10 ** 6)
    # The windows sit this many standard deviations of the coordinates off their mean, per axis
    # (in sd of the point coordinates): on a uniformly covered patch mean -+ 0.7 sd are about its 30th
    # and 70th percentiles, inside the scan yet off its middle, where a scan's hole often is.
    sampling_window_offset_sd: float = number(0.7, 0.0, _INF)


@dataclass(frozen=True)
class CandidateSettings(_Group):
    """The occupancy grid and its candidate voids (:mod:`holecli.robust.candidates`), in gaps g."""

    # Occupancy grid cell, in gaps: large enough that material never leaves a chain of empty cells.
    cell_gaps: float = number(2.0, 0.0, _INF)
    # A Delaunay triangle whose empty circumcircle is larger than this (in gaps) is a hole triangle.
    alpha_gaps: float = number(2.5, 0.0, _INF)
    # Width of the material ring triangulated around a hole, beyond the hole's void, in alphas (plus
    # one cell): rim points lie within an alpha of the edge, the outer 2 alphas are the cut zone.
    margin_alphas: float = number(3.0, 0.0, _INF)
    # Clusters of occupied cells of at most this many cells that the 3 x 3 opening removes and that
    # touch no material are specks (reflections inside a hole), not material: a boss or debris
    # larger than this stays, and the void around it becomes a ring (in cells).
    max_speck_cells: int = count(8, 0, 10 ** 9)
    # Default smallest reported diameter, in gaps (natural gaps of random sampling reach ~4 g).
    min_diameter_gaps: float = number(6.0, 0.0, _INF)


@dataclass(frozen=True)
class RimSettings(_Group):
    """The rim of a hole and its circle fit (:mod:`holecli.robust.edge`)."""

    # Material ends at the hole's edge: a rim point deeper than this (in gaps) inside the hole than the
    # outermost rim point of its direction, or a point this deep inside the first fitted circle, is
    # a reflection inside the hole that joined the material, and is dropped before the rim is
    # extracted and fitted again (an alpha, 2.5 gaps, let 100 reflections in a 3 mm hole pull its
    # diameter in by up to 1.5 h; 0.75 gaps drops true rim points of noisy and random scans).
    envelope_gaps: float = number(1.0, 0.0, _INF)
    # Rim circle fit: sigma clipping threshold, and a floor of the residual scale (in spacings).
    clip_sigmas: float = number(4.0, 0.0, _INF)
    clip_floor_spacings: float = number(0.05, 0.0, _INF)
    # Fewest rim points for a full hole, and for a partial hole or any hole found in a bay of the
    # scan's border (where the dents of a ragged border must not pass for holes).
    min_rim_points: int = count(6, 3, 10 ** 9)
    min_partial_rim_points: int = count(12, 3, 10 ** 9)


@dataclass(frozen=True)
class AcceptanceSettings(_Group):
    """What a candidate must show to be a hole (the refusals of :mod:`holecli.robust.acceptance`)."""

    # A fitted circle is no hole when the inner half of it holds more than this fraction of the surface
    # points that area would hold at the scan's density: a groove around a standing island (an O-ring
    # groove, a C-shaped slot), whose outer rim is a good circle (check "material_inside"). A hole's
    # inner half holds at most a few reflections; 0.7 let a 0.8 mm island through.
    max_material_inside: float = number(0.5, 0.0, 1.0)
    # The points more than an envelope inside the first circle fitted to a rim are dropped as
    # reflections before the refit; those on material cells of the occupancy grid (specks are not)
    # may be at most this fraction of the points the disk holds, else the circle spanned a cut-out's
    # own sides (check "material_in_first_circle"). Holes on the validation scans drop <= 1 %.
    max_material_dropped: float = number(0.05, 0.0, 1.0, closed=True)
    # A blind hole whose flat floor lies less than this many diameters deep is a pocket (a spot face, a
    # milled recess), not a drilled hole (check "pocket"): a 118-degree drill's point alone is 0.30
    # diameters long, so no drill leaves a floor that shallow.
    pocket_max_depth_ratio: float = number(0.15, 0.0, _INF)
    # A void whose rim is this far from a circle (robust sd of residuals / radius) is not a hole.
    max_relative_scatter: float = number(0.06, 0.0, _INF)
    # A partial hole must keep at least this much of its rim.
    min_partial_arc_deg: float = number(120.0, 0.0, 360.0, closed=True)
    # A hole whose circle has scanned material around less than this many degrees is partial.
    full_arc_deg: float = number(350.0, 0.0, 360.0, closed=True)
    # A void is a boss (not a hole) when this fraction of its expected surface points stand above it.
    boss_fraction: float = number(0.25, 0.0, 1.0, closed=True)


@dataclass(frozen=True)
class BiasSettings(_Group):
    """The sampling-bias correction and its synthetic holes (:mod:`holecli.robust.estimators.rim_fit`)."""

    # Sampling-bias correction: synthetic holes cut at r + k * period for these k (the pattern's
    # period: line pitch or grid spacing; half an alpha on irregular sampling), in this many passes.
    # The largest empty circle's overshoot is measured on synthetic holes at r + k * gap, same k.
    bias_offsets: tuple = field(default=(1, 2, 3, 4), metadata={"range": PositiveTuple()})
    bias_passes: int = count(2, 1, 100)
    # As many of those synthetic holes as give about this many rim points in all.
    bias_rim_points: int = count(400, 1, 10 ** 9)
    # The last pass of the bias correction measures at least this many synthetic holes (of the
    # bias_offsets), so that the spread of their errors gives the hole's uncertainty
    # (holecli.robust.uncertainty); the lattice's separating circle and the empty circle measure
    # that many too.
    uncertainty_min_synthetic: int = count(4, 1, 10 ** 9)
    # Points within this many alphas of the outer line of the triangulated ring are cut-zone
    # material (the cut, not a hole, leaves empty triangles there): an alpha disk's diameter.
    cut_alphas: float = number(2.0, 0.0, _INF)
    # A synthetic hole's ring is first triangulated with a cut zone this many alphas wide instead of
    # cut_alphas (its outer line that much nearer, its cut zone's inner line where it was): a triangle
    # that the points left out could change has an empty circle reaching past the nearer outer line,
    # and to touch the hole it would span 2 alphas of material. Where the material does not surround
    # the hole (its rim then comes out open or not at all) the full ring is triangulated.
    synthetic_cut_alphas: float = number(1.0, 0.0, _INF)
    # Fewest rim points of a synthetic hole that is fitted (points).
    bias_min_rim_points: int = count(5, 3, 10 ** 9)
    # A synthetic hole whose fitted radius is off its known one by this many alphas or more failed
    # (the rim ran off into another void), and is left out of the mean.
    bias_max_excess_alphas: float = number(1.0, 0.0, _INF)


@dataclass(frozen=True)
class LatticeSettings(_Group):
    """The lattice brackets of a regular scan (:mod:`holecli.robust.estimators.lattice`), in lattice steps."""

    # A neighbour one step along an axis is present within this fraction of the step: far above the
    # in-plane noise of a quiet regular scan, far below half a step.
    lattice_present_steps: float = number(0.15, 0.0, 1.0)
    # A lattice position is missing when no point lies within this fraction of the step (half a
    # step: the point would be nearer the next position).
    lattice_missing_steps: float = number(0.5, 0.0, 1.0)
    # An axis has a regular step only where at least this fraction of the points have their
    # neighbour one step along it (fraction of the points).
    lattice_min_present_fraction: float = number(0.5, 0.0, 1.0, closed=True)
    # Fewest brackets (points) for the separating circle: three define a circle, eight around it
    # constrain all three parameters with a margin.
    lattice_min_brackets: int = count(8, 3, 10 ** 9)
    # ... and no angular gap between brackets larger than this (degrees): a quarter of the circle
    # without a bracket leaves the circle free to slide that way.
    lattice_max_gap_deg: float = number(90.0, 0.0, 360.0, closed=True)
    # Other material points within this many steps outside the circle must lie outside it too.
    lattice_others_steps: float = number(2.0, 0.0, _INF)


@dataclass(frozen=True)
class EmptyCircleSettings(_Group):
    """When the edge is the largest empty circle (:mod:`holecli.robust.estimators.empty_circle`)."""

    # On irregular sampling (random points, a cloud sampled from a CAD mesh) the edge is the largest empty
    # circle of the surface points when their height noise is at most this fraction of the mean point
    # distance (1 / sqrt(density)): the in-plane scatter that comes with noise carries points into the
    # hole. On random sampling at 0.25 of it the empty circle came out 0.17 h small (the rim fit
    # 0.08 h); at 0.085 the empty circle is the better (sd 0.045 h against the fit's 0.12 h).
    empty_circle_max_noise: float = number(0.15, 0.0, _INF)


@dataclass(frozen=True)
class CountersinkSettings(_Group):
    """The countersink cone at a hole's edge (:func:`holecli.robust.estimators.cone.fit_cone_edge`)."""

    # A cone's wall slopes between these (depth per unit radius: 0.2 is 11 degrees from the surface,
    # 3.0 is 72; a 100-degree countersink slopes 0.84, a 60-degree one 1.73); a steeper "cone" is a
    # bore wall, a flatter one is noise.
    cone_min_slope: float = number(0.2, 0.0, _INF)
    cone_max_slope: float = number(3.0, 0.0, _INF)
    # The cone must hold this many points clearly below the surface inside the rim (points).
    cone_min_points_below: int = count(12, 1, 10 ** 9)
    # "Clearly below the surface": deeper than this many robust sd of the surface heights (height
    # noise): three sigma keeps the surface's own noise out.
    cone_below_sigmas: float = number(3.0, 0.0, _INF)
    # The window of the edge search reaches this many window widths inside the rim's radius (one
    # width outside it): the cone's points lie inside the edge.
    cone_inner_widths: float = number(2.0, 0.0, _INF)
    # The hinge fit trims points farther than this many robust sd of its residuals (bore-wall and
    # floor points far below the cone), at most cone_trim_rounds times.
    cone_trim_sigmas: float = number(3.0, 0.0, _INF)
    cone_trim_rounds: int = count(3, 1, 1000)
    # The edge is searched on this many radii across the window, then as many again around the best
    # (counts): the second pass resolves 1/64^2 of the window.
    cone_edge_steps: int = count(64, 2, 10 ** 6)
    # The flat-floor check cuts the points below the surface inside the edge into this many radial
    # bins, each kept with at least this many points (counts).
    cone_depth_bins: int = count(8, 2, 10 ** 6)
    cone_min_bin_points: int = count(3, 1, 10 ** 9)
    # A countersink cone's points below the surface must deepen toward the center at least at this
    # fraction of the cone's fitted slope (depth per radius): the flat floor of a blind hole, at one
    # depth all across the inside, is not a cone (check "flat_floor" of holecli.robust.estimators.cone).
    # Below 1: a cone's points must deepen at some fraction of its slope; -inf turns the check off.
    cone_depth_slope_ratio: float = number(0.3, -_INF, 1.0)
    # A cone must be resolved by the scan: its points clearly below the surface must reach this many
    # gaps g inside its edge (5th percentile of their radii). The hinge has two unknowns, the edge and
    # the slope; points within one row of samples of the edge fix only their product's depth there.
    # That is where an edge's mixed pixels lie (a laser line's width, a spot straddling the rim: one
    # sample footprint, under a gap), and a hinge through them reads any plain hole as countersunk.
    # Twice that fringe; real countersinks span 9 gaps and more, a 40 um line's fringe 0.4.
    cone_min_span_gaps: float = number(2.0, 0.0, _INF)
    # A countersink's edge found within this fraction of its search window's outer limit is at the
    # limit, and the window moves out to it, at most this many times (on a wide scan of a curved
    # panel the band hides the top of the cone; it rarely hides more than one window).
    cone_window_limit: float = number(0.02, 0.0, 1.0)
    cone_window_moves: int = count(3, 0, 100)


@dataclass(frozen=True)
class FringeSettings(_Group):
    """The fringe of mixed points at a plain hole's edge (``holecli.robust.measure._edge_fringe``)."""

    # Points off the surface band within edge_fringe_gaps gaps of the edge, and no deeper than
    # edge_fringe_depth times that reach, are mixed samples of the edge (a footprint across the rim);
    # their area over the edge's length is the fringe's width, which enters the diameter's u.
    edge_fringe_gaps: float = number(1.0, 0.0, _INF)
    edge_fringe_depth: float = number(3.0, 0.0, _INF)


@dataclass(frozen=True)
class ShapeSettings(_Group):
    """The whole hole below its edge (:mod:`holecli.robust.hole_shape`)."""

    # A point is below the surface when it lies more than shape_below_sigmas surface-noise sigmas
    # under it (the noise of the surface ring around the hole); the points are gathered within
    # shape_search_radii edge radii of the axis and shape_depth_radii edge radii deep.
    shape_below_sigmas: float = number(4.0, 0.0, _INF)
    shape_search_radii: float = number(1.3, 1.0, _INF)
    shape_depth_radii: float = number(4.0, 0.0, _INF)
    # A cone, wall or floor is measured from at least shape_min_points points spread over at least
    # shape_min_arc_deg of its circumference (a cylinder's diameter needs 90 degrees of its wall).
    shape_min_points: int = count(30, 7, 10 ** 9)
    shape_min_arc_deg: float = number(90.0, 0.0, 360.0, closed=True)
    # A bore wall seen over less than shape_axis_min_span of its radius along the axis gives no axis:
    # its cylinder is fitted parallel to the axis from the cone, the floor or the surface normal.
    shape_axis_min_span: float = number(0.5, 0.0, _INF)
    # A free bore axis more than shape_max_axis_change_deg off the axis known before it (cone, floor,
    # normal) is not trusted (the wall is then fitted along the known axis).
    shape_max_axis_change_deg: float = number(15.0, 0.0, 180.0)
    # A cone or cylinder fit leaving an rms above shape_max_rms_sigmas surface-noise sigmas (and above
    # shape_max_rms_radii of its radius) is no such surface: its values are null.
    shape_max_rms_sigmas: float = number(5.0, 0.0, _INF)
    shape_max_rms_radii: float = number(0.005, 0.0, _INF)
    # Trimming of the cone, cylinder and floor fits: points beyond shape_trim_sigmas robust sigmas.
    shape_trim_sigmas: float = number(3.0, 0.0, _INF)
    # A flat floor: at least shape_floor_fraction of the points below the surface inside the edge lie
    # in one plane; it is a blind hole's floor when its points reach within shape_floor_center_radii
    # edge radii of the axis (else a counterbore's step, around the bore).
    shape_floor_fraction: float = number(0.2, 0.0, 1.0, closed=True)
    shape_floor_center_radii: float = number(0.3, 0.0, 1.0)
    # A floor spreads over at least shape_floor_min_width edge radii from the axis outward (a ring of
    # wall points at one depth, one row of a scan, is planar too, and has no width).
    shape_floor_min_width: float = number(0.15, 0.0, _INF)
    # The floor's plane is the best of shape_floor_hypotheses planes through three points below,
    # among those leaning at most shape_floor_max_tilt_deg off the surface normal.
    shape_floor_hypotheses: int = count(128, 1, 10 ** 6)
    shape_floor_max_tilt_deg: float = number(20.0, 0.0, 90.0)
    # A fitted countersink's included angle must lie in this range (degrees) to be reported.
    shape_min_angle_deg: float = number(30.0, 0.0, 180.0)
    shape_max_angle_deg: float = number(150.0, 0.0, 180.0)


@dataclass(frozen=True)
class DoubtSettings(_Group):
    """Warnings of a doubtful result (:mod:`holecli.robust.doubts`).

    Calibrated with benchmarks/doubts.py on the clean scenes of benchmarks/realistic.py (4 seeds per
    class, 32 holes) and the clouds of sample_clouds/: the clean value quoted for each is the extreme
    seen there.
    """

    # few_rim_points: fewer rim points than this (points): five points a side of a square around the
    # circle; the clean holes have 44 or more (33 on a partial hole), a 0.9 mm hole on a 0.15 mm grid 9.
    doubt_min_rim_points: int = count(20, 0, 10 ** 9)
    # rim_gap: the largest angular gap between the rim points above this (degrees): clean full holes
    # leave at most 20 (random sampling), an eighth of the circle lost is occlusion or missing data.
    doubt_max_rim_gap_deg: float = number(45.0, 0.0, 360.0, closed=True)
    # points_inside: more surface-band points deeper than two gaps inside the fitted circle than this
    # fraction of what that disk would hold at the scan's density, and more than doubt_min_inside_points
    # (points): no clean hole has any; 20 reflections in the Table I hole (3 % of its disk) are found.
    doubt_max_inside_fraction: float = number(0.02, 0.0, _INF)
    doubt_min_inside_points: int = count(5, 0, 10 ** 9)
    # surface_not_flat: the rms of the surface ring [r, 3r] about its local plane (quadric on a curved
    # surface) above this many of the scan's height-noise sigmas plus doubt_surface_floor_spacings
    # spacings (the floor for a noise-free scan, whose sigma is round-off): clean rings reach 1.35 sigmas.
    # Only the surface band's points are in the ring (material beyond 4 sigmas is not surface), so a
    # ring cannot reach much above 3: 2 is the highest limit that still fires.
    doubt_surface_sigmas: float = number(2.0, 0.0, _INF)
    doubt_surface_floor_spacings: float = number(0.01, 0.0, _INF)
    # near_border: partial, or the circle nearer the scan's outside than this many radii: the ring
    # just outside the edge is where the rim, the bias correction and the local plane are read. The
    # clean full holes keep 0.77 radii or more (2 in the realistic scenes).
    doubt_border_radii: float = number(0.5, 0.0, _INF)
    # large_bias_correction: the diameter's sampling-bias correction above this many spacings, or
    # above this fraction of the diameter (either): clean corrections reach 0.9 h on grids, 1.7 h on
    # random sampling, 2.45 h on stripes (the spacing is along the lines), and 4 % of the diameter.
    doubt_max_bias_spacings: float = number(3.0, 0.0, _INF)
    doubt_max_bias_diameter: float = number(0.06, 0.0, _INF)
    # high_fit_rms: the rim fit's rms above this many gaps g: the sampling alone leaves 0.21-0.41 g on
    # the clean scenes; lateral noise of 0.3 h on the Table I grid gives about 0.7.
    doubt_max_fit_rms_gaps: float = number(0.6, 0.0, _INF)
    # A fringe of mixed points at the edge mostly hidden in the surface band (its share off the band
    # this wide, in gaps): where the edge lies in it is not measured (blurred_edge).
    doubt_max_hidden_fringe_gaps: float = number(0.01, 0.0, _INF)
    # edge_bore_mismatch: a plain through hole's edge and bore wall disagree by more than this many
    # combined standard uncertainties (the validation suite's 17 such holes: at most 3.9).
    doubt_edge_bore_sigmas: float = number(6.0, 0.0, _INF)


@dataclass(frozen=True)
class CurvedSettings(_Group):
    """Holes on a curved surface (a panel): the quadric and the flattened crop around each hole."""

    # The surface at a hole follows a quadric instead of a plane when the quadric's sag at the hole's
    # center exceeds this many of its standard errors (a curved panel; on a flat one the quadric is
    # only noisier).
    curvature_sigmas: float = number(3.0, 0.0, _INF)
    # On such a surface each hole is measured again on its neighbourhood within this many radii,
    # flattened by the quadric of the surface points in the ring from 1 to crop_ring_radii radii.
    crop_radii: float = number(4.0, 1.0, _INF)
    crop_ring_radii: float = number(3.5, 1.0, _INF)


@dataclass(frozen=True)
class RunSettings(_Group):
    """How the work is run (threads, indexes): no effect on the figures."""

    # With at least this many candidate holes the neighbourhood queries go through a cell index of the
    # points (one sort, 12 bytes a point) instead of a pass over all of them each (random sampling's
    # natural gaps grow with the points: quadratic work without it).
    cell_index_from_candidates: int = count(16, 1, 10 ** 12)
    # Holes are measured in this many threads when the cloud has at least this many points.
    threads: int = count(2, 1, 1024)
    threads_from_points: int = count(200_000, 0, 10 ** 12)


# --- All of them ------------------------------------------------------------------------------------

#: (attribute of RobustSettings, group type), in the order of the method's steps.
GROUPS = (
    ("plane", PlaneSettings), ("sampling", SamplingSettings), ("candidates", CandidateSettings),
    ("rim", RimSettings), ("acceptance", AcceptanceSettings), ("bias", BiasSettings),
    ("lattice", LatticeSettings), ("empty_circle", EmptyCircleSettings), ("countersink", CountersinkSettings),
    ("fringe", FringeSettings), ("shape", ShapeSettings), ("doubts", DoubtSettings), ("curved", CurvedSettings),
    ("run", RunSettings),
)

#: The one name map: each tunable's (flat) name -> the attribute of the group that holds it.
GROUP_OF = {item.name: group for group, kind in GROUPS for item in fields(kind)}


@dataclass(frozen=True, init=False)
class RobustSettings:
    """Every tunable of the robust method: one group per step, each field also read by its own name.

    Made from groups, flat field names, or both (a flat name overrides that field of a group given
    with it, which is what :func:`dataclasses.replace` does)::

        RobustSettings(cell_gaps=3.0)
        RobustSettings(candidates=CandidateSettings(cell_gaps=3.0), threads=1)

    Raises
    ------
    ValueError
        A field out of its range, naming the field and the range (``RobustSettings.cell_gaps must
        be a number in (0.0, inf), got -1.0``).
    TypeError
        An unknown name, or a group of the wrong type.
    """

    plane: PlaneSettings
    sampling: SamplingSettings
    candidates: CandidateSettings
    rim: RimSettings
    acceptance: AcceptanceSettings
    bias: BiasSettings
    lattice: LatticeSettings
    empty_circle: EmptyCircleSettings
    countersink: CountersinkSettings
    fringe: FringeSettings
    shape: ShapeSettings
    doubts: DoubtSettings
    curved: CurvedSettings
    run: RunSettings

    def __init__(self, **values):
        changes = {}
        for name, value in values.items():
            if name not in GROUP_OF and name not in _GROUP_TYPES:
                raise TypeError(f"RobustSettings got an unexpected keyword argument {name!r}")
            if name in GROUP_OF:
                changes.setdefault(GROUP_OF[name], {})[name] = value
        for group, kind in GROUPS:
            given = values.get(group)
            if given is None:
                given = kind()
            elif type(given) is not kind:
                raise TypeError(f"RobustSettings.{group} must be a {kind.__name__}, got {type(given).__name__}")
            if group in changes:
                given = replace(given, **changes[group])
            object.__setattr__(self, group, given)

    def flat_items(self):
        """Every tunable as (name, value), group by group in the order of :data:`GROUPS`."""
        return tuple((name, getattr(getattr(self, group), name)) for name, group in GROUP_OF.items())

    @classmethod
    def flat_fields(cls):
        """Every tunable's dataclass field (``name``, ``default``, ``metadata["range"]``), in that order."""
        return tuple(item for _, kind in GROUPS for item in fields(kind))


_GROUP_TYPES = dict(GROUPS)


def _flat_attributes():
    """Each field of a group readable on RobustSettings by its own name (derived from GROUP_OF)."""
    for name, group in GROUP_OF.items():
        if hasattr(RobustSettings, name):
            raise RuntimeError(f"RobustSettings: the field name {name!r} is taken")
        setattr(RobustSettings, name, property(attrgetter(f"{group}.{name}"), doc=f"``{group}.{name}``"))


_flat_attributes()

DEFAULT_SETTINGS = RobustSettings()
