"""The rigid transform part (CAD) frame -> measuring frame from matched holes.

Model: ``measured = R @ nominal + t`` for every hole's center, and ``measured_normal = R @ nominal_normal``.
The fit starts from a weighted Kabsch (Umeyama without scale) on the centers, the normals joined in as
directions, then refines by Gauss-Newton the weighted sum of squares

    sum_i r_i^T S_i^-1 r_i + sum_i |m_i - R n_i|^2 / sigma_n^2,

``r_i`` the center residual, ``S_i = sigma_inplane^2 (I - m m^T) + sigma_normal^2 m m^T`` (``m`` the
measured normal: a hole's center is usually better known across its axis than along it) and ``sigma_n``
the normal's angular sigma in radians. Normals must be oriented alike in both frames (both out of the
material, say): a flipped normal is a 180 degree residual, not a match.

Covariance parameters are ``(w, dt)``: ``R = exp([w]x) R0``, ``t = t0 + dt`` (see :mod:`.transform`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from holecli.registration.transform import (
    RegistrationError,
    RigidTransform,
    cross_matrix,
    direction_uncertainty_deg,
    point_covariance,
)

# Gauss-Newton: at most this many iterations; stop when the step's rotation (rad) and translation
# (relative to the holes' spread) are both below STEP_TOLERANCE.
MAX_ITERATIONS = 20
STEP_TOLERANCE = 1e-13
# An eigenvalue of the (Jacobi-scaled) normal matrix below this fraction of the largest marks an
# undetermined degree of freedom.
RANK_TOLERANCE = 1e-10
# Holes count as collinear when their second principal spread is below this fraction of the first.
COLLINEAR_TOLERANCE = 1e-9

# Without sigmas, the normals' weight relative to the centers is estimated from the residuals (variance
# components) in at most VARIANCE_ROUNDS fits, stopping when the ratio changes by less than
# VARIANCE_RATIO_TOLERANCE; a group with less redundancy than MIN_REDUNDANCY keeps the start weight.
VARIANCE_ROUNDS = 8
VARIANCE_RATIO_TOLERANCE = 0.01
MIN_REDUNDANCY = 1.0

ROTATION_ABOUT_NORMAL = "rotation about the normal"
ROTATION_ABOUT_LINE = "rotation about the line through the holes"


@dataclass(frozen=True, eq=False)
class HoleResiduals:
    """Per-hole residuals of a rigid fit, in the measuring frame.

    Attributes
    ----------
    vector : (n, 3) float
        ``measured_center - (R @ nominal_center + t)``, file units.
    in_plane : (n,) float
        Magnitude of the residual across the measured normal.
    along_normal : (n,) float
        Signed component along the measured normal.
    normal_angle_deg : (n,) float
        Angle between the measured normal and ``R @ nominal_normal``, degrees.
    """

    vector: np.ndarray
    in_plane: np.ndarray
    along_normal: np.ndarray
    normal_angle_deg: np.ndarray

    @property
    def magnitude(self):
        """(n,) float: length of each center residual."""
        return np.linalg.norm(self.vector, axis=1)


def hole_residuals(transform, nominal_centers, nominal_normals, measured_centers, measured_normals):
    """The residuals of measured holes from nominal ones mapped by ``transform``.

    Parameters
    ----------
    transform : RigidTransform
        Part frame -> measuring frame.
    nominal_centers, nominal_normals : (n, 3) float
        Part frame (unit normals).
    measured_centers, measured_normals : (n, 3) float
        Measuring frame (unit normals).

    Returns
    -------
    HoleResiduals
    """
    vector = measured_centers - transform.apply_points(nominal_centers)
    along = np.sum(vector * measured_normals, axis=1)
    in_plane = np.linalg.norm(vector - along[:, None] * measured_normals, axis=1)
    predicted = transform.apply_directions(nominal_normals)
    sine = np.linalg.norm(np.cross(predicted, measured_normals), axis=1)
    angle = np.degrees(np.arctan2(sine, np.sum(predicted * measured_normals, axis=1)))
    return HoleResiduals(vector, in_plane, along, angle)


def kabsch_points(source, target):
    """The rigid transform taking ``source`` onto ``target`` (unweighted Kabsch, centres then SVD).

    Parameters
    ----------
    source, target : (n, 3) float

    Returns
    -------
    rotation : (3, 3) float
    translation : (3,) float
    """
    source_mean, target_mean = source.mean(axis=0), target.mean(axis=0)
    u, _, vt = np.linalg.svd((source - source_mean).T @ (target - target_mean))
    d = np.sign(np.linalg.det(vt.T @ u.T)) or 1.0
    rotation = vt.T @ np.diag([1.0, 1.0, d]) @ u.T
    return rotation, target_mean - rotation @ source_mean


@dataclass(frozen=True, eq=False)
class RigidFit:
    """A rigid transform fitted to matched holes, with its quality and uncertainty.

    Attributes
    ----------
    transform : RigidTransform
        Part frame -> measuring frame.
    covariance : (6, 6) float
        Of ``(w, dt)``, rad^2 and file units^2 (module docstring). ``+-inf`` in the rows and columns an
        undetermined degree of freedom reaches (the limit of ``C + lambda v v^T``, ``lambda -> inf``);
        all NaN when it was to come from the residuals and there are none (``dof == 0``).
    covariance_determined : (6, 6) float
        The finite part: the pseudo-inverse of the normal matrix on its determined subspace (same
        scaling as ``covariance``).
    free_directions : (k, 6) float
        Unit parameter vectors of the undetermined degrees of freedom.
    free_dofs : tuple of str
        Their names: ``"rotation about the normal"`` (one hole) or ``"rotation about the line through
        the holes"`` (collinear holes whose normals are parallel to that line).
    residuals : HoleResiduals
    rms : float
        Root mean square of the center residual magnitudes, file units.
    dof : int
        Residual components (3 per center, 2 per normal) minus the determined parameters.
    covariance_source : str
        ``"sigmas"`` (propagated from the given sigmas) or ``"residuals"`` (scaled by the residual
        variance per degree of freedom).
    chi2 : float
        The weighted sum of squares at the solution.
    iterations : int
        Gauss-Newton iterations run.
    """

    transform: RigidTransform
    covariance: np.ndarray
    covariance_determined: np.ndarray
    free_directions: np.ndarray
    free_dofs: tuple
    residuals: HoleResiduals
    rms: float
    dof: int
    covariance_source: str
    chi2: float
    iterations: int

    def point_covariance(self, point):
        """(3, 3) covariance, in the measuring frame, of a part-frame point mapped by the fit."""
        return point_covariance(self.covariance_determined, point, self.transform, self.free_directions)

    def direction_uncertainty_deg(self, direction):
        """Standard angular uncertainty, degrees, of a part-frame direction mapped by the fit."""
        return direction_uncertainty_deg(self.covariance_determined, direction, self.transform, self.free_directions)


def _as_points(values, name, count=None):
    values = np.asarray(values, dtype=np.float64)
    if values.ndim != 2 or values.shape[1] != 3:
        raise RegistrationError(f"{name} must be an (n, 3) array, got shape {values.shape}")
    if count is not None and len(values) != count:
        raise RegistrationError(f"{name} must hold {count} rows (one per hole), got {len(values)}")
    if not np.all(np.isfinite(values)):
        raise RegistrationError(f"{name} must be finite")
    return values


def _as_normals(values, name, count):
    values = _as_points(values, name, count)
    norms = np.linalg.norm(values, axis=1)
    if np.any(norms == 0.0):
        raise RegistrationError(f"{name} must not hold zero vectors (row {int(np.argmin(norms))})")
    return values / norms[:, None]


def _as_sigma(value, name, count):
    sigma = np.asarray(value, dtype=np.float64)
    if sigma.ndim == 0:
        sigma = np.full(count, float(sigma))
    if sigma.shape != (count,):
        raise RegistrationError(f"{name} must be a scalar or ({count},), got shape {sigma.shape}")
    if not np.all(np.isfinite(sigma)) or np.any(sigma <= 0):
        raise RegistrationError(f"{name} must be finite and > 0, got {sigma.tolist()}")
    return np.array(sigma, dtype=np.float64)


def _shortest_rotation(a, b):
    """The rotation by the smallest angle taking unit ``a`` onto unit ``b``."""
    axis = np.cross(a, b)
    sine, cosine = np.linalg.norm(axis), float(a @ b)
    if sine < 1e-15:
        if cosine > 0:
            return np.eye(3)
        # Opposite: half a turn about any axis perpendicular to a.
        perpendicular = np.cross(a, np.eye(3)[np.argmin(np.abs(a))])
        return Rotation.from_rotvec(np.pi * perpendicular / np.linalg.norm(perpendicular)).as_matrix()
    return Rotation.from_rotvec(axis / sine * np.arctan2(sine, cosine)).as_matrix()


def _kabsch(nominal, measured, weights, nominal_dirs, measured_dirs, dir_weights):
    """Weighted Kabsch on centred points plus directions.

    When the cross-covariance has rank one (one hole; collinear holes with normals along their line),
    only one direction pair is defined and the shortest rotation between them is returned.
    """
    cross = (nominal * weights[:, None]).T @ measured + (nominal_dirs * dir_weights[:, None]).T @ measured_dirs
    u, s, vt = np.linalg.svd(cross)
    if s[0] == 0.0:
        return np.eye(3)
    if s[1] <= COLLINEAR_TOLERANCE * s[0]:
        return _shortest_rotation(u[:, 0], vt[0])
    d = np.sign(np.linalg.det(vt.T @ u.T)) or 1.0
    return vt.T @ np.diag([1.0, 1.0, d]) @ u.T


def _is_collinear(points):
    centred = points - points.mean(axis=0)
    s = np.linalg.svd(centred, compute_uv=False) if len(points) > 1 else np.zeros(1)
    return len(points) < 3 or s[1] <= COLLINEAR_TOLERANCE * max(s[0], 1e-300)


def _residuals_and_jacobian(rotation, shift, nominal, nominal_normals, measured, measured_normals):
    """Center residuals (n, 3), normal residuals (n, 3) and their Jacobians (n, 3, 6) w.r.t. (w, dt)."""
    rotated = nominal @ rotation.T
    rotated_normals = nominal_normals @ rotation.T
    center_res = measured - rotated - shift
    normal_res = measured_normals - rotated_normals
    n = len(nominal)
    # d(R p)/dw = -[R p]x: the residual moves by +[R p]x w - dt.
    center_jac = np.concatenate([cross_matrix(rotated), np.broadcast_to(-np.eye(3), (n, 3, 3))], axis=2)
    normal_jac = np.concatenate([cross_matrix(rotated_normals), np.zeros((n, 3, 3))], axis=2)
    return center_res, normal_res, center_jac, normal_jac


def _normal_equations(center_res, normal_res, center_jac, normal_jac, center_weights, normal_weights):
    hessian = np.einsum("nia,nij,njb->ab", center_jac, center_weights, center_jac)
    hessian += np.einsum("n,nia,nib->ab", normal_weights, normal_jac, normal_jac)
    gradient = np.einsum("nia,nij,nj->a", center_jac, center_weights, center_res)
    gradient += np.einsum("n,nia,ni->a", normal_weights, normal_jac, normal_res)
    chi2 = float(
        np.einsum("ni,nij,nj->", center_res, center_weights, center_res)
        + normal_weights @ np.sum(normal_res**2, axis=1)
    )
    return hessian, gradient, chi2


def _decompose(hessian):
    """Jacobi-scaled eigen-decomposition: (pseudo-inverse on the determined subspace, free unit directions)."""
    diagonal = np.sqrt(np.maximum(np.diag(hessian), 1e-300))
    scaled = hessian / np.outer(diagonal, diagonal)
    values, vectors = np.linalg.eigh(scaled)
    determined = values > RANK_TOLERANCE * values.max()
    inverse_scaled = (vectors[:, determined] / values[determined]) @ vectors[:, determined].T
    pseudo_inverse = inverse_scaled / np.outer(diagonal, diagonal)
    free = vectors[:, ~determined] / diagonal[:, None]
    free = free / np.linalg.norm(free, axis=0)
    return pseudo_inverse, free.T


def _gauss_newton(rotation, shift, data, center_weights, normal_weights, lever):
    iterations = 0
    for iterations in range(1, MAX_ITERATIONS + 1):
        terms = _residuals_and_jacobian(rotation, shift, *data)
        hessian, gradient, _ = _normal_equations(*terms, center_weights, normal_weights)
        pseudo_inverse, _ = _decompose(hessian)
        # The model's Jacobian is -J (J the residuals'): the step is -(J^T W J)^+ J^T W r.
        step = -pseudo_inverse @ gradient
        rotation = Rotation.from_rotvec(step[:3]).as_matrix() @ rotation
        shift = shift + step[3:]
        if np.linalg.norm(step[:3]) < STEP_TOLERANCE and np.linalg.norm(step[3:]) < STEP_TOLERANCE * lever:
            break
    return rotation, shift, iterations


def _variance_ratio(rotation, shift, data, center_weights, normal_weights):
    """Normals' over centers' variance factor (Foerstner's variance components), or None if not estimable.

    Each group's factor is its weighted sum of squares over its redundancy ``m_g - trace(H^+ H_g)``.
    """
    center_res, normal_res, center_jac, normal_jac = _residuals_and_jacobian(rotation, shift, *data)
    count = len(center_res)
    zero = np.zeros(count)
    hessian_c, _, chi2_c = _normal_equations(center_res, normal_res, center_jac, normal_jac, center_weights, zero)
    hessian_n, _, chi2_n = _normal_equations(
        center_res, normal_res, center_jac, normal_jac, np.zeros_like(center_weights), normal_weights
    )
    pseudo_inverse, _ = _decompose(hessian_c + hessian_n)
    redundancy_c = 3 * count - np.trace(pseudo_inverse @ hessian_c)
    redundancy_n = 2 * count - np.trace(pseudo_inverse @ hessian_n)
    if min(redundancy_c, redundancy_n) < MIN_REDUNDANCY or chi2_c <= 0 or chi2_n <= 0:
        return None
    return (chi2_n / redundancy_n) / (chi2_c / redundancy_c)


def fit_rigid(
    nominal_centers,
    nominal_normals,
    measured_centers,
    measured_normals,
    center_sigma_inplane=None,
    center_sigma_normal=None,
    normal_sigma_deg=None,
):
    """Fit the rigid transform part frame -> measuring frame to matched holes.

    Parameters
    ----------
    nominal_centers, measured_centers : (n, 3) float
        Hole centers in the part (CAD) frame and in the measuring frame, row ``i`` the same hole.
    nominal_normals, measured_normals : (n, 3) float
        Hole axes, oriented alike in both frames; normalised here.
    center_sigma_inplane : float or (n,) float, optional
        Standard uncertainty of each measured center across its normal, file units.
    center_sigma_normal : float or (n,) float, optional
        Along its normal; defaults to ``center_sigma_inplane`` (and the other way round).
    normal_sigma_deg : float or (n,) float, optional
        Standard uncertainty of each measured normal, degrees, per perpendicular component. Without it
        the normals weigh as ``sigma_center / L`` radians, ``L`` the rms distance of the nominal
        centers from their mean (1 radian for a single hole): a normal then counts like the centers'
        lever arm. Needs a center sigma, which fixes the units of the weights.

    Returns
    -------
    RigidFit
        When a center sigma is given the covariance is the inverse of the weighted normal matrix
        ``J^T W J`` (``covariance_source == "sigmas"``). Otherwise every center weighs 1, the normals'
        weight relative to the centers is re-estimated from the two groups' residuals (variance
        components: each group's weighted sum of squares over its redundancy, iterated; kept at the
        start value above when a group has less than one redundant component or no residual), and the
        covariance is the inverse times ``chi2 / dof``, the residual variance per degree of freedom
        (``covariance_source == "residuals"``); all NaN when ``dof == 0``. Within a group the weights
        are then taken as right up to that group's scale.

    Raises
    ------
    RegistrationError
        (a ValueError) on mismatched shapes, non-finite values, zero normals or bad sigmas.

    Notes
    -----
    Undetermined degrees of freedom are reported in ``free_dofs`` rather than raised:

    * one hole: the center fixes the position, the normal two rotations; the rotation about the
      normal stays free and the result keeps the shortest rotation taking the nominal normal onto the
      measured one.
    * two holes, or three and more on one line: the normals fix the rotation about that line unless
      they are all parallel to it; then it stays free and the result keeps the shortest rotation
      taking the nominal line onto the measured one.

    The refinement's steps (the pseudo-inverse's) have no component along a free direction, so the
    start's choice stays (exactly so without noise). Its covariance is ``+-inf`` where it reaches
    (see :class:`RigidFit`).
    """
    nominal_centers = _as_points(nominal_centers, "nominal_centers")
    count = len(nominal_centers)
    if count == 0:
        raise RegistrationError("fit_rigid needs at least one hole, got 0")
    measured_centers = _as_points(measured_centers, "measured_centers", count)
    nominal_normals = _as_normals(nominal_normals, "nominal_normals", count)
    measured_normals = _as_normals(measured_normals, "measured_normals", count)

    if center_sigma_inplane is None and center_sigma_normal is None:
        if normal_sigma_deg is not None:
            raise RegistrationError("normal_sigma_deg needs center_sigma_inplane (the ratio fixes the weights)")
        source = "residuals"
        sigma_inplane = sigma_normal = np.ones(count)
    else:
        source = "sigmas"
        first = center_sigma_inplane if center_sigma_inplane is not None else center_sigma_normal
        second = center_sigma_normal if center_sigma_normal is not None else center_sigma_inplane
        sigma_inplane = _as_sigma(first, "center_sigma_inplane", count)
        sigma_normal = _as_sigma(second, "center_sigma_normal", count)

    # Centre both sets: rotations about the centroids are well conditioned whatever the origin.
    nominal_mean = nominal_centers.mean(axis=0)
    measured_mean = measured_centers.mean(axis=0)
    nominal_local = nominal_centers - nominal_mean
    measured_local = measured_centers - measured_mean
    spread = float(np.sqrt(np.mean(np.sum(nominal_local**2, axis=1))))
    lever = spread if spread > 0 else 1.0

    if normal_sigma_deg is None:
        center_scale = np.sqrt((2 * sigma_inplane**2 + sigma_normal**2) / 3)
        normal_sigma = center_scale / lever if spread > 0 else np.ones(count)
    else:
        normal_sigma = np.radians(_as_sigma(normal_sigma_deg, "normal_sigma_deg", count))

    outer = np.einsum("ni,nj->nij", measured_normals, measured_normals)
    center_weights = (np.eye(3) - outer) / sigma_inplane[:, None, None] ** 2 + outer / sigma_normal[:, None, None] ** 2
    normal_weights = 1.0 / normal_sigma**2

    isotropic = 3.0 / (2 * sigma_inplane**2 + sigma_normal**2)
    rotation = _kabsch(nominal_local, measured_local, isotropic, nominal_normals, measured_normals, normal_weights)
    shift = np.zeros(3)  # translation in the centred frames
    data = (nominal_local, nominal_normals, measured_local, measured_normals)

    iterations = 0
    for _ in range(VARIANCE_ROUNDS if source == "residuals" else 1):
        rotation, shift, steps = _gauss_newton(rotation, shift, data, center_weights, normal_weights, lever)
        iterations += steps
        if source != "residuals":
            break
        ratio = _variance_ratio(rotation, shift, data, center_weights, normal_weights)
        if ratio is None or abs(ratio - 1.0) < VARIANCE_RATIO_TOLERANCE:
            break
        normal_weights = normal_weights / ratio

    terms = _residuals_and_jacobian(rotation, shift, *data)
    hessian, _, chi2 = _normal_equations(*terms, center_weights, normal_weights)
    pseudo_inverse, free = _decompose(hessian)

    # Back to the part's own origin: t = measured_mean + shift - R nominal_mean, so a rotation
    # perturbation w moves t by [R nominal_mean]x w (the local parameters (w, dt') -> (w, dt)).
    translation = measured_mean + shift - rotation @ nominal_mean
    to_global = np.eye(6)
    to_global[3:, :3] = cross_matrix(rotation @ nominal_mean)
    covariance_determined = to_global @ pseudo_inverse @ to_global.T
    free_global = (to_global @ free.T).T
    if len(free_global):
        free_global = free_global / np.linalg.norm(free_global, axis=1, keepdims=True)

    determined = 6 - len(free_global)
    dof = 3 * count + 2 * count - determined
    if source == "residuals":
        covariance_determined = covariance_determined * (chi2 / dof) if dof > 0 else np.full((6, 6), np.nan)

    covariance = covariance_determined.copy()
    for direction in free_global if np.all(np.isfinite(covariance)) else ():
        mask = np.abs(np.outer(direction, direction)) > 1e-12
        covariance[mask] = np.inf * np.sign(np.outer(direction, direction)[mask])

    if len(free_global) == 0:
        free_dofs = ()
    elif count == 1 and len(free_global) == 1:
        free_dofs = (ROTATION_ABOUT_NORMAL,)
    elif _is_collinear(nominal_centers) and len(free_global) == 1:
        free_dofs = (ROTATION_ABOUT_LINE,)
    else:
        free_dofs = tuple(f"undetermined parameter direction {np.round(v, 6).tolist()}" for v in free_global)

    transform = RigidTransform(rotation, translation)
    residuals = hole_residuals(transform, nominal_centers, nominal_normals, measured_centers, measured_normals)
    rms = float(np.sqrt(np.mean(np.sum(residuals.vector**2, axis=1))))
    return RigidFit(
        transform=transform,
        covariance=covariance,
        covariance_determined=covariance_determined,
        free_directions=free_global.reshape(-1, 6),
        free_dofs=free_dofs,
        residuals=residuals,
        rms=rms,
        dof=int(dof),
        covariance_source=source,
        chi2=chi2,
        iterations=iterations,
    )
