"""Pairing measured holes with nominal ones, and the leave-one-out check for a misplaced hole.

:func:`match_holes` pairs by name when the measured holes carry names; otherwise, with three or more
holes, from the mutual distances alone (no frame needed): every nominal triplet whose pairwise
distances agree with a well-spread measured triplet gives a candidate rigid transform, all measured
holes are mapped by it and paired with their nearest nominal holes, and the candidate pairing most
holes with the smallest residual wins. One or two holes carry too little shape: they pair by name or
by nearness after a given initial transform.

Symmetric layouts
-----------------
A layout that a rotation maps onto itself (a square, a regular polygon, a rectangle turned half a
turn, ...) admits several pairings that fit equally well: the distances cannot tell them apart. The
one found is then arbitrary among them and :attr:`HoleMatch.ambiguous` is True, with the number of
distinct equally good pairings in ``alternatives``. Holes in one plane are always at least twofold
ambiguous in this sense when the part may be turned over: the mirror image of a planar layout is the
layout turned half a turn about an axis in its plane, a proper rotation. Only the normals (which the
turned-over part shows reversed) or names resolve that; pass names, or check the fit's normal
residuals afterwards. The distances alone cannot: :attr:`HoleMatch.tied` lists the equally good
pairings (a square's four turns in its plane *and* its four turned-over poses) for the caller to choose
among by the normals, and a layout matched against its own mirror image is paired (by a turn-over)
without any tie. :func:`holecli.registration.register` does both: it prefers the tied pairing that
keeps the measured normals' signs, and refuses a fit that reverses every one of them.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np
from scipy.optimize import linear_sum_assignment
from scipy.spatial.distance import cdist
from scipy.stats import chi2 as chi2_distribution
from scipy.stats import f as f_distribution

from holecli.registration.rigid import kabsch_points
from holecli.registration.transform import RegistrationError, RigidTransform

# Default pairing tolerance as a fraction of the smallest nominal hole-to-hole distance: a measured
# hole further than this from every mapped nominal hole stays unmatched.
TOLERANCE_FRACTION = 0.25
# Measured triplets tried as the base of a distance match, the best spread first: at least
# BASE_TRIPLETS, then more (up to MAX_BASE_TRIPLETS) until one pairs every hole it can (a spurious
# measured hole spoils the triplets it is in).
BASE_TRIPLETS = 4
MAX_BASE_TRIPLETS = 300
# A candidate pairing counts as equally good as the best when its rms is below
# TIE_FACTOR * best + TIE_FRACTION * tolerance (the second term covers noise around an exact fit).
TIE_FACTOR = 1.5
TIE_FRACTION = 0.01


@dataclass(frozen=True, eq=False)
class HoleMatch:
    """Measured holes paired with nominal ones.

    Attributes
    ----------
    pairs : list of (int, int)
        ``(measured index, nominal index)``, sorted by measured index.
    unmatched_measured : list of int
    unmatched_nominal : list of int
    method : str
        ``"names"``, ``"distances"`` or ``"nearest"`` (after the given initial transform).
    rms : float
        Root mean square distance, file units, of the paired holes after the transform used to pair
        them (NaN for ``"names"``).
    ambiguous : bool
        Another, different pairing of as many holes fits about as well (see the module's notes).
    alternatives : int
        Number of distinct equally good pairings found (1 when unambiguous).
    tied : tuple of tuple
        The equally good pairings of a distance match, each a sorted tuple of ``(measured, nominal)``
        pairs, the best fitting (``pairs``) first; ``(pairs,)`` when unambiguous, empty for the other
        methods. A caller that knows more (the normals' signs) chooses among them: see the module's notes.
    """

    pairs: list
    unmatched_measured: list
    unmatched_nominal: list
    method: str
    rms: float
    ambiguous: bool = False
    alternatives: int = 1
    tied: tuple = ()


def _as_points(values, name):
    values = np.asarray(values, dtype=np.float64)
    if values.ndim != 2 or values.shape[1] != 3 or not np.all(np.isfinite(values)):
        raise RegistrationError(f"{name} must be a finite (n, 3) array, got shape {values.shape}")
    return values


def _assign(mapped, nominal, tolerance):
    """Nearest one-to-one pairing (Hungarian on distances), gated by ``tolerance``."""
    distances = cdist(mapped, nominal)
    rows, cols = linear_sum_assignment(distances)
    keep = distances[rows, cols] <= tolerance
    return list(zip(rows[keep].tolist(), cols[keep].tolist())), distances[rows[keep], cols[keep]]


def _result(pairs, count_measured, count_nominal, method, rms, ambiguous=False, alternatives=1, tied=()):
    pairs = sorted(pairs)
    used_m = {m for m, _ in pairs}
    used_n = {n for _, n in pairs}
    return HoleMatch(
        pairs=pairs,
        unmatched_measured=[i for i in range(count_measured) if i not in used_m],
        unmatched_nominal=[i for i in range(count_nominal) if i not in used_n],
        method=method,
        rms=float(rms),
        ambiguous=ambiguous,
        alternatives=alternatives,
        tied=tuple(tied),
    )


def _base_triplets(points, count):
    """Measured triplets by decreasing triangle area (the well conditioned first for a 3-point Kabsch)."""
    triplets = np.array(list(itertools.combinations(range(len(points)), 3)))
    a, b, c = points[triplets[:, 0]], points[triplets[:, 1]], points[triplets[:, 2]]
    areas = np.linalg.norm(np.cross(b - a, c - a), axis=1)
    order = np.argsort(areas)[::-1][:count]
    return [tuple(triplets[i].tolist()) for i in order if areas[i] > 0]


def _match_by_distances(nominal, measured, tolerance):
    nominal_distances = cdist(nominal, nominal)
    measured_distances = cdist(measured, measured)
    candidates = {}
    most = min(len(nominal), len(measured))
    for tried, (a, b, c) in enumerate(_base_triplets(measured, MAX_BASE_TRIPLETS)):
        if tried >= BASE_TRIPLETS and candidates and max(len(key) for key in candidates) == most:
            break
        target = (measured_distances[a, b], measured_distances[b, c], measured_distances[a, c])
        # Candidate nominal (i, j, k) for the ordered measured (a, b, c): the first pair by a vectorised
        # filter, then the third hole. O(k^3) distance look-ups at worst, few Kabsch fits.
        first = np.argwhere(np.abs(nominal_distances - target[0]) <= 2 * tolerance)
        for i, j in first:
            if i == j:
                continue
            ks = np.nonzero(
                (np.abs(nominal_distances[j] - target[1]) <= 2 * tolerance)
                & (np.abs(nominal_distances[i] - target[2]) <= 2 * tolerance)
            )[0]
            for k in ks:
                if k in (i, j):
                    continue
                rotation, translation = kabsch_points(measured[[a, b, c]], nominal[[i, j, k]])
                pairs, distances = _assign(measured @ rotation.T + translation, nominal, tolerance)
                if len(pairs) < 3:
                    continue
                key = tuple(sorted(pairs))
                if key in candidates:
                    continue
                # Score on a fit to all the pairs, not only the base triplet.
                m_idx = [m for m, _ in key]
                n_idx = [n for _, n in key]
                rotation, translation = kabsch_points(measured[m_idx], nominal[n_idx])
                residual = measured[m_idx] @ rotation.T + translation - nominal[n_idx]
                candidates[key] = float(np.sqrt(np.mean(np.sum(residual**2, axis=1))))
    if not candidates:
        return None
    best = max(candidates, key=lambda key: (len(key), -candidates[key]))
    best_rms = candidates[best]
    ties = sorted(
        (key for key in candidates
         if len(key) == len(best) and candidates[key] <= TIE_FACTOR * best_rms + TIE_FRACTION * tolerance),
        key=lambda key: (key != best, candidates[key]))
    return best, best_rms, ties


def match_holes(
    nominal_names,
    nominal_centers,
    measured_centers,
    measured_names=None,
    initial_transform=None,
    tolerance=None,
):
    """Pair measured holes with nominal holes.

    Parameters
    ----------
    nominal_names : sequence of str, length k
    nominal_centers : (k, 3) float
        Part (CAD) frame.
    measured_centers : (m, 3) float
        Measuring frame, any order.
    measured_names : sequence of str or None, length m, optional
        When given, holes pair by name and nothing else (names absent from the nominal list, or None,
        stay unmatched).
    initial_transform : RigidTransform, optional
        An approximate part -> measuring transform. With it, the holes pair by nearness after mapping
        the nominal centers; it is required for one or two unnamed holes.
    tolerance : float, optional
        File units: the furthest a measured hole may lie from its (mapped) nominal hole, and half the
        allowed disagreement of a distance. Default: ``TOLERANCE_FRACTION`` times the smallest nominal
        hole-to-hole distance.

    Returns
    -------
    HoleMatch

    Raises
    ------
    RegistrationError
        (a ValueError) on bad shapes, mismatched name counts, duplicate names, or one or two unnamed
        holes without an initial transform.
    """
    nominal_centers = _as_points(nominal_centers, "nominal_centers")
    measured_centers = _as_points(measured_centers, "measured_centers")
    nominal_names = list(nominal_names)
    if len(nominal_names) != len(nominal_centers):
        raise RegistrationError(f"{len(nominal_names)} nominal names for {len(nominal_centers)} nominal centers")
    if len(set(nominal_names)) != len(nominal_names):
        raise RegistrationError("nominal names must be unique")
    count_m, count_n = len(measured_centers), len(nominal_centers)

    if measured_names is not None:
        measured_names = list(measured_names)
        if len(measured_names) != count_m:
            raise RegistrationError(f"{len(measured_names)} measured names for {count_m} measured centers")
        named = [name for name in measured_names if name is not None]
        if len(set(named)) != len(named):
            raise RegistrationError("measured names must be unique")
        index = {name: i for i, name in enumerate(nominal_names)}
        pairs = [(m, index[name]) for m, name in enumerate(measured_names) if name in index]
        return _result(pairs, count_m, count_n, "names", np.nan)

    if tolerance is None:
        if count_n < 2:
            tolerance = np.inf
        else:
            distances = cdist(nominal_centers, nominal_centers)
            tolerance = TOLERANCE_FRACTION * float(distances[np.triu_indices(count_n, 1)].min())
    elif not np.isfinite(tolerance) or tolerance <= 0:
        raise RegistrationError(f"tolerance must be finite and > 0, got {tolerance!r}")

    if initial_transform is not None:
        mapped = initial_transform.apply_points(nominal_centers)
        pairs, distances = _assign(measured_centers, mapped, tolerance)
        rms = np.sqrt(np.mean(distances**2)) if len(distances) else np.nan
        return _result(pairs, count_m, count_n, "nearest", rms)

    if count_m < 3 or count_n < 3:
        raise RegistrationError(
            f"{min(count_m, count_n)} holes carry no shape to match by: give measured names or an initial transform"
        )
    found = _match_by_distances(nominal_centers, measured_centers, tolerance)
    if found is None:
        return _result([], count_m, count_n, "distances", np.nan)
    pairs, rms, ties = found
    return _result(list(pairs), count_m, count_n, "distances", rms, ambiguous=len(ties) > 1,
                   alternatives=len(ties), tied=ties)


@dataclass(frozen=True, eq=False)
class OutlierCheck:
    """The leave-one-out check of a hole set.

    Attributes
    ----------
    outliers : list
        Names (or indices, without names) of the holes judged misplaced, in the order found; empty
        when none, or when not checked.
    predicted_residuals : (n,) float
        For each hole, the distance between its measured center and where the fit to all the *other*
        holes puts it, file units (NaN when not checked). From the first round (all holes present).
    standardized : (n,) float
        The same residual in units of its own standard uncertainty, ``sqrt(r^T V^-1 r)`` with
        ``V`` the hole's center covariance plus the refit's prediction covariance (first round).
    probability : (n,) float
        The chance of a standardized residual at least as large from noise alone (first round).
    checked : bool
        False when there were too few holes to check.
    reason : str
        Why the holes named are outliers, or why none are, or why no check was made.
    """

    outliers: list
    predicted_residuals: np.ndarray
    standardized: np.ndarray
    probability: np.ndarray
    checked: bool
    reason: str


# Leave-one-out needs this many holes: each refit then keeps three, enough to fix every rotation from
# the centers alone and still leave the left-out hole as an independent check of it.
MIN_HOLES_FOR_OUTLIERS = 4
_SIGMA_OPTIONS = ("center_sigma_inplane", "center_sigma_normal", "normal_sigma_deg")


def _hole_covariance(fit, normal, options, index):
    """The left-out hole's own center covariance: from the sigmas given, else the refit's residual scale."""
    inplane = options.get("center_sigma_inplane", options.get("center_sigma_normal"))
    along = options.get("center_sigma_normal", inplane)
    if inplane is None:
        variance = fit.chi2 / fit.dof if fit.dof > 0 else np.nan
        return variance * np.eye(3)
    inplane = float(np.ravel(inplane)[index] if np.ndim(inplane) else inplane)
    along = float(np.ravel(along)[index] if np.ndim(along) else along)
    n = normal / np.linalg.norm(normal)
    outer = np.outer(n, n)
    return inplane**2 * (np.eye(3) - outer) + along**2 * outer


def _leave_one_out(fit_function, nominal_centers, nominal_normals, measured_centers, measured_normals, options):
    count = len(nominal_centers)
    predicted = np.empty(count)
    standardized = np.empty(count)
    probability = np.empty(count)
    rest_misfit = np.empty(count)
    for i in range(count):
        keep = np.arange(count) != i
        kept_options = {
            key: (np.asarray(value)[keep] if key in _SIGMA_OPTIONS and np.ndim(value) else value)
            for key, value in options.items()
        }
        fit = fit_function(nominal_centers[keep], nominal_normals[keep], measured_centers[keep],
                           measured_normals[keep], **kept_options)
        residual = measured_centers[i] - fit.transform.apply_points(nominal_centers[i])
        predicted[i] = np.linalg.norm(residual)
        covariance = fit.point_covariance(nominal_centers[i]) + _hole_covariance(fit, measured_normals[i], options, i)
        if np.all(np.isfinite(covariance)):
            standardized[i] = float(np.sqrt(residual @ np.linalg.pinv(covariance, hermitian=True) @ residual))
        else:
            standardized[i] = np.nan
        probability[i] = _tail_probability(standardized[i], fit, options)
        rest_misfit[i] = fit.chi2 / fit.dof if fit.dof > 0 else np.nan
    return predicted, standardized, probability, rest_misfit


def _tail_probability(standardized, fit, options):
    """Probability of a standardized residual at least this large from noise alone.

    With the sigmas given its square is chi-square with 3 degrees of freedom; with the scale estimated
    from the refit's ``dof`` residual components, a third of it is F(3, dof) (heavier tailed: three
    holes' residuals estimate a scale poorly).
    """
    if not np.isfinite(standardized):
        return np.nan
    if any(options.get(key) is not None for key in ("center_sigma_inplane", "center_sigma_normal")):
        return float(chi2_distribution.sf(standardized**2, 3))
    if fit.dof <= 0:
        return np.nan
    return float(f_distribution.sf(standardized**2 / 3.0, 3, fit.dof))


def find_outliers(
    fit_function,
    nominal_centers,
    nominal_normals,
    measured_centers,
    measured_normals,
    names=None,
    factor=5.0,
    floor=0.0,
    **fit_options,
):
    """Name the holes that the other holes place far from where they were measured (leave-one-out).

    For each hole the transform is refitted to the other holes and the hole's measured center is
    compared with its nominal center mapped by that refit. The residual is standardized by its own
    uncertainty (the hole's center covariance plus the refit's covariance at that point, so that a
    hole the others pin down poorly, far from them or off the line of a near-collinear rest, is not
    blamed for their leverage). The candidate is the hole whose removal leaves the others most
    consistent (the refit's smallest chi-square per degree of freedom); it is named when the chance
    of its standardized residual is below the chance of ``factor`` standard uncertainties with known sigmas
    (chi-square, 3 degrees of freedom; with the scale estimated from the refit's residuals, the
    F(3, dof) distribution, which asks more of a refit of few holes) *and* its residual exceeds
    ``floor`` in file units; it is then set aside and the check repeats on the rest while at least
    ``MIN_HOLES_FOR_OUTLIERS`` holes remain.

    Only the largest is named per round because one misplaced hole spoils every refit it takes part
    in: the good holes' leave-one-out residuals then grow as well, though less. (Comparing each hole's
    raw residual with the median of the others' failed on random layouts: a near-collinear rest of
    three holes predicts a good fourth hole 0.1 mm off from 5 um noise.)

    Parameters
    ----------
    fit_function : callable
        ``fit_function(nominal_centers, nominal_normals, measured_centers, measured_normals,
        **fit_options)`` returning a :class:`holecli.registration.rigid.RigidFit` (or an object with its
        ``transform``, ``point_covariance``, ``chi2`` and ``dof``): :func:`fit_rigid` itself, or a wrapper.
    nominal_centers, nominal_normals, measured_centers, measured_normals : (n, 3) float
        Matched holes, row ``i`` the same hole.
    names : sequence of str, optional
        Reported instead of indices.
    factor : float
        Standard uncertainties (dimensionless) the residual must exceed with known sigmas; 5 flags
        noise with a probability of about 1.5e-5 per hole when the sigmas are right.
    floor : float
        File units: a residual at or below it is never an outlier, whatever the sigmas claim (set it to
        what is too small to matter, a few times the centers' measurement uncertainty).
    **fit_options
        Passed to ``fit_function``; per-hole sigma arrays are sliced with the holes. Without sigmas the
        hole's own variance is the refit's residual variance per degree of freedom.

    Returns
    -------
    OutlierCheck
        ``checked`` is False, with the reason, for fewer than ``MIN_HOLES_FOR_OUTLIERS`` holes: with
        three, each refit keeps two holes, whose rotation about their line rests on the normals alone.
    """
    nominal_centers = _as_points(nominal_centers, "nominal_centers")
    nominal_normals = _as_points(nominal_normals, "nominal_normals")
    measured_centers = _as_points(measured_centers, "measured_centers")
    measured_normals = _as_points(measured_normals, "measured_normals")
    count = len(nominal_centers)
    if not (len(nominal_normals) == len(measured_centers) == len(measured_normals) == count):
        raise RegistrationError(
            "find_outliers needs one row per hole in every array, got "
            f"{count}, {len(nominal_normals)}, {len(measured_centers)}, {len(measured_normals)} rows"
        )
    labels = list(names) if names is not None else list(range(count))
    if len(labels) != count:
        raise RegistrationError(f"{len(labels)} names for {count} holes")
    if not (np.isfinite(factor) and factor > 0):
        raise RegistrationError(f"factor must be finite and > 0, got {factor!r}")
    if not (np.isfinite(floor) and floor >= 0):
        raise RegistrationError(f"floor must be finite and >= 0, got {floor!r}")

    if count < MIN_HOLES_FOR_OUTLIERS:
        nan = np.full(count, np.nan)
        return OutlierCheck([], nan, nan.copy(), nan.copy(), False,
                            f"{count} holes: leave-one-out needs at least {MIN_HOLES_FOR_OUTLIERS}")

    # factor standard uncertainties of a 3D residual with known sigmas, as a tail probability.
    threshold = float(chi2_distribution.sf(factor**2, 3))
    remaining = np.arange(count)
    outliers, reasons = [], []
    first = None
    while len(remaining) >= MIN_HOLES_FOR_OUTLIERS:
        options = {
            key: (np.asarray(value)[remaining] if key in _SIGMA_OPTIONS and np.ndim(value) else value)
            for key, value in fit_options.items()
        }
        predicted, standardized, probability, rest_misfit = _leave_one_out(
            fit_function, nominal_centers[remaining], nominal_normals[remaining],
            measured_centers[remaining], measured_normals[remaining], options,
        )
        if first is None:
            first = (predicted, standardized, probability)
        # The candidate is the hole whose removal leaves the others most consistent (the smallest
        # chi-square per degree of freedom of the refit: the largest reduction of the misfit). Not
        # the largest standardized residual: a refit to a rest that still holds the displaced hole
        # is bent, its covariance (from the sigmas) does not know it, and it places a good hole far
        # off, by more than the displaced hole's own displacement (a 0.2 mm move among 4 holes
        # made a good hole 0.29 mm off).
        eligible = predicted > floor
        if np.isfinite(rest_misfit[eligible]).all() and eligible.any():
            worst = int(np.flatnonzero(eligible)[np.argmin(rest_misfit[eligible])])
        else:
            worst = int(np.argmin(np.where(eligible, np.nan_to_num(probability, nan=np.inf), np.inf)))
        if not (eligible[worst] and probability[worst] < threshold):
            break
        hole = int(remaining[worst])
        outliers.append(labels[hole])
        reasons.append(
            f"{labels[hole]}: placed {predicted[worst]:.6g} from its measured center by the other holes, "
            f"{standardized[worst]:.3g} standard uncertainties (chance {probability[worst]:.2g} from noise, "
            f"< {threshold:.2g}, that of {factor:g} with known sigmas) and > floor {floor:g}"
        )
        remaining = remaining[remaining != hole]
    if outliers:
        reason = "; ".join(reasons)
    else:
        reason = (f"no hole's leave-one-out residual exceeds both {factor:g} standard uncertainties "
                  f"and the floor {floor:g}")
    return OutlierCheck(outliers, *first, True, reason)
