"""One least-squares toolkit for the geometric fits: a Levenberg-Marquardt solver, the trimmed refit
around it, and the covariance of the fitted parameters.

The circle (:mod:`holecli.geometry.circle`), the cylinder and the cone (:mod:`holecli.geometry.revolution`)
are fitted by the same three pieces:

* :func:`levenberg_marquardt` minimises ``sum(residuals(p)^2)`` from a start, with an analytic Jacobian
  or the forward differences of :func:`forward_difference`;
* :func:`trimmed_refit` repeats a fit on the points within ``clip`` robust standard deviations of
  its residuals until the kept set stops changing (stray points of another surface, reflections);
* :func:`covariance` is ``s^2 (J^T J)^-1`` with ``s^2`` the residuals' variance on ``n - p`` degrees
  of freedom.

Numpy only: importing scipy.optimize costs the command line about half a second.
"""

from __future__ import annotations

import numpy as np

from holecli.geometry.kernels import robust_sigma

__all__ = ["covariance", "forward_difference", "gauss_newton", "levenberg_marquardt", "trimmed_refit"]


def forward_difference(residuals, steps):
    """The forward-difference Jacobian of ``residuals``, one step per parameter.

    Parameters
    ----------
    residuals : callable
        ``residuals(p) -> (n,) float``.
    steps : sequence of float
        The step of each parameter.

    Returns
    -------
    callable
        ``jacobian(p, f) -> (n, len(steps)) float``, ``f`` being ``residuals(p)`` (already computed).
    """
    def jacobian(p, f):
        out = np.empty((len(f), len(p)))
        for k, step in enumerate(steps):
            shifted = np.array(p, dtype=np.float64)
            shifted[k] += step
            out[:, k] = (residuals(shifted) - f) / step
        return out

    return jacobian


def levenberg_marquardt(residuals, start, jacobian, *, iterations=200, tolerance=1e-14, stop="step"):
    """Minimise ``sum(residuals(p)^2)`` from ``start`` (Levenberg-Marquardt).

    Marquardt's diagonal scaling, as MINPACK's ``lmder`` (scipy's ``least_squares(method="lm")``) does:
    each iteration solves ``(J^T J + lambda diag(J^T J)) step = -J^T r``, accepts a step that does not
    raise the cost (then ``lambda / 10``) and otherwise tries again at ``10 lambda``. It stops

    * ``stop="step"``: when the step falls below ``tolerance`` relative to the parameters, or no
      step lowers the cost any more, or lambda passes 1e16 (the flat valley of a short arc is
      followed to its bottom, not left where the decrease first gets small: the circle);
    * ``stop="decrease"``: when the cost's relative decrease falls to ``tolerance`` or 12 tries
      find no lower cost (a forward-difference Jacobian, whose round-off leaves the last steps
      meaningless: the cylinder and the cone).

    Parameters
    ----------
    residuals : callable
        ``residuals(p) -> (n,) float``.
    start : (k,) float
    jacobian : callable
        ``jacobian(p, f) -> (n, k) float`` at ``p`` with ``f = residuals(p)``: analytic, or
        :func:`forward_difference`.
    iterations : int
        Most iterations.
    tolerance : float
        Of the step (``"step"``) or of the cost's relative decrease (``"decrease"``).
    stop : {"step", "decrease"}

    Returns
    -------
    (k,) float
    """
    if stop not in ("step", "decrease"):
        raise ValueError(f"stop must be 'step' or 'decrease', got {stop!r}")
    by_step = stop == "step"
    p = np.array(start, dtype=np.float64)
    f = residuals(p)
    cost = float(f @ f)
    damping = 1e-3
    for _ in range(iterations):
        jac = jacobian(p, f)
        normal = jac.T @ jac
        gradient = jac.T @ f
        diagonal = np.maximum(np.diag(normal), 1e-300) if by_step else np.diag(normal) + 1e-300
        improved = False
        for _ in range(10 ** 6 if by_step else 12):
            try:
                step = np.linalg.solve(normal + damping * np.diag(diagonal), -gradient)
            except np.linalg.LinAlgError:
                if not by_step:
                    damping *= 10.0
                    continue
                step = np.zeros(len(p))
            trial = p + step
            trial_f = residuals(trial)
            trial_cost = float(trial_f @ trial_f)
            if (trial_cost <= cost) if by_step else (np.isfinite(trial_cost) and trial_cost <= cost):
                improved = True
                break
            damping *= 10.0
            if by_step and damping > 1e16:
                return p
        if not improved:
            break
        decrease = cost - trial_cost
        p, f, cost = trial, trial_f, trial_cost
        if by_step:
            damping = max(damping / 10.0, 1e-16)
            if (np.max(np.abs(step)) <= tolerance * (1.0 + np.max(np.abs(p)))
                    or (decrease == 0.0 and damping < 1e-12)):
                break
        else:
            damping = max(damping / 10.0, 1e-12)
            if decrease <= tolerance * max(cost, 1e-300):
                break
    return p


