"""A rigid transform (rotation and translation) and the propagation of its uncertainty.

A :class:`RigidTransform` maps the part (CAD) frame onto the measuring frame: ``q = R @ p + t``.

Uncertainty parametrisation
---------------------------
A 6x6 covariance of a transform refers to the parameters ``(w, dt)``, ``w`` a rotation vector in
radians applied on the left and ``dt`` a translation in file units::

    R = exp([w]x) @ R0,    t = t0 + dt

so that, to first order, a part-frame point ``p`` moves by ``w x (R0 @ p) + dt`` and a direction
``n`` by ``w x (R0 @ n)``. Entries may be ``+-inf`` where a degree of freedom is undetermined (see
:func:`holecli.registration.rigid.fit_rigid`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from holecli.errors import HoleCliError

# A rotation matrix may differ from orthonormal by this much (max abs of R^T R - I) and still count as one.
ORTHONORMAL_TOLERANCE = 1e-6


class RegistrationError(HoleCliError, ValueError):
    """The inputs of a registration step are unusable (wrong shape, too few holes, not a rotation).

    Parameters
    ----------
    message : str
        What is wrong, with the expected shape or range and the value received, as one line.
    """


def cross_matrix(vector):
    """The skew-symmetric matrix ``[v]x`` with ``[v]x @ u == np.cross(v, u)``; ``(..., 3)`` in, ``(..., 3, 3)`` out."""
    v = np.asarray(vector, dtype=np.float64)
    out = np.zeros(v.shape[:-1] + (3, 3))
    out[..., 0, 1], out[..., 0, 2] = -v[..., 2], v[..., 1]
    out[..., 1, 0], out[..., 1, 2] = v[..., 2], -v[..., 0]
    out[..., 2, 0], out[..., 2, 1] = -v[..., 1], v[..., 0]
    return out


def _check_rotation(rotation):
    rotation = np.asarray(rotation, dtype=np.float64)
    if rotation.shape != (3, 3) or not np.all(np.isfinite(rotation)):
        raise RegistrationError(f"a rotation must be a finite (3, 3) array, got shape {rotation.shape}")
    error = float(np.max(np.abs(rotation.T @ rotation - np.eye(3))))
    if error > ORTHONORMAL_TOLERANCE:
        raise RegistrationError(
            f"the rotation is not orthonormal: max |R^T R - I| = {error:.3g} > {ORTHONORMAL_TOLERANCE:g}"
        )
    det = float(np.linalg.det(rotation))
    if det < 0:
        raise RegistrationError(f"the rotation has determinant {det:.6g}, expected +1 (a reflection, not a rotation)")
    return rotation


def _check_vectors(values, name):
    values = np.asarray(values, dtype=np.float64)
    single = values.ndim == 1
    values = np.atleast_2d(values)
    if values.ndim != 2 or values.shape[1] != 3:
        raise RegistrationError(f"{name} must be a (3,) or (n, 3) array, got shape {np.shape(values)}")
    return values, single


@dataclass(frozen=True, eq=False)
class RigidTransform:
    """The rigid transform ``q = rotation @ p + translation`` (part frame to measuring frame).

    Attributes
    ----------
    rotation : (3, 3) float
        A proper rotation (orthonormal, determinant +1).
    translation : (3,) float
        In file units: where the part frame's origin lands in the measuring frame.
    """

    rotation: np.ndarray
    translation: np.ndarray

    def __post_init__(self):
        rotation = _check_rotation(self.rotation)
        translation = np.asarray(self.translation, dtype=np.float64).reshape(-1)
        if translation.shape != (3,) or not np.all(np.isfinite(translation)):
            raise RegistrationError(f"a translation must be a finite 3-vector, got {self.translation!r}")
        rotation.flags.writeable = False
        translation.flags.writeable = False
        object.__setattr__(self, "rotation", rotation)
        object.__setattr__(self, "translation", translation)

    @classmethod
    def identity(cls):
        """The transform that changes nothing."""
        return cls(np.eye(3), np.zeros(3))

    @classmethod
    def from_matrix(cls, matrix):
        """The transform of a 4x4 homogeneous matrix.

        Parameters
        ----------
        matrix : (4, 4) float
            ``[[R, t], [0, 0, 0, 1]]`` with ``R`` orthonormal of determinant +1.

        Raises
        ------
        RegistrationError
            (a ValueError) when the shape, the last row or the rotation block is wrong.
        """
        matrix = np.asarray(matrix, dtype=np.float64)
        if matrix.shape != (4, 4):
            raise RegistrationError(f"a homogeneous transform must be a (4, 4) array, got shape {matrix.shape}")
        if not np.all(np.isfinite(matrix)):
            raise RegistrationError("a homogeneous transform must be finite, got NaN or inf entries")
        if not np.allclose(matrix[3], [0.0, 0.0, 0.0, 1.0], rtol=0.0, atol=ORTHONORMAL_TOLERANCE):
            raise RegistrationError(
                f"the last row of a homogeneous transform must be 0 0 0 1, got {matrix[3].tolist()}"
            )
        return cls(matrix[:3, :3], matrix[:3, 3])

    @property
    def matrix(self):
        """(4, 4) float: the homogeneous matrix ``[[R, t], [0, 0, 0, 1]]``."""
        out = np.eye(4)
        out[:3, :3] = self.rotation
        out[:3, 3] = self.translation
        return out

    @property
    def quaternion(self):
        """(4,) float: the unit quaternion ``(w, x, y, z)`` of the rotation, scalar first, ``w >= 0``."""
        x, y, z, w = Rotation.from_matrix(self.rotation).as_quat()
        q = np.array([w, x, y, z])
        return -q if w < 0 else q

    @property
    def rotation_vector(self):
        """(3,) float: the rotation's axis times its angle, in radians."""
        return Rotation.from_matrix(self.rotation).as_rotvec()

    @property
    def roll_pitch_yaw_deg(self):
        """(3,) float: ``(roll, pitch, yaw)`` in degrees with ``R = Rz(yaw) @ Ry(pitch) @ Rx(roll)``.

        Rotations about the fixed measuring axes x (roll) first, then y (pitch), then z (yaw); equally the
        intrinsic z-y'-x'' sequence. Pitch lies in [-90, 90]; at pitch +-90 (gimbal lock) roll and yaw
        are not separable and scipy's resolution of them is returned.
        """
        yaw, pitch, roll = Rotation.from_matrix(self.rotation).as_euler("ZYX", degrees=True)
        return np.array([roll, pitch, yaw])

    def apply_points(self, points):
        """Points of the part frame in the measuring frame: ``R @ p + t``.

        Parameters
        ----------
        points : (3,) or (n, 3) float

        Returns
        -------
        ndarray of the input's shape
        """
        values, single = _check_vectors(points, "points")
        out = values @ self.rotation.T + self.translation
        return out[0] if single else out

    def apply_directions(self, directions):
        """Directions (normals, axes) of the part frame in the measuring frame: ``R @ n`` (no translation).

        Parameters
        ----------
        directions : (3,) or (n, 3) float

        Returns
        -------
        ndarray of the input's shape
        """
        values, single = _check_vectors(directions, "directions")
        out = values @ self.rotation.T
        return out[0] if single else out

    def inverse(self):
        """The transform back: measuring frame to part frame, ``p = R^T @ (q - t)``."""
        return RigidTransform(self.rotation.T, -self.rotation.T @ self.translation)

    def compose(self, other):
        """The transform that applies ``other`` first, then ``self``: ``x -> self(other(x))``.

        Parameters
        ----------
        other : RigidTransform

        Returns
        -------
        RigidTransform
            Its matrix is ``self.matrix @ other.matrix``.
        """
        return RigidTransform(self.rotation @ other.rotation, self.rotation @ other.translation + self.translation)

    def to_dict(self):
        """The transform as JSON-ready lists.

        Keys: ``matrix``, ``rotation``, ``translation``, ``quaternion_wxyz``, ``roll_pitch_yaw_deg``,
        ``rotation_vector_rad``.
        """
        return {
            "matrix": self.matrix.tolist(),
            "rotation": self.rotation.tolist(),
            "translation": self.translation.tolist(),
            "quaternion_wxyz": self.quaternion.tolist(),
            "roll_pitch_yaw_deg": self.roll_pitch_yaw_deg.tolist(),
            "rotation_vector_rad": self.rotation_vector.tolist(),
        }


