"""Registration of a part from its measured reference holes: match, fit, outlier check, verdict.

:func:`register` is pure (no files, no printing): measured holes (measuring frame) and the nominal
holes of a spec (part frame) go in, a :class:`Registration` comes out, with the rigid transform part ->
measuring frame, every hole's residual, the outlier check and the verdict.

Steps
-----
1. Matching. Holes with a name (``measured_names``: the CLI names a scan's hole after the scan's file
   stem, or ``--name SCAN=HOLE``) pair with the spec hole of that name. Without names, three or more
   holes pair by their mutual distances (:func:`holecli.registration.match_holes`, frame-free). With
   some named and some not, the named holes are fitted first and, when they fix every degree of
   freedom, the others pair by nearness after that fit. One or two unnamed holes cannot be matched,
   but for one measured hole against a spec of one hole (``"only"``).
2. Normals. A measured normal has no sign of its own (holecli orients it to z > 0, see
   :mod:`holecli.results`) and a spec's normal may have either sign (hole by hole: not every one
   reversed, see the notes below). With three or more matched holes not on one line, a centers-only
   Kabsch gives a first rotation and every measured normal is turned to agree with its rotated
   nominal normal. With one or two (or collinear) holes the normals are
   taken as they are: the spec's normals must then point out of the material and each scan be taken
   from outside (holecli's measured normals point to +z, toward a sensor above the part).
   When a distance match finds several equally good pairings (a symmetric layout), the one kept is
   one whose centers-only rotation reverses the fewest *trusted* measured normals (below): a square's
   turned-over poses fit its centers exactly as well as its turns in the plane.
3. Fit. :func:`holecli.registration.fit_rigid` on centers and normals, weighted by the holes' own
   standard uncertainties (``uncertainty.center_in_plane``, ``center_along_normal``, ``normal_deg``)
   when every matched hole has them (floored, see :data:`SIGMA_FLOOR_FRACTION` and
   :data:`NORMAL_SIGMA_FLOOR_DEG`), else unweighted with the covariance scaled from the residuals.
4. Outlier check. :func:`holecli.registration.find_outliers` (leave-one-out, four or more holes). A
   hole it names is *left out* of the final fit, which is repeated without it; its residual is then
   where the other holes place it. It is reported, never silently dropped.
5. Consistency (check ``inconsistent_holes``, :mod:`holecli.registration.consistency`): the final
   fit's weighted chi-square against its degrees of freedom, for every hole count with redundancy
   (two holes and more; the leave-one-out check needs four). When the holes disagree with the spec
   beyond their own uncertainties (and by more than ``outlier_floor``), a warning names the hole
   when it can be told (else the pair), and the fit is repeated with a standard uncertainty added to
   every hole's center (:func:`holecli.registration.consistency.widen`), so that the transform's
   and the targets' uncertainties cover the discrepancy.
6. Verdict (with ``max_residual``): ``fail`` when a hole used in the final fit has an in-plane
   residual or an along-normal residual (absolute) above ``max_residual``, when the holes are
   inconsistent (``"inconsistent_holes"`` in ``failed``), or when an outlier was
   named (a misplaced reference hole is a finding, even though the frame was fitted without it);
   ``pass`` otherwise. Without ``max_residual`` the verdict is None.

Turned over or mirrored: refused
--------------------------------
A planar layout's mirror image is the layout turned half a turn about an axis in its plane, a proper
rotation (see :mod:`holecli.registration.matching`): a part loaded upside down, or a spec whose layout
is the part's mirror image (a drawing read from the wrong side, x -> -x), matches and fits its centers
as well as the right one, and step 2 then turns every measured normal round to agree. Only the
normals' signs tell: after such a fit each measured normal, as measured, points *against* the part's
normal mapped by the fit. A measured normal's sign is only a convention, z > 0 in the measuring frame
(:mod:`holecli.results`): it means "toward a sensor above", out of the material, when the normal is at
least :data:`TRUSTED_NORMAL_MIN_Z` out of the measuring xy plane; nearer the horizontal (a wall, which
a sensor may see from either side) it means nothing and is not counted. **Check
``normals_reversed``:** when every used hole with a trusted normal (at least one) has its measured
normal more than 90 degrees from the mapped spec normal, :func:`register` raises
:class:`RegistrationError` instead of returning a transform that turns the part over. It is refused
rather than warned about because the transform is then wrong in a way no residual shows (the fit is
exact) and the corrected targets would point into the part; the same data also arise from a spec whose
normals point into the material, or scans taken from below, which the message names: registration
needs the spec's normals to point out of the material, toward the sensor. Holes whose trusted normals
disagree among themselves (some reversed, some not) are not refused: that is a spec with mixed signs,
which step 2 allows. Two holes with parallel normals (or holes on one line) are their own mirror
image: a mirrored layout is then not detectable, and the fit takes the measured normals' signs as
they are.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from holecli.registration.consistency import check_consistency, widen
from holecli.registration.matching import OutlierCheck, find_outliers, match_holes
from holecli.registration.rigid import COLLINEAR_TOLERANCE, fit_rigid, hole_residuals, kabsch_points
from holecli.registration.transform import RegistrationError, RigidTransform

__all__ = ["DEFAULT_OUTLIER_FACTOR", "Registration", "RegisteredHole", "register"]

DEFAULT_OUTLIER_FACTOR = 5.0
# A hole's center sigmas are floored at this fraction of the largest center sigma of the set: a
# noise-free scan reports a center along its normal known to 1e-17, which would make one
# component of one hole outweigh all the rest by thirteen orders of magnitude.
SIGMA_FLOOR_FRACTION = 0.01
# Likewise for the normals' angular sigma, degrees.
NORMAL_SIGMA_FLOOR_DEG = 1e-4
# A measured normal's sign (z > 0, toward a sensor above) is trusted when its z component is at least
# this (30 degrees out of the measuring xy plane); a near-horizontal normal (a wall) may face a sensor
# on either side, so its sign says nothing about which way the part lies.
TRUSTED_NORMAL_MIN_Z = 0.5
SCHEMA_VERSION = 1


@dataclass(frozen=True, eq=False)
class RegisteredHole:
    """One matched hole after the registration.

    Attributes
    ----------
    name : str
        The spec hole's name.
    measured_index : int
        Index into the ``measured_holes`` given to :func:`register`.
    nominal_center, nominal_normal : (3,) float
        Part frame (the normal as in the spec, unit length).
    measured_center, measured_normal : (3,) float
        Measuring frame; the normal turned to agree with the nominal one (see the module's step 2).
    normal_flipped : bool
        The measured normal was reversed to agree with the nominal one.
    used : bool
        Part of the final fit (False for an outlier).
    outlier : bool
    in_plane, along_normal, normal_angle_deg : float
        Residual of the measured center from the mapped nominal one, across and along the measured
        normal (signed), file units; angle between the measured and the mapped nominal normal, degrees.
    """

    name: str
    measured_index: int
    nominal_center: np.ndarray
    nominal_normal: np.ndarray
    measured_center: np.ndarray
    measured_normal: np.ndarray
    normal_flipped: bool
    used: bool
    outlier: bool
    in_plane: float
    along_normal: float
    normal_angle_deg: float


def _finite_or_none(value):
    value = float(value)
    return value if math.isfinite(value) else None


def _list(values):
    return [_finite_or_none(v) for v in np.ravel(values)]


@dataclass(frozen=True, eq=False)
class Registration:
    """The result of :func:`register`.

    Attributes
    ----------
    transform : RigidTransform
        Part frame -> measuring frame.
    fit : holecli.registration.RigidFit
        The final fit (outliers left out).
    holes : tuple of RegisteredHole
        Every matched hole, in the order of ``measured_holes``.
    match_method : str
        ``"names"``, ``"distances"``, ``"names+nearest"`` or ``"only"`` (one unnamed measured hole and a
        spec of one hole).
    ambiguous : bool
        The distance match found other pairings that fit as well (a symmetric layout): name the holes.
    unmatched_measured : tuple of int
        Measured holes no spec hole took (not used).
    unmatched_nominal : tuple of str
        Spec holes without a measured hole.
    outlier_check : OutlierCheck
    outliers : tuple of str
    sigmas : bool
        The fit was weighted by the holes' own uncertainties (``fit.covariance_source == "sigmas"``).
    max_residual : float or None
    verdict : str or None
        ``"pass"``, ``"fail"`` or None (no ``max_residual``).
    failed : tuple of str
        Why the verdict failed: ``"<hole>: in_plane 0.012 > 0.01"``, ``"<hole>: outlier"``.
    warnings : tuple of (str, str)
        ``(code, message)`` of what makes the registration doubtful: ``outlier``, ``ambiguous_match``,
        ``free_dofs``, ``inconsistent_holes``.
    notes : tuple of (str, str)
        ``(code, message)`` of facts that make nothing given doubtful: ``unmatched_hole`` (a measured
        hole not used), ``no_uncertainty`` (the fit is unweighted).
    consistency : holecli.registration.consistency.ConsistencyCheck or None
        The test of the final fit's holes against their uncertainties (module step 5); when they are
        inconsistent, ``fit`` is already the widened refit (its ``added_sigma``).
    """

    transform: RigidTransform
    fit: object
    holes: tuple
    match_method: str
    ambiguous: bool
    unmatched_measured: tuple
    unmatched_nominal: tuple
    outlier_check: OutlierCheck
    outliers: tuple
    sigmas: bool
    max_residual: object
    verdict: object
    failed: tuple
    warnings: tuple
    notes: tuple = ()
    consistency: object = None

    @property
    def doubtful(self):
        """bool: a reference hole disagrees with the others or with the spec (an outlier named, or
        ``inconsistent_holes``): ``holecli register`` exits 8 (5 with a failed verdict)."""
        return bool(self.outliers) or (self.consistency is not None and not self.consistency.consistent)

    @property
    def free_dofs(self):
        """tuple of str: the degrees of freedom the holes leave undetermined (empty when none)."""
        return tuple(self.fit.free_dofs)

    @property
    def rms(self):
        """float: root mean square center residual of the holes used in the final fit, file units."""
        return float(self.fit.rms)

    def uncertainty(self):
        """Standard uncertainties (coverage factor 1) of the transform, JSON-ready.

        Returns
        -------
        dict
            ``source`` (``"sigmas"`` or ``"residuals"``), ``translation`` (3, file units: where the
            part's origin lands), ``rotation_deg`` (3, degrees: small rotations about the measuring
            frame's x, y, z axes), ``covariance`` (6x6 of ``(w, dt)``, rad^2 and file units^2, see
            :mod:`holecli.registration.transform`). None for an entry that is infinite (a free degree
            of freedom reaches it) or not known (NaN: no redundancy to estimate it from residuals).
        """
        covariance = np.asarray(self.fit.covariance)
        with np.errstate(invalid="ignore"):
            diagonal = np.sqrt(np.diag(covariance))
        return {
            "source": self.fit.covariance_source,
            "translation": _list(diagonal[3:]),
            "rotation_deg": _list(np.degrees(diagonal[:3])),
            "covariance": [_list(row) for row in covariance],
        }

    def to_dict(self):
        """The registration as a JSON-ready dict (no NaN or infinity: those are None).

        Returns
        -------
        dict
            ``transform`` (:meth:`RigidTransform.to_dict`, with ``roll_pitch_yaw_convention``),
            ``uncertainty`` (:meth:`uncertainty`), ``free_dofs``, ``rms``, ``dof``, ``match``
            (``method``, ``ambiguous``, ``unmatched_measured``, ``unmatched_nominal``), ``holes`` (one
            dict per :class:`RegisteredHole`), ``outliers``, ``outlier_check`` (``checked``,
            ``reason``), ``consistency`` (:meth:`ConsistencyCheck.to_dict`, or None), ``max_residual``,
            ``verdict``, ``failed``, ``warnings``, ``notes``.
        """
        transform = self.transform.to_dict()
        transform["roll_pitch_yaw_convention"] = (
            "R = Rz(yaw) @ Ry(pitch) @ Rx(roll): about the fixed measuring axes x, then y, then z")
        holes = []
        for hole in self.holes:
            holes.append({
                "name": hole.name,
                "measured_index": hole.measured_index,
                "used": hole.used,
                "outlier": hole.outlier,
                "nominal_center": _list(hole.nominal_center),
                "nominal_normal": _list(hole.nominal_normal),
                "measured_center": _list(hole.measured_center),
                "measured_normal": _list(hole.measured_normal),
                "normal_flipped": hole.normal_flipped,
                "residual": {"in_plane": _finite_or_none(hole.in_plane),
                             "along_normal": _finite_or_none(hole.along_normal),
                             "normal_angle_deg": _finite_or_none(hole.normal_angle_deg)},
            })
        return {
            "transform": transform,
            "uncertainty": self.uncertainty(),
            "free_dofs": list(self.free_dofs),
            "rms": _finite_or_none(self.rms),
            "dof": int(self.fit.dof),
            "match": {"method": self.match_method, "ambiguous": self.ambiguous,
                      "unmatched_measured": list(self.unmatched_measured),
                      "unmatched_nominal": list(self.unmatched_nominal)},
            "holes": holes,
            "outliers": list(self.outliers),
            "outlier_check": {"checked": self.outlier_check.checked, "reason": self.outlier_check.reason},
            "consistency": None if self.consistency is None else self.consistency.to_dict(),
            "max_residual": self.max_residual,
            "verdict": self.verdict,
            "failed": list(self.failed),
            "warnings": [{"code": code, "message": message} for code, message in self.warnings],
            "notes": [{"code": code, "message": message} for code, message in self.notes],
        }

    def corrected_targets(self, targets):
        """Targets of the part frame mapped into the measuring frame, with their uncertainty.

        Parameters
        ----------
        targets : holecli.io.targets.Targets
            (or anything with ``names``, ``points`` (n, 3) and ``normals`` (n, 3)).

        Returns
        -------
        list of dict
            Per target: ``name``, ``x, y, z`` (mapped point), ``nx, ny, nz`` (mapped unit normal),
            ``u_x, u_y, u_z`` (standard uncertainties of the point's coordinates from
            :func:`holecli.registration.point_covariance` of the fit; ``inf`` where a free degree of
            freedom moves it, NaN when not known) and ``u_normal_deg`` (of the normal's direction,
            :func:`holecli.registration.direction_uncertainty_deg`).
        """
        points = self.transform.apply_points(np.asarray(targets.points, dtype=np.float64).reshape(-1, 3))
        normals = self.transform.apply_directions(np.asarray(targets.normals, dtype=np.float64).reshape(-1, 3))
        rows = []
        for name, point, normal, mapped, mapped_normal in zip(targets.names, targets.points, targets.normals,
                                                               points, normals):
            covariance = self.fit.point_covariance(np.asarray(point, dtype=np.float64))
            with np.errstate(invalid="ignore"):
                u = np.sqrt(np.diag(covariance))
            rows.append({
                "name": name,
                "x": float(mapped[0]), "y": float(mapped[1]), "z": float(mapped[2]),
                "nx": float(mapped_normal[0]), "ny": float(mapped_normal[1]), "nz": float(mapped_normal[2]),
                "u_x": float(u[0]), "u_y": float(u[1]), "u_z": float(u[2]),
                "u_normal_deg": float(self.fit.direction_uncertainty_deg(np.asarray(normal, dtype=np.float64))),
            })
        return rows


def _vector(value, what):
    array = np.asarray(value, dtype=np.float64).reshape(-1)
    if array.shape != (3,) or not np.all(np.isfinite(array)):
        raise RegistrationError(f"{what} must be a finite 3-vector, got {value!r}")
    return array


def _sigmas(holes):
    """Per-hole (in_plane, along_normal, normal_deg) arrays, floored, or None unless every hole has them."""
    values = []
    for hole in holes:
        u = getattr(hole, "uncertainty", None)
        if u is None:
            return None
        triple = (u.center_in_plane, u.center_along_normal, u.normal_deg)
        if any(v is None or not math.isfinite(v) or v < 0 for v in triple):
            return None
        values.append(triple)
    values = np.array(values, dtype=np.float64)
    largest = float(values[:, :2].max())
    if not largest > 0:
        return None
    centers = np.maximum(values[:, :2], SIGMA_FLOOR_FRACTION * largest)
    normals = np.maximum(values[:, 2], NORMAL_SIGMA_FLOOR_DEG)
    return {"center_sigma_inplane": centers[:, 0], "center_sigma_normal": centers[:, 1], "normal_sigma_deg": normals}


def _spread_enough(points):
    """Three or more points not on one line (a centers-only Kabsch fixes every rotation)."""
    if len(points) < 3:
        return False
    s = np.linalg.svd(points - points.mean(axis=0), compute_uv=False)
    return s[1] > COLLINEAR_TOLERANCE * 1e3 * max(s[0], 1e-300)


def _orient(nominal_centers, nominal_normals, measured_centers, measured_normals):
    """Measured normals turned to agree with the nominal ones (module step 2), and which were turned."""
    flipped = np.zeros(len(measured_normals), dtype=bool)
    if not _spread_enough(nominal_centers) or not _spread_enough(measured_centers):
        return measured_normals, flipped
    rotation, _ = kabsch_points(nominal_centers, measured_centers)
    flipped = np.sum((nominal_normals @ rotation.T) * measured_normals, axis=1) < 0
    return np.where(flipped[:, None], -measured_normals, measured_normals), flipped


def _trusted(measured_normals):
    """Which measured normals' signs mean "toward a sensor above" (module notes)."""
    return np.abs(measured_normals[:, 2]) >= TRUSTED_NORMAL_MIN_Z


def _reversed(rotation, nominal_normals, measured_normals):
    """Which measured normals point against their nominal normals turned by ``rotation`` (> 90 degrees)."""
    return np.sum((nominal_normals @ rotation.T) * measured_normals, axis=1) < 0


def _reversed_trusted(pairs, nominal_centers, nominal_normals, measured_centers, measured_normals):
    """How many trusted measured normals a pairing's centers-only rotation reverses (0 when it cannot tell)."""
    m_idx = [m for m, _ in pairs]
    n_idx = [n for _, n in pairs]
    if not _spread_enough(nominal_centers[n_idx]):
        return 0
    rotation, _ = kabsch_points(nominal_centers[n_idx], measured_centers[m_idx])
    normals = measured_normals[m_idx]
    return int(np.sum(_reversed(rotation, nominal_normals[n_idx], normals) & _trusted(normals)))


def _check_not_turned_over(names, nominal_normals, measured_normals, transform):
    """Check ``normals_reversed`` (module notes): refuse a fit that reverses every trusted measured normal.

    ``measured_normals`` are as measured (before :func:`_orient`), the used holes' only.
    """
    trusted = _trusted(measured_normals)
    if not trusted.any():
        return
    against = _reversed(transform.rotation, nominal_normals, measured_normals)
    if not np.all(against[trusted]):
        return
    mapped = transform.apply_directions(nominal_normals[trusted])
    angles = np.degrees(np.arccos(np.clip(np.sum(mapped * measured_normals[trusted], axis=1), -1.0, 1.0)))
    listed = ", ".join(f"{name} {angle:.1f} deg" for name, angle in zip(np.asarray(names)[trusted], angles))
    raise RegistrationError(
        f"normals_reversed: every measured normal points against its spec normal after the fit ({listed}): "
        "the part is turned over, or the spec's layout is its mirror image (a drawing read from the wrong side); "
        "else the spec's normals point into the material or the scans look up from below (registration needs "
        "spec normals out of the material, toward the sensor: holecli's measured normals point to +z)")


def _match(nominal_names, nominal_centers, nominal_normals, measured_centers, measured_normals, measured_names):
    """(pairs, method, ambiguous): see the module's step 1."""
    count = len(measured_centers)
    if measured_names is None:
        measured_names = [None] * count
    measured_names = list(measured_names)
    if len(measured_names) != count:
        raise RegistrationError(f"{len(measured_names)} measured names for {count} measured holes")
    known = set(nominal_names)
    for name in measured_names:
        if name is not None and name not in known:
            raise RegistrationError(f"no hole {name!r} in the spec (its holes: {', '.join(nominal_names)})")
    named = [name for name in measured_names if name is not None]
    repeated = sorted({name for name in named if named.count(name) > 1})
    if repeated:
        raise RegistrationError(f"hole {repeated[0]!r} is named by {named.count(repeated[0])} measured holes")
    if len(named) == count:
        found = match_holes(nominal_names, nominal_centers, measured_centers, measured_names=measured_names)
        return found.pairs, "names", False
    if not named:
        if count == 1 and len(nominal_names) == 1:
            # One measured hole, one spec hole: nothing to choose between.
            return [(0, 0)], "only", False
        if count < 3 or len(nominal_names) < 3:
            raise RegistrationError(
                f"{count} unnamed measured hole{'s' if count != 1 else ''} cannot be matched by their mutual "
                "distances (that needs 3 or more): name each scan after its hole (file stem or --name SCAN=HOLE)")
        found = match_holes(nominal_names, nominal_centers, measured_centers)
        if len(found.tied) < 2:
            return found.pairs, "distances", found.ambiguous
        # A symmetric layout: the distances tie between turns in the plane and turned-over poses. Keep a
        # pairing that reverses the fewest trusted measured normals (the module's step 2); it is still
        # ambiguous when several do as well.
        reversals = [_reversed_trusted(pairs, nominal_centers, nominal_normals, measured_centers, measured_normals)
                     for pairs in found.tied]
        fewest = min(reversals)
        kept = [pairs for pairs, count in zip(found.tied, reversals) if count == fewest]
        return list(kept[0]), "distances", len(kept) > 1
    # Some named, some not: the named holes fix the frame, the others pair by nearness after it.
    index = {name: i for i, name in enumerate(nominal_names)}
    named_pairs = [(m, index[name]) for m, name in enumerate(measured_names) if name is not None]
    m_idx = [m for m, _ in named_pairs]
    n_idx = [n for _, n in named_pairs]
    normals, _ = _orient(nominal_centers[n_idx], nominal_normals[n_idx], measured_centers[m_idx],
                         measured_normals[m_idx])
    first = fit_rigid(nominal_centers[n_idx], nominal_normals[n_idx], measured_centers[m_idx], normals)
    if first.free_dofs:
        raise RegistrationError(
            f"the {len(named_pairs)} named holes leave the {first.free_dofs[0]} free, so the unnamed ones cannot be "
            "placed: name every scan's hole, or none")
    rest_m = [m for m in range(count) if measured_names[m] is None]
    rest_n = [n for n in range(len(nominal_names)) if n not in set(n_idx)]
    pairs = list(named_pairs)
    if rest_n:
        tolerance = None
        if len(nominal_names) >= 2:
            distances = np.linalg.norm(nominal_centers[:, None] - nominal_centers[None], axis=2)
            tolerance = 0.25 * float(distances[np.triu_indices(len(nominal_names), 1)].min())
        found = match_holes([nominal_names[n] for n in rest_n], nominal_centers[rest_n], measured_centers[rest_m],
                            initial_transform=first.transform, tolerance=tolerance)
        pairs += [(rest_m[m], rest_n[n]) for m, n in found.pairs]
    return sorted(pairs), "names+nearest", False


def register(measured_holes, nominal_spec_holes, measured_names=None, max_residual=None,
             outlier_factor=DEFAULT_OUTLIER_FACTOR, outlier_floor=0.0):
    """Register a part: the rigid transform part frame -> measuring frame from its reference holes.

    Parameters
    ----------
    measured_holes : sequence of holecli.results.Hole
        The measured holes, measuring frame (anything with ``center``, ``normal`` and ``uncertainty``
        or None).
    nominal_spec_holes : sequence of holecli.tolerance.NominalHole
        The spec's holes, part frame. Each matched hole needs a ``center`` and a ``normal``.
    measured_names : sequence of (str or None), optional
        The spec hole each measured hole is, where known (see the module's step 1).
    max_residual : float, optional
        File units: the largest in-plane or along-normal residual a used hole may have (verdict).
    outlier_factor : float
        ``factor`` of :func:`holecli.registration.find_outliers` (standard uncertainties).
    outlier_floor : float
        ``floor`` of :func:`holecli.registration.find_outliers`, file units: a hole that the others
        place at most this far from where it was measured is never an outlier.

    Returns
    -------
    Registration

    Raises
    ------
    RegistrationError
        (a ValueError) for no measured or no nominal hole, a name not in the spec or given twice, holes
        that cannot be matched (one or two unnamed holes), no hole matched, a matched spec hole
        without a normal, a bad ``max_residual``, a fit that turns the part over (every trusted
        measured normal reversed, the module's check ``normals_reversed``).
    """
    measured_holes = list(measured_holes)
    nominals = list(nominal_spec_holes)
    if not measured_holes:
        raise RegistrationError("no measured hole to register with")
    if not nominals:
        raise RegistrationError("no nominal hole to register to")
    if max_residual is not None and not (math.isfinite(max_residual) and max_residual > 0):
        raise RegistrationError(f"max_residual must be finite and > 0, got {max_residual!r}")
    nominal_names = []
    for number, nominal in enumerate(nominals, start=1):
        name = nominal.name if nominal.name is not None else f"hole {number}"
        if nominal.center is None:
            raise RegistrationError(f"spec hole {name!r} has no center")
        nominal_names.append(name)
    nominal_centers = np.array([_vector(n.center, f"the center of {name!r}") for n, name in zip(nominals, nominal_names)])
    nominal_normals = np.array([
        _vector(n.normal, f"the normal of {name!r}") if n.normal is not None else np.full(3, np.nan)
        for n, name in zip(nominals, nominal_names)])
    with np.errstate(invalid="ignore"):
        nominal_normals = nominal_normals / np.linalg.norm(nominal_normals, axis=1, keepdims=True)
    measured_centers = np.array([_vector(h.center, f"measured hole {i}'s center") for i, h in enumerate(measured_holes)])
    measured_normals = np.array([_vector(h.normal, f"measured hole {i}'s normal") for i, h in enumerate(measured_holes)])
    lengths = np.linalg.norm(measured_normals, axis=1)
    if np.any(lengths == 0):
        raise RegistrationError(f"measured hole {int(np.argmin(lengths))} has a zero normal")
    measured_normals = measured_normals / lengths[:, None]

    pairs, method, ambiguous = _match(nominal_names, nominal_centers, nominal_normals, measured_centers,
                                      measured_normals, measured_names)
    if not pairs:
        raise RegistrationError("no measured hole matches a spec hole")
    m_idx = np.array([m for m, _ in pairs])
    n_idx = np.array([n for _, n in pairs])
    names = [nominal_names[n] for n in n_idx]
    without = [name for name, n in zip(names, n_idx) if not np.all(np.isfinite(nominal_normals[n]))]
    if without:
        raise RegistrationError(f"spec hole {without[0]!r} has no normal: registration needs every matched hole's")
    nom_c, nom_n = nominal_centers[n_idx], nominal_normals[n_idx]
    mea_c = measured_centers[m_idx]
    mea_n, flipped = _orient(nom_c, nom_n, mea_c, measured_normals[m_idx])
    sigmas = _sigmas([measured_holes[m] for m in m_idx])

    check = find_outliers(fit_rigid, nom_c, nom_n, mea_c, mea_n, names=names, factor=outlier_factor,
                          floor=outlier_floor, **(sigmas or {}))
    outliers = tuple(check.outliers)
    used = np.array([name not in outliers for name in names])
    used_sigmas = None if sigmas is None else {key: value[used] for key, value in sigmas.items()}
    fit = fit_rigid(nom_c[used], nom_n[used], mea_c[used], mea_n[used], **(used_sigmas or {}))
    _check_not_turned_over([name for name, keep in zip(names, used) if keep], nom_n[used],
                           measured_normals[m_idx][used], fit.transform)
    # step 5: the final fit's holes against their own uncertainties; widened when they disagree (after the
    # turned-over check: the widened refit weighs the normals less and could hide a reversed pose)
    consistency = check_consistency(fit, [name for name, keep in zip(names, used) if keep], nom_c[used], nom_n[used],
                                    mea_c[used], mea_n[used], sigmas=used_sigmas, factor=outlier_factor,
                                    floor=outlier_floor)
    if not consistency.consistent:
        fit, added = widen(fit_rigid, nom_c[used], nom_n[used], mea_c[used], mea_n[used], used_sigmas)
        consistency = replace(consistency, added_sigma=added,
                              reason=f"{consistency.reason}; uncertainties widened: {added:.3g} added to every "
                                     "hole's center sigma, the fit repeated")
    transform = fit.transform

    # every matched hole's, the outliers' too (where the other holes place them)
    residuals = hole_residuals(transform, nom_c, nom_n, mea_c, mea_n)
    holes = tuple(
        RegisteredHole(name=names[k], measured_index=int(m_idx[k]), nominal_center=nom_c[k], nominal_normal=nom_n[k],
                       measured_center=mea_c[k], measured_normal=mea_n[k], normal_flipped=bool(flipped[k]),
                       used=bool(used[k]), outlier=not used[k], in_plane=float(residuals.in_plane[k]),
                       along_normal=float(residuals.along_normal[k]),
                       normal_angle_deg=float(residuals.normal_angle_deg[k]))
        for k in range(len(names)))

    failed = []
    verdict = None
    if max_residual is not None:
        for hole in holes:
            if hole.outlier:
                failed.append(f"{hole.name}: outlier")
                continue
            if hole.in_plane > max_residual:
                failed.append(f"{hole.name}: in_plane {hole.in_plane:.6g} > {max_residual:g}")
            if abs(hole.along_normal) > max_residual:
                failed.append(f"{hole.name}: along_normal {hole.along_normal:+.6g} exceeds {max_residual:g}")
        if not consistency.consistent:
            failed.append("inconsistent_holes")
        verdict = "fail" if failed else "pass"

    # warnings: the transform may be wrong; notes: facts that make nothing given doubtful
    warnings, notes = [], []
    if outliers:
        warnings.append(("outlier", check.reason))
    if not consistency.consistent:
        warnings.append(("inconsistent_holes", consistency.reason))
    if ambiguous:
        warnings.append(("ambiguous_match", "other pairings of the holes fit as well (a symmetric layout): "
                                            "name the scans after their holes to be sure"))
    unmatched_measured = tuple(sorted(set(range(len(measured_holes))) - set(m_idx.tolist())))
    unmatched_nominal = tuple(nominal_names[n] for n in range(len(nominals)) if n not in set(n_idx.tolist()))
    if unmatched_measured:
        notes.append(("unmatched_hole", f"{len(unmatched_measured)} measured hole(s) match no spec hole "
                                        f"(measured indices {list(unmatched_measured)}): not used"))
    if int(used.sum()) == 2 and not fit.free_dofs:
        # consistency.py's module docstring: a move of one of two holes across the line through them is a
        # rotation of the pair about the normal, which the fit absorbs whole
        first, second = (name for name, keep in zip(names, used) if keep)
        warnings.append(("unchecked_direction", f"with two holes, {first} or {second} drilled off across the line "
                                                f"through them cannot be told from a rotation of the part about "
                                                f"its normal: nothing checks that direction (register with three "
                                                f"or more holes to check every direction)"))
    if fit.free_dofs:
        warnings.append(("free_dofs", f"{len(names) - len(outliers)} hole(s) leave free: {', '.join(fit.free_dofs)}"))
    if sigmas is None:
        notes.append(("no_uncertainty", "not every hole has its own uncertainty: the fit is unweighted and its "
                                         "uncertainty comes from the residuals"))
    return Registration(
        transform=transform, fit=fit, holes=holes, match_method=method, ambiguous=bool(ambiguous),
        unmatched_measured=unmatched_measured, unmatched_nominal=unmatched_nominal, outlier_check=check,
        outliers=outliers, sigmas=sigmas is not None, max_residual=max_residual, verdict=verdict,
        failed=tuple(failed), warnings=tuple(warnings), notes=tuple(notes), consistency=consistency)
