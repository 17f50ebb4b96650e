"""Tunables of the robust method, in one place.

Every length is a multiple of a scale measured on the cloud itself (see :mod:`holecli.robust.sampling`), never
an absolute length, so a cloud in metres gives the same result as the same cloud in millimetres:
``spacing`` (h) is the median nearest-neighbour distance of the surface points and ``gap`` (g) the
90th percentile of the empty-circle radii of their local Delaunay triangles (0.71 h on a square grid,
about half the line pitch on stripes, 2.8 h on random sampling).
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class RobustSettings:
    # Plane: RANSAC hypotheses scored by the 30 % quantile of |residual| (scale-free), then refined
    # by SVD on the points within `plane_clip` robust standard deviations.
    ransac_sample: int = 1000
    ransac_hypotheses: int = 64
    ransac_quantile: float = 0.3
    plane_clip: float = 4.0
    # Sampling statistics from a few local windows of about this many points each.
    sampling_windows: int = 3
    sampling_window_points: int = 600
    # Occupancy grid cell, in gaps: large enough that material never leaves a chain of empty cells.
    cell_gaps: float = 2.0
    # A Delaunay triangle whose empty circumcircle is larger than this (in gaps) is a hole triangle.
    alpha_gaps: float = 2.5
    # Width of the material ring triangulated around a hole, beyond the hole's void, in alphas (plus
    # one cell): rim points lie within an alpha of the edge, the outer 2 alphas are the cut zone.
    margin_alphas: float = 3.0
    # Material ends at the hole's edge: a rim point deeper than this (in gaps) inside the hole than the
    # outermost rim point of its direction, or a point this deep inside the first fitted circle, is
    # a reflection inside the hole that joined the material, and is dropped before the rim is
    # extracted and fitted again (an alpha, 2.5 gaps, let 100 reflections in a 3 mm hole pull its
    # diameter in by up to 1.5 h; 0.75 gaps drops true rim points of noisy and random scans).
    envelope_gaps: float = 1.0
    # On irregular sampling (random points, a cloud sampled from a CAD mesh) the edge is the largest empty
    # circle of the surface points when their height noise is at most this fraction of the mean point
    # distance (1 / sqrt(density)): the in-plane scatter that comes with noise carries points into the
    # hole. On random sampling at 0.25 of it the empty circle came out 0.17 h small (the rim fit
    # 0.08 h); at 0.085 the empty circle is the better (sd 0.045 h against the fit's 0.12 h).
    empty_circle_max_noise: float = 0.15
    # Default smallest reported diameter, in gaps (natural gaps of random sampling reach ~4 g).
    min_diameter_gaps: float = 6.0
    # Rim circle fit: sigma clipping threshold, and a floor of the residual scale (in spacings).
    clip_sigmas: float = 4.0
    clip_floor_spacings: float = 0.05
    # A void whose rim is this far from a circle (robust sd of residuals / radius) is not a hole.
    max_relative_scatter: float = 0.06
    # A partial hole must keep at least this much of its rim.
    min_partial_arc_deg: float = 120.0
    # A hole whose circle has scanned material around less than this many degrees is partial.
    full_arc_deg: float = 350.0
    # A void is a boss (not a hole) when this fraction of its expected surface points stand above it.
    boss_fraction: float = 0.25
    # Sampling-bias correction: synthetic holes cut at r + k * period for these k (the pattern's
    # period: line pitch or grid spacing; half an alpha on irregular sampling), in this many passes.
    bias_offsets: tuple = (1, 2, 3, 4)
    bias_passes: int = 2
    # As many of those synthetic holes as give about this many rim points in all.
    bias_rim_points: int = 400
    # The surface at a hole follows a quadric instead of a plane when the quadric's sag at the hole's
    # center exceeds this many of its standard errors (a curved panel; on a flat one the quadric is
    # only noisier).
    curvature_sigmas: float = 3.0
    # On such a surface each hole is measured again on its neighbourhood within this many radii,
    # flattened by the quadric of the surface points in the ring from 1 to crop_ring_radii radii.
    crop_radii: float = 4.0
    crop_ring_radii: float = 3.5
    # A countersink's edge found within this fraction of its search window's outer limit is at the
    # limit, and the window moves out to it, at most this many times (on a wide scan of a curved
    # panel the band hides the top of the cone; it rarely hides more than one window).
    cone_window_limit: float = 0.02
    cone_window_moves: int = 3
    # Holes are measured in this many threads when the cloud has at least this many points.
    threads: int = 2
    threads_from_points: int = 200_000
    # A countersink cone's points below the surface must deepen toward the center at least at this
    # fraction of the cone's fitted slope (depth per radius): the flat floor of a blind hole, at one
    # depth all across the inside, is not a cone (check "flat_floor" of holecli.robust.countersink).
    cone_depth_slope_ratio: float = 0.3
    # Fewest rim points for a full hole, and for a partial hole or any hole found in a bay of the
    # scan's border (where the dents of a ragged border must not pass for holes).
    min_rim_points: int = 6
    min_partial_rim_points: int = 12

    def __post_init__(self):
        for name, low, high in _RANGES:
            value = getattr(self, name)
            if name in _COUNTS:
                good = isinstance(value, int) and not isinstance(value, bool) and low <= value <= high
            else:
                good = (isinstance(value, (int, float)) and not isinstance(value, bool)
                        and (low < value < high or value == low == -_INF
                             or (name in _CLOSED and value == high)))
            if not good:
                kind = "an integer" if name in _COUNTS else "a number"
                raise ValueError(f"RobustSettings.{name} must be {kind} in {_describe(name, low, high)}, "
                                 f"got {value!r}")
        offsets = self.bias_offsets
        if (not isinstance(offsets, tuple) or not offsets
                or not all(isinstance(k, (int, float)) and not isinstance(k, bool) and 0 < k < _INF
                           for k in offsets)):
            raise ValueError(f"RobustSettings.bias_offsets must be a non-empty tuple of positive numbers, "
                             f"got {offsets!r}")


# (field, lower, upper): floats strictly inside (lower, upper) unless listed in _CLOSED (upper allowed);
# counts in [lower, upper].
_INF = float("inf")
_RANGES = (
    ("ransac_sample", 3, 10 ** 9), ("ransac_hypotheses", 1, 10 ** 6), ("ransac_quantile", 0.0, 1.0),
    ("plane_clip", 0.0, _INF), ("sampling_windows", 1, 1000), ("sampling_window_points", 10, 10 ** 9),
    ("cell_gaps", 0.0, _INF), ("alpha_gaps", 0.0, _INF), ("margin_alphas", 0.0, _INF),
    ("envelope_gaps", 0.0, _INF), ("empty_circle_max_noise", 0.0, _INF), ("min_diameter_gaps", 0.0, _INF), ("clip_sigmas", 0.0, _INF),
    ("clip_floor_spacings", 0.0, _INF), ("max_relative_scatter", 0.0, _INF),
    ("min_partial_arc_deg", 0.0, 360.0), ("full_arc_deg", 0.0, 360.0), ("boss_fraction", 0.0, 1.0),
    ("bias_passes", 1, 100), ("bias_rim_points", 1, 10 ** 9), ("curvature_sigmas", 0.0, _INF),
    ("crop_radii", 1.0, _INF), ("crop_ring_radii", 1.0, _INF), ("cone_window_limit", 0.0, 1.0),
    ("cone_window_moves", 0, 100), ("threads", 1, 1024), ("threads_from_points", 0, 10 ** 12),
    # below 1: a cone's points must deepen at some fraction of its slope; -inf turns the check off
    ("cone_depth_slope_ratio", -_INF, 1.0),
    ("min_rim_points", 3, 10 ** 9), ("min_partial_rim_points", 3, 10 ** 9),
)
_COUNTS = {"ransac_sample", "ransac_hypotheses", "sampling_windows", "sampling_window_points", "bias_passes",
           "bias_rim_points", "cone_window_moves", "threads", "threads_from_points", "min_rim_points",
           "min_partial_rim_points"}
_CLOSED = {"min_partial_arc_deg", "full_arc_deg", "boss_fraction"}


def _describe(name, low, high):
    if name in _COUNTS:
        return f"[{low}, {high}]"
    return f"({low}, {high}{']' if name in _CLOSED else ')'}"


DEFAULT_SETTINGS = RobustSettings()
