"""Registration: the rigid transform part (CAD) frame -> measuring frame from the part's reference holes.

:mod:`.transform` holds the transform and the propagation of its uncertainty, :mod:`.rigid` the fit
to matched holes, :mod:`.matching` the pairing of measured holes with nominal ones and the
leave-one-out outlier check, :mod:`.consistency` the test of the holes against their
uncertainties (any count from two), :mod:`.register` the whole registration (match, fit, outlier check,
verdict) of measured holes to a spec's nominal holes.
"""

from holecli.registration.transform import (
    RegistrationError,
    RigidTransform,
    direction_covariance,
    direction_uncertainty_deg,
    point_covariance,
)
from holecli.registration.rigid import HoleResiduals, RigidFit, fit_rigid
from holecli.registration.matching import HoleMatch, OutlierCheck, find_outliers, match_holes
from holecli.registration.consistency import ConsistencyCheck, check_consistency
from holecli.registration.register import RegisteredHole, Registration, register

__all__ = [
    "ConsistencyCheck",
    "HoleMatch",
    "HoleResiduals",
    "OutlierCheck",
    "RegisteredHole",
    "Registration",
    "RegistrationError",
    "RigidFit",
    "RigidTransform",
    "check_consistency",
    "direction_covariance",
    "direction_uncertainty_deg",
    "find_outliers",
    "fit_rigid",
    "match_holes",
    "point_covariance",
    "register",
]