def gauss_newton(residuals, start, jacobian, *, iterations=50, tolerance=1e-13, converged=None):
    """Minimise ``sum(residuals(p)^2)`` from a start already near the minimum (Gauss-Newton).

    Each step is the least-squares solution (``numpy.linalg.lstsq``) of ``J step = -r``, taken
    undamped; it stops when every component of the step is below ``tolerance`` (or as ``converged``
    says). The rounds of a
    trimmed circle fit (:func:`holecli.geometry.circle.fit_circle_robust`) start each from the previous
    round's circle, where this needs a step or two; :func:`levenberg_marquardt` reaches the same
    minimum but not to the last bits (the figures of the sample clouds moved by up to 2e-8 relative).

    Parameters
    ----------
    residuals, start, jacobian
        As for :func:`levenberg_marquardt`.
    iterations : int
        Most steps.
    tolerance : float
        Of the step's largest component (absolute, in the parameters' units).
    converged : callable, optional
        ``converged(p, step) -> bool``, asked after each step (``p`` the parameters it was taken
        from) instead of ``tolerance``: a test relative to the model's size.

    Returns
    -------
    (k,) float
    """
    p = np.array(start, dtype=np.float64)
    for _ in range(iterations):
        f = residuals(p)
        step, *_ = np.linalg.lstsq(jacobian(p, f), -f, rcond=None)
        done = np.max(np.abs(step)) < tolerance if converged is None else converged(p, step)
        p = p + step
        if done:
            break
    return p


def trimmed_refit(fit, residuals, start, *, clip, floor, rounds, minimum, refit_last=False):
    """A fit repeated on the points within ``clip`` robust sigmas of its residuals until they stay.

    The first round already leaves out what lies far from the starting model: a good start then keeps
    a neighbouring surface's points from pulling the first fit into a wrong minimum that trimming
    after it would no longer leave. Each round fits the kept points, takes the residual scale as
    :func:`holecli.geometry.kernels.robust_sigma` of the kept points' residuals (never below
    ``floor``) and keeps the points within ``clip`` times it; it stops when the kept set no longer
    changes or would hold fewer than ``minimum`` points.

    Parameters
    ----------
    fit : callable
        ``fit(p, kept) -> p``: the model fitted to the points ``kept`` (bool mask) from ``p``.
    residuals : callable
        ``residuals(p) -> (n,) float`` of every point.
    start : (k,) float
    clip : float
        Trimming threshold, in robust standard deviations.
    floor : float
        Smallest residual scale (the points' noise; keeps noise-free data from trimming round-off).
    rounds : int
        Most fitting rounds.
    minimum : int
        Fewest points kept (else every point is, at the start, or the last set stays).
    refit_last : bool
        Fit the last kept set at the end when it was not fitted (``rounds`` ran out, or is 0); when
        the rounds stopped because the kept set stayed, ``p`` is already its fit.

    Returns
    -------
    p : (k,) float
    kept : (n,) bool
    """
    p = np.array(start, dtype=np.float64)
    residual = residuals(p)
    kept = np.abs(residual) <= clip * max(robust_sigma(residual), floor)
    if np.count_nonzero(kept) < minimum:
        kept = np.ones(len(residual), dtype=bool)
    fitted = False  # whether p is the fit of the kept set
    for _ in range(rounds):
        p = fit(p, kept)
        residual = residuals(p)
        new_kept = np.abs(residual) <= clip * max(robust_sigma(residual[kept]), floor)
        if np.count_nonzero(new_kept) < minimum or np.array_equal(new_kept, kept):
            fitted = True
            break
        kept = new_kept
    if refit_last and not fitted:
        p = fit(p, kept)
    return p, kept


def covariance(jacobian, residuals):
    """The least-squares covariance ``s^2 (J^T J)^-1`` of fitted parameters.

    ``s^2 = sum(r^2) / (n - p)`` is the residuals' variance on ``n - p`` degrees of freedom. The
    residuals may be scaled (divided by a known scale, as for a scipy ``least_squares`` fit of
    ``r / scale``: pass its ``jac`` and ``fun``); the covariance is then in the parameters' units
    all the same, the scale cancelling.

    Parameters
    ----------
    jacobian : (n, p) float
        The residuals' Jacobian at the solution.
    residuals : (n,) float
        The residuals at the solution.

    Returns
    -------
    (p, p) float or None
        None with ``n <= p`` points or a singular ``J^T J``.
    """
    jacobian = np.asarray(jacobian, dtype=np.float64)
    residuals = np.asarray(residuals, dtype=np.float64)
    n, p = jacobian.shape
    if n <= p:
        return None
    try:
        inverse = np.linalg.inv(jacobian.T @ jacobian)
    except np.linalg.LinAlgError:
        return None
    return inverse * float(residuals @ residuals) / (n - p)
