"""The bend: the map from the sheet frame ``(u, v, w)`` to the world, flat, convex or concave."""

from __future__ import annotations

import math

import numpy as np


class _Bend:
    """Sheet frame (u, v, w) to world and back; flat when radius is None."""

    def __init__(self, curvature, radius):
        self.flat = curvature == "flat"
        self.R = None if self.flat else float(radius)
        self.sign = {"flat": 0.0, "convex": 1.0, "concave": -1.0}[curvature]

    def to3d(self, u, v, w):
        u, v, w = (np.asarray(a, dtype=np.float64) for a in (u, v, w))
        if self.flat:
            return np.stack(np.broadcast_arrays(u, v, -w), axis=-1)
        s, R = self.sign, self.R
        phi, rho = u / R, R - s * w
        return np.stack(np.broadcast_arrays(rho * np.sin(phi), v, s * rho * np.cos(phi) - s * R), axis=-1)

    def to2d(self, x):
        x = np.asarray(x, dtype=np.float64)
        if self.flat:
            return x[..., 0], x[..., 1], -x[..., 2]
        s, R = self.sign, self.R
        dx, dz = x[..., 0], x[..., 2] + s * R
        return R * np.arctan2(dx, s * dz), x[..., 1], s * (R - np.hypot(dx, dz))

    def frame(self, u):
        """Unit vectors e_u, e_v and the top normal n = e_u x e_v at arc coordinate u."""
        if self.flat:
            return np.array([1.0, 0, 0]), np.array([0, 1.0, 0]), np.array([0, 0, 1.0])
        s, phi = self.sign, u / self.R
        return (np.array([math.cos(phi), 0.0, -s * math.sin(phi)]), np.array([0, 1.0, 0]),
                np.array([s * math.sin(phi), 0.0, math.cos(phi)]))

    def hit(self, a, b, w, guess):
        """Parameters s with a + s b on the surface at depth w, the root nearest ``guess``.

        a, b : (k, 3) float; returns (k,) float.
        """
        if self.flat:
            return (-w - a[:, 2]) / b[:, 2]
        s, R = self.sign, self.R
        p = np.stack([a[:, 0], a[:, 2] + s * R], axis=1)
        q = np.stack([b[:, 0], b[:, 2]], axis=1)
        qa, qb = np.sum(q * q, axis=1), np.sum(p * q, axis=1)
        qc = np.sum(p * p, axis=1) - (R - s * w) ** 2
        root = np.sqrt(np.maximum(qb * qb - qa * qc, 0.0))
        s1, s2 = (-qb - root) / qa, (-qb + root) / qa
        return np.where(np.abs(s1 - guess) < np.abs(s2 - guess), s1, s2)
