"""Sub-spacing edge estimate on regularly sampled scans: the circle that separates present from missing
lattice points.

On a scan line with a regular step, the last point before a hole and the first missing position after it
bracket the edge: the edge circle passes outside every material point and inside every missing lattice
position next to one. In the lifted coordinates ``f(p) = |p|^2 - 2 c.p + k`` (with ``k = |c|^2 - r^2``)
each bracket is a linear inequality in ``(c, k)``, so the circles consistent with all brackets form a
convex polytope; holecli takes the circle of largest margin inside it by linear programming
(:mod:`holecli.geometry.small_lp`: four variables, every row kept). On a noise-free
grid or stripe scan this pins the edge to a small fraction of the spacing, far below the statistical
sampling bias of a rim fit. When the brackets contradict each other (in-plane noise, an irregular
pattern) there is no such circle and the caller keeps its rim fit.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from holecli.geometry.kernels import largest_angular_gap
from holecli.geometry.small_lp import maximize
from holecli.robust.estimators import harness
from holecli.robust.estimators.harness import EdgeEstimate, synthetic_errors
from holecli.robust.estimators.rim_fit import synthetic_rim, synthetic_ring
from holecli.settings import DEFAULT_SETTINGS
from holecli.vocabulary import ESTIMATOR_LATTICE


def lattice_steps(xy, axes, spacing, *, settings=DEFAULT_SETTINGS):
    """Refine lattice step vectors from the points: the median neighbour vector along each axis.

    With two axes (a grid) the two diagonals are added: they bracket the edge where it runs at 45
    degrees to the axes.

    Parameters
    ----------
    xy : (n, 2) float
    axes : sequence of (2,) float
        Unit directions along which the sampling is regular.
    spacing : float
    settings : RobustSettings
        Source of ``lattice_present_steps`` (a neighbour one step along is present within this
        fraction of the step) and ``lattice_min_present_fraction``.

    Returns
    -------
    list of (2,) float
        One step vector per axis (None where the points show no regular step along it).
    """
    tree = cKDTree(xy)
    steps = []
    for axis in axes:
        axis = np.asarray(axis, dtype=np.float64)
        distance, index = tree.query(xy + spacing * axis, k=1)
        close = distance < settings.lattice_present_steps * spacing
        if close.sum() < settings.lattice_min_present_fraction * len(xy):
            steps.append(None)
            continue
        steps.append(np.median(xy[index[close]] - xy[close], axis=0))
    if len(steps) == 2 and steps[0] is not None and steps[1] is not None:
        steps += [steps[0] + steps[1], steps[0] - steps[1]]
    return steps


def separating_circle(local_xy, rim_xy, steps, center, radius, *, settings=DEFAULT_SETTINGS, radii=False):
    """Largest-margin circle through every bracket of present and missing lattice positions.

    A bracket is a rim point ``p`` whose line is regular behind it (``p - v`` present) and empty ahead
    (no point near ``q = p + v``, inside the current circle): the edge crosses the segment ``[p, q]``.
    Every bracketing point must lie outside the circle and every missing position inside it, both by
    the margin that is maximised; every other material point near the edge must lie outside. Using
    the two ends of the same brackets keeps the information on both sides of the edge symmetric, so
    the circle is not pushed in or out.

    Parameters
    ----------
    local_xy : (n, 2) float
        Material points around the hole.
    rim_xy : (m, 2) float
        Its rim points.
    steps : sequence of (2,) float or None
        Lattice step vectors (both signs are used; None entries are skipped).
    center : (2,) float
    radius : float
        Current estimate of the edge circle.
    settings : RobustSettings
        Source of ``lattice_present_steps``, ``lattice_missing_steps``, ``lattice_min_brackets``,
        ``lattice_max_gap_deg`` and ``lattice_others_steps``.
    radii : bool
        Also return the range of radii the brackets allow: the smallest and the largest radius of
        a circle that separates them all (margin zero, its center free). The points say nothing of
        where in that range the edge lies: on a lattice aligned with the hole (its center on a
        lattice position, as a scan centred on the hole's nominal position is) the positions at
        one distance from the center come in fours or eights, the range is that much wider than on
        a lattice of random phase, and a round radius on a round pitch puts a point exactly on the
        edge: the truth is then at the range's outer end, half its width from the largest-margin
        circle.

    Returns
    -------
    (center, radius, margin) or None
        None when fewer than ``lattice_min_brackets`` (8) brackets are found, they leave more than
        ``lattice_max_gap_deg`` (a quarter) of the circle without one, or no circle satisfies them all.
        With ``radii``: ``(center, radius, margin, (low, high))``.
    """
    steps = [np.asarray(s) for s in steps if s is not None]
    if not steps:
        return None
    step_length = float(np.median([np.linalg.norm(s) for s in steps]))
    vectors = np.array([vector for step in steps for vector in (step, -step)])
    # The distance from the nearest material point behind and ahead of every rim point along every
    # vector, in one query (of an unbalanced tree: quicker to build, the same distances), exact up to
    # twice the farther of the two thresholds (beyond it: infinite, on the same side of both).
    ahead_xy = rim_xy[None] + vectors[:, None]
    reach = 2.0 * max(settings.lattice_present_steps, settings.lattice_missing_steps) * np.linalg.norm(vectors, axis=1).max()
    distance, _ = cKDTree(local_xy, balanced_tree=False, compact_nodes=False).query(
        np.concatenate([rim_xy[None] - vectors[:, None], ahead_xy]).reshape(-1, 2), distance_upper_bound=reach)
    behind_all, ahead_all = distance.reshape(2, len(vectors), len(rim_xy))
    inner, outer = [], []
    for vector, behind, ahead, candidate in zip(vectors, behind_all, ahead_all, ahead_xy):
        length = float(np.linalg.norm(vector))
        inside = np.hypot(*(candidate - center).T) < radius
        ok = ((behind < settings.lattice_present_steps * length)
              & (ahead > settings.lattice_missing_steps * length) & inside)
        inner.append(candidate[ok])
        outer.append(rim_xy[ok])
    inner = np.unique(np.concatenate(inner), axis=0)
    outer = np.unique(np.concatenate(outer), axis=0)
    if len(inner) < settings.lattice_min_brackets:
        return None
    if largest_angular_gap(inner, center) > np.radians(settings.lattice_max_gap_deg):
        return None
    # Coordinates centred on the current center and in units of its radius: the programme (and its
    # solver's absolute tolerances) is then the same in millimetres and in metres.
    others = (local_xy[np.hypot(*(local_xy - center).T) < radius + settings.lattice_others_steps * step_length]
              - center) / radius
    outer = (outer - center) / radius
    inner = (inner - center) / radius
    unit = radius
    radius, step_length = 1.0, step_length / unit
    # Variables (cx, cy, k, t), k = |c|^2 - r^2; f(p) = |p|^2 - 2 c.p + k.
    # Outside by the margin: f(p) >= 2 r t; inside: f(q) <= -2 r t; other material: f(p) >= 0.
    scale = 2.0 * radius
    rows = [
        np.column_stack([2 * outer, -np.ones(len(outer)), np.full(len(outer), scale)]),
        np.column_stack([-2 * inner, np.ones(len(inner)), np.full(len(inner), scale)]),
        np.column_stack([2 * others, -np.ones(len(others)), np.zeros(len(others))]),
    ]
    bounds = np.concatenate([np.sum(outer**2, axis=1), -np.sum(inner**2, axis=1), np.sum(others**2, axis=1)])
    rows = np.vstack(rows)
    # A feasible start: the current center, the radius of the nearest other material point, and the
    # margin (negative) that the brackets then leave.
    k = -float(np.min(bounds[len(outer) + len(inner):], initial=radius**2))
    margin = min(float(np.min((bounds - rows[:, 2] * k)[:len(outer) + len(inner)] / scale)), step_length)
    solution = _maximize(np.array([0.0, 0.0, 0.0, 1.0]), rows, bounds,
                         [(-radius, radius), (-radius, radius), (None, None), (None, step_length)],
                         np.array([0.0, 0.0, k, margin]))
    if solution is None or solution[3] <= 0:
        return None
    cx, cy, k, margin = solution
    radius_sq = cx * cx + cy * cy - k
    if radius_sq <= 0:
        return None
    found = center + unit * np.array([cx, cy]), unit * float(np.sqrt(radius_sq)), unit * float(margin)
    if not radii:
        return found
    # The extreme radii at zero margin: r^2 = |c|^2 - k, linear about the largest-margin center c0
    # (|c|^2 ~ |c0|^2 + 2 c0.(c - c0); the term left out, |c - c0|^2, is below 1e-4 of r^2 as long as
    # the centers differ by under 1 % of the radius). The largest-margin circle, its margin set to
    # zero, is where both start.
    extremes = []
    for sign in (1.0, -1.0):
        extreme = _maximize(-sign * np.array([2.0 * cx, 2.0 * cy, -1.0]), rows[:, :3], bounds,
                            [(-radius, radius), (-radius, radius), (None, None)], np.array([cx, cy, k]))
        if extreme is None:
            extremes.append(found[1])
            continue
        ex, ey, ek = extreme
        extremes.append(unit * float(np.sqrt(max(ex * ex + ey * ey - ek, 0.0))))
    low, high = min(extremes[0], found[1]), max(extremes[1], found[1])
    return (*found, (low, high))


def _maximize(objective, rows, limits, bounds, start):
    """The point that maximises ``objective . x`` subject to ``rows x <= limits`` and the ``bounds``
    of each variable (``(low, high)``, None for no bound), from the feasible ``start``.

    Solved by :func:`holecli.geometry.small_lp.maximize`; by scipy's HiGHS where it cannot certify
    an optimum, or where the optimum may not be unique (about one programme in a thousand on random
    lattice cuts, none on the benchmarks' scans): HiGHS's choice among the optimal points is the one
    holecli made before, kept so that the records do not move. None when neither finds one.
    """
    box = np.eye(len(objective))
    upper = [j for j, (_, high) in enumerate(bounds) if high is not None]
    lower = [j for j, (low, _) in enumerate(bounds) if low is not None]
    result = maximize(objective, np.vstack([rows, box[upper], -box[lower]]),
                      np.concatenate([limits, [bounds[j][1] for j in upper], [-bounds[j][0] for j in lower]]), start)
    if result.unique:
        return result.x
    from scipy.optimize import linprog  # here: its import costs the command line about half a second

    fallback = linprog(c=-objective, A_ub=rows, b_ub=limits, bounds=bounds, method="highs")
    return fallback.x if fallback.status == 0 else None


def lattice_errors(xy, center, radius, offsets, scales, steps, *, settings=DEFAULT_SETTINGS, reflections=None):
    """The errors of :func:`separating_circle` on synthetic holes of known center and radius.

    Each synthetic hole of radius ``radius + offset`` is cut at ``center`` into ``xy`` and measured
    as a real hole of the lattice is: its rim extracted and fitted
    (:func:`holecli.robust.estimators.rim_fit.synthetic_rim`), then the separating circle of its brackets along
    the lattice ``steps``, from that fit.

    Parameters
    ----------
    xy : (n, 2) float
        Material points around the hole, reaching at least ``radius + max(offsets) + scales.margin``.
    center : (2,) float
    radius : float
        The hole's radius.
    offsets : sequence of float
        Positive offsets of the synthetic radii.
    scales : holecli.robust.estimators.rim_fit.RimScales
    steps : sequence of (2,) float or None
        The lattice's step vectors (:func:`lattice_steps`).
    settings : RobustSettings
    reflections : sequence of (m, 2) float or None, optional
        Per offset, the points added inside that synthetic hole (None: none).

    Returns
    -------
    holecli.robust.estimators.harness.SyntheticErrors or None
        None when no synthetic hole could be measured.
    """
    def measure(synthetic, inside):
        rim = synthetic_rim(xy, center, synthetic, scales, allow_open=False, settings=settings, inside=inside)
        if rim is None:
            return None
        edge = separating_circle(rim.local, rim.rim_xy, steps, rim.fit.center, rim.fit.radius, settings=settings)
        return None if edge is None else edge[:2]

    return synthetic_errors(measure, center, [radius + offset for offset in offsets], reflections)


def _lattice_errors(scene, center, radius, steps, settings, floor):
    """:func:`lattice_errors` of a hole of the lattice measured at ``center`` with ``radius``:
    synthetic holes cut into the material around it, the lattice's period apart."""
    offsets = [k * scene.sampling.spacing for k in settings.bias_offsets]
    scales, ring = synthetic_ring(scene, center, radius, offsets, settings, floor)
    return lattice_errors(ring, center, radius, offsets, scales, steps, settings=settings,
                          reflections=harness.reflections(scene, center, radius, offsets))


class Lattice:
    """The largest-margin circle separating present from missing lattice positions
    (:func:`separating_circle`): a full hole on a regularly sampled scan (a grid, stripes).

    Not bias corrected: the radius's uncertainty is the root mean square of its errors on synthetic
    holes, at least the rectangular one over the range of radii the brackets allow."""

    name = ESTIMATOR_LATTICE  # its precedence: holecli.vocabulary.ESTIMATORS
    # The method terms (a, b) for the in-plane center and the diameter: a h and b sigma_h in
    # quadrature (see holecli.robust.uncertainty for how they were measured).
    method_terms = {"center": (0.002, 0.0), "diameter": (0.015, 0.1)}
    correction_share = 0.0
    bias_corrected = False      # its errors' root mean square is the u, not their spread
    at_least_fit = False
    from_cone_covariance = False

    def center_floor(self, density, radius):
        """No floor of the center's uncertainty."""
        return 0.0

    def applies(self, scene, partial, settings):
        """A full hole on a scan whose sampling is regular along at least one axis."""
        return bool(scene.sampling.lattice_axes) and not partial

    def edge(self, scene, local, rim_xy, center, radius, partial, floor, settings):
        """The separating circle of the brackets around the rim, and its errors on synthetic holes;
        None when the brackets give none."""
        steps = lattice_steps(local, scene.sampling.lattice_axes, scene.sampling.spacing, settings=settings)
        edge = separating_circle(local, rim_xy, steps, center, radius, settings=settings, radii=True)
        if edge is None:
            return None
        synthetic = _lattice_errors(scene, edge[0], edge[1], steps, settings, floor)
        return EdgeEstimate(estimator=self, center=edge[0], radius=edge[1], bias=radius - edge[1],
                            synthetic=synthetic, radius_range=edge[3])


LATTICE = Lattice()