def _check_covariance(covariance6):
    covariance6 = np.asarray(covariance6, dtype=np.float64)
    if covariance6.shape != (6, 6):
        raise RegistrationError(f"the transform covariance must be a (6, 6) array, got shape {covariance6.shape}")
    return covariance6


def _check_free(free_directions):
    if free_directions is None:
        return np.zeros((0, 6))
    free = np.asarray(free_directions, dtype=np.float64).reshape(-1, 6)
    if not np.all(np.isfinite(free)):
        raise RegistrationError("free_directions must be finite (k, 6) parameter vectors")
    return free


# A free parameter direction reaches a result when |J v| exceeds this fraction of |J| |v|.
_REACH_TOLERANCE = 1e-9


def _propagate(jacobian, covariance6, free_directions):
    free = _check_free(free_directions)
    if len(free) == 0 and not np.all(np.isfinite(covariance6)):
        # An infinite variance of a parameter the result does not depend on must stay out of it
        # (inf * 0 would be NaN): drop the Jacobian's zero columns; what remains is +-inf or NaN.
        used = np.any(jacobian != 0.0, axis=0)
        with np.errstate(invalid="ignore"):
            return np.einsum(
                "ia,ab,jb->ij", jacobian[:, used], covariance6[np.ix_(used, used)], jacobian[:, used]
            )
    out = jacobian @ covariance6 @ jacobian.T
    scale = np.linalg.norm(jacobian)
    for direction in free:
        reach = jacobian @ direction
        if np.linalg.norm(reach) > _REACH_TOLERANCE * scale * np.linalg.norm(direction):
            # covariance6 + lambda v v^T with lambda -> inf: +-inf wherever reach_i reach_j != 0.
            outer = np.outer(reach, reach)
            mask = np.abs(outer) > (_REACH_TOLERANCE * scale) ** 2
            out[mask] = np.inf * np.sign(outer[mask])
    return out


