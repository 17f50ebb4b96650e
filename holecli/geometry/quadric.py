"""The quadric of a surface around a hole: ``h(s, t)`` of second degree in a frame centred on the hole,
taken only where the surface really curves (a curved panel), and its height and gradient there."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Quadric", "curved_quadric"]

# A sag below this fraction of the hole's radius is round-off of exact data, not curvature (a curved
# panel's sag at a hole is 1e-3 of its radius or more).
_SAG_ROUND_OFF = 1e-7


@dataclass(frozen=True, eq=False)
class Quadric:
    """``h(s, t) = a + b u + c v + d u^2 + e u v + f v^2`` with ``u, v = s / scale, t / scale``."""

    coefficients: np.ndarray
    scale: float

    def height(self, st):
        u, v = st[:, 0] / self.scale, st[:, 1] / self.scale
        return np.column_stack([np.ones_like(u), u, v, u * u, u * v, v * v]) @ self.coefficients

    def gradient(self, st):
        """(dh/ds, dh/dt) at each of ``st`` (k, 2)."""
        a, b, c, d, e, f = self.coefficients
        u, v = st[:, 0] / self.scale, st[:, 1] / self.scale
        return np.column_stack([b + 2 * d * u + e * v, c + e * u + 2 * f * v]) / self.scale


def curved_quadric(local, scale, sigmas, resolution=0.0):
    """The quadric of ``local`` ((k, 3): s, t and the height, in a frame centred on a hole), or None
    when the surface is not significantly curved there: its sag at the origin within ``sigmas``
    standard errors (check ``curvature_sigmas``), within the round-off of the coordinates, or within
    the heights' ``resolution`` (a noise-free quantised face's levels lie in bands across it, which
    a quadric bends to by a fraction of a step, far beyond its standard error).

    On a flat surface a quadric's height at the center is only noisier than a plane's (its curvature
    terms are fitted to noise: about 1.7 times the spread on the Table I ring), so it is used only where
    the surface really curves.
    """
    scale = max(float(scale), 1e-300)
    if len(local) <= 6:
        return None
    s, t, h = local[:, 0] / scale, local[:, 1] / scale, np.ascontiguousarray(local[:, 2])
    # The normal equations over the six monomials' columns, not an SVD of a (k, 6) design matrix: a
    # ring holds up to 10^6 points on a dense scan (the copy would cost memory, the SVD time), the
    # coordinates are scaled to the hole (well conditioned), and the inverse is wanted anyway for the
    # standard error. Rank as numpy's lstsq judges it, on the design's singular values.
    columns = (np.ones_like(s), s, t, s * s, s * t, t * t)
    gram = np.array([[float(a @ b) for b in columns] for a in columns])
    eigenvalues = np.linalg.eigvalsh(gram)
    if not eigenvalues[0] > (np.finfo(float).eps * len(h)) ** 2 * eigenvalues[-1]:
        return None
    inverse = np.linalg.inv(gram)
    coefficients = inverse @ np.array([float(column @ h) for column in columns])
    residuals = sum(c * column for c, column in zip(coefficients, columns)) - h
    variance = float(residuals @ residuals) / (len(h) - 6)
    standard_error = np.sqrt(variance * inverse[0, 0])
    if abs(coefficients[0]) <= max(sigmas * standard_error, _SAG_ROUND_OFF * scale, resolution):
        return None
    return Quadric(coefficients=coefficients, scale=scale)
