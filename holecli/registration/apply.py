"""Apply a registration to a spec: the nominal holes of the part frame mapped into the measuring frame.

``holecli register`` writes the transform part frame -> measuring frame with its covariance (its
JSON record, schema ``holecli.register``). :func:`parse_registration` takes that record back (as the
dict ``json.load`` gives) and :func:`map_spec` maps a :class:`holecli.tolerance.Spec`'s nominal centers
and normals with it, each nominal carrying the registration's own uncertainty at its place
(:func:`holecli.registration.point_covariance`, :func:`holecli.registration.direction_uncertainty_deg`),
which :func:`holecli.tolerance.check` adds in quadrature to the measured hole's. Pure functions: no
file is opened here.

The record keeps the 6x6 covariance with ``null`` where an entry is infinite (a free degree of
freedom) or not known; both are taken as infinite here, so a nominal that such a degree of freedom
moves gets an uncertainty not known (``inf``), never a tight one.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Optional

import numpy as np

from holecli.registration.transform import (RegistrationError, RigidTransform, direction_uncertainty_deg,
                                            point_covariance)

__all__ = ["REGISTER_SCHEMA", "LoadedRegistration", "map_spec", "parse_registration"]

# The ``schema`` of a ``holecli register`` record (holecli.cli.register.SCHEMA).
REGISTER_SCHEMA = "holecli.register"


@dataclass(frozen=True, eq=False)
class LoadedRegistration:
    """A registration read back from ``holecli register``'s JSON record.

    Attributes
    ----------
    transform : RigidTransform
        Part frame -> measuring frame.
    covariance : (6, 6) float ndarray
        Of ``(w, dt)`` (:mod:`holecli.registration.transform`); ``inf`` where the record has null.
    units : str or None
        The record's ``units`` when it names a unit (``mm``, ``m``, ``in``), else None (register's
        ``"file units of the scans and the spec"``: the scans' units, not said).
    spec_file, spec_sha256 : str or None
        The spec the registration was fitted against.
    verdict : str or None
        Its ``verdict`` (``pass``, ``fail`` or None).
    free_dofs : tuple of str
        The degrees of freedom it left undetermined.
    """

    transform: RigidTransform
    covariance: np.ndarray
    units: Optional[str] = None
    spec_file: Optional[str] = None
    spec_sha256: Optional[str] = None
    verdict: Optional[str] = None
    free_dofs: tuple = ()

    def scaled(self, factor):
        """The registration with its lengths multiplied by ``factor`` (a change of unit): the
        translation by it, the covariance's translation block by its square, the rotation-translation
        blocks by it."""
        scale = np.concatenate([np.ones(3), np.full(3, float(factor))])
        with np.errstate(invalid="ignore"):
            covariance = self.covariance * np.outer(scale, scale)
        transform = RigidTransform(self.transform.rotation, self.transform.translation * factor)
        return dataclasses.replace(self, transform=transform, covariance=covariance)


def parse_registration(data):
    """The :class:`LoadedRegistration` of a ``holecli register`` JSON record.

    Parameters
    ----------
    data : object
        The record as ``json.load`` gives it.

    Returns
    -------
    LoadedRegistration

    Raises
    ------
    RegistrationError
        With what is wrong, as one line: not a JSON object, not a ``holecli register`` record
        (``schema``), no 4x4 rigid ``transform.matrix``, no 6x6 ``uncertainty.covariance`` of numbers
        and nulls.
    """
    if not isinstance(data, dict):
        raise RegistrationError(f"not a holecli register record: expected a JSON object, got {type(data).__name__}")
    if data.get("schema") != REGISTER_SCHEMA:
        raise RegistrationError(f"not a holecli register record: \"schema\" is {data.get('schema')!r}, "
                                f"expected {REGISTER_SCHEMA!r} (write it with holecli register ... -o FILE)")
    transform = data.get("transform")
    matrix = transform.get("matrix") if isinstance(transform, dict) else None
    if not _numbers(matrix, 4, 4, nulls=False):
        raise RegistrationError("transform.matrix must be a 4x4 array of numbers")
    transform = RigidTransform.from_matrix(np.array(matrix, dtype=np.float64))
    uncertainty = data.get("uncertainty")
    covariance = uncertainty.get("covariance") if isinstance(uncertainty, dict) else None
    if not _numbers(covariance, 6, 6, nulls=True):
        raise RegistrationError("uncertainty.covariance must be a 6x6 array of numbers (null: not known)")
    covariance = np.array([[math.inf if value is None else float(value) for value in row] for row in covariance])
    if not np.all(np.diag(covariance) >= 0):
        raise RegistrationError("uncertainty.covariance has a negative variance on its diagonal")
    units = data.get("units")
    from holecli.units import UNITS

    spec = data.get("spec") if isinstance(data.get("spec"), dict) else {}
    free = data.get("free_dofs") if isinstance(data.get("free_dofs"), list) else []
    return LoadedRegistration(transform=transform, covariance=covariance,
                              units=units if units in UNITS else None,
                              spec_file=_text(spec.get("file")), spec_sha256=_text(spec.get("sha256")),
                              verdict=_text(data.get("verdict")), free_dofs=tuple(str(dof) for dof in free))


def map_spec(spec, registration, provenance=None):
    """``spec`` with its nominal holes mapped into the measuring frame by ``registration``.

    Parameters
    ----------
    spec : holecli.tolerance.Spec
        In the part frame, in the registration's units.
    registration : LoadedRegistration
    provenance : dict, optional
        What the record's ``options.tolerances.registration`` says (the file, its SHA-256, ...).

    Returns
    -------
    holecli.tolerance.Spec
        Every nominal's ``center`` mapped (``R @ c + t``) with ``center_covariance`` the
        registration's covariance at it (:func:`holecli.registration.point_covariance`), its
        ``normal`` rotated with ``normal_uncertainty_deg``
        (:func:`holecli.registration.direction_uncertainty_deg`), and ``registration`` =
        ``provenance`` (``{}`` when not given). A nominal without a center (or normal) keeps none.
    """
    holes = []
    transform, covariance = registration.transform, registration.covariance
    for hole in spec.holes:
        changes = {}
        if hole.center is not None:
            center = np.asarray(hole.center, dtype=np.float64)
            with np.errstate(invalid="ignore"):
                mapped_covariance = point_covariance(covariance, center, transform)
            changes["center"] = tuple(float(v) for v in transform.apply_points(center))
            changes["center_covariance"] = tuple(tuple(float(v) for v in row) for row in mapped_covariance)
        if hole.normal is not None:
            normal = np.asarray(hole.normal, dtype=np.float64)
            with np.errstate(invalid="ignore"):
                u_normal = direction_uncertainty_deg(covariance, normal, transform)
            changes["normal"] = tuple(float(v) for v in transform.apply_directions(normal))
            changes["normal_uncertainty_deg"] = u_normal if math.isfinite(u_normal) else math.inf
        holes.append(dataclasses.replace(hole, **changes))
    return dataclasses.replace(spec, holes=tuple(holes), registration=dict(provenance or {}))


def _numbers(rows, count, size, nulls):
    """Whether ``rows`` is ``count`` lists of ``size`` finite numbers (or None, with ``nulls``)."""
    if not isinstance(rows, list) or len(rows) != count:
        return False
    for row in rows:
        if not isinstance(row, list) or len(row) != size:
            return False
        for value in row:
            if value is None and nulls:
                continue
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
                return False
    return True


def _text(value):
    return value if isinstance(value, str) else None