def point_covariance(covariance6, point, transform, free_directions=None):
    """The 3x3 covariance of a part-frame point mapped into the measuring frame.

    With the parametrisation of the module (``R = exp([w]x) R0``, ``t = t0 + dt``) the mapped point moves
    by ``-[R0 p]x w + dt``, so its covariance is ``J C J^T`` with ``J = [-[R0 p]x, I]``.

    Parameters
    ----------
    covariance6 : (6, 6) float
        Covariance of ``(w, dt)``: rotation vector in rad^2, translation in file units^2.
    point : (3,) float
        The point in the part frame.
    transform : RigidTransform
        The transform the covariance is about (``R0``, ``t0``); the rotation is needed because the
        rotation perturbation acts on ``R0 @ p``.
    free_directions : (k, 6) float, optional
        Undetermined parameter directions (:attr:`RigidFit.free_directions`); ``covariance6`` is then the
        finite, determined part (:attr:`RigidFit.covariance_determined`) and the covariance is taken as
        ``covariance6 + lambda v v^T`` with ``lambda -> inf``: results the free motion reaches are +-inf,
        the others stay finite. Without it, infinite entries of ``covariance6`` give inf or NaN.

    Returns
    -------
    (3, 3) float ndarray
        In file units^2; ``inf``/NaN entries where an undetermined degree of freedom moves the point.
    """
    covariance6 = _check_covariance(covariance6)
    values, single = _check_vectors(point, "point")
    if not single:
        raise RegistrationError(f"point must be a 3-vector, got shape {np.shape(point)}")
    rotated = transform.rotation @ values[0]
    jacobian = np.hstack([-cross_matrix(rotated), np.eye(3)])
    return _propagate(jacobian, covariance6, free_directions)


def direction_covariance(covariance6, direction, transform, free_directions=None):
    """The 3x3 covariance of a part-frame unit direction mapped into the measuring frame (rank 2, in rad^2).

    The mapped direction ``d = R0 n`` moves by ``w x d = -[d]x w``; the translation does not reach it.

    Parameters
    ----------
    covariance6 : (6, 6) float
    direction : (3,) float
        Normalised here.
    transform : RigidTransform
    free_directions : (k, 6) float, optional
        Undetermined parameter directions (:attr:`RigidFit.free_directions`); ``covariance6`` is then the
        finite, determined part (:attr:`RigidFit.covariance_determined`) and the covariance is taken as
        ``covariance6 + lambda v v^T`` with ``lambda -> inf``: results the free motion reaches are +-inf,
        the others stay finite. Without it, infinite entries of ``covariance6`` give inf or NaN.

    Returns
    -------
    (3, 3) float ndarray
    """
    covariance6 = _check_covariance(covariance6)
    values, single = _check_vectors(direction, "direction")
    norm = np.linalg.norm(values[0])
    if not single or norm == 0.0:
        raise RegistrationError(f"direction must be a non-zero 3-vector, got {direction!r}")
    rotated = transform.rotation @ (values[0] / norm)
    jacobian = np.hstack([-cross_matrix(rotated), np.zeros((3, 3))])
    return _propagate(jacobian, covariance6, free_directions)


def direction_uncertainty_deg(covariance6, direction, transform, free_directions=None):
    """The standard uncertainty, in degrees, of the angle of a mapped part-frame direction.

    It is the root mean square of the angle between the mapped direction and its true value,
    ``sqrt(trace(C))`` with ``C`` the :func:`direction_covariance` (both perpendicular components
    together, small angles). A rotation about the direction itself does not count: it leaves the
    direction in place, so an undetermined rotation about a hole's normal leaves that normal's
    uncertainty finite.

    Parameters
    ----------
    covariance6 : (6, 6) float
    direction : (3,) float
    transform : RigidTransform
    free_directions : (k, 6) float, optional
        Undetermined parameter directions (:attr:`RigidFit.free_directions`); ``covariance6`` is then the
        finite, determined part (:attr:`RigidFit.covariance_determined`) and the covariance is taken as
        ``covariance6 + lambda v v^T`` with ``lambda -> inf``: results the free motion reaches are +-inf,
        the others stay finite. Without it, infinite entries of ``covariance6`` give inf or NaN.

    Returns
    -------
    float
        Degrees; ``inf`` (or NaN) when an undetermined rotation tilts the direction.
    """
    covariance = direction_covariance(covariance6, direction, transform, free_directions)
    return float(np.degrees(np.sqrt(np.trace(covariance))))
