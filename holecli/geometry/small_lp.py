"""Linear programmes in a few variables and many rows: ``maximise c.x subject to A x <= b``.

The lattice estimator's programmes (:mod:`holecli.robust.estimators.lattice`) have three or four
variables and tens to thousands of rows. A general solver spends most of such a call in its own
set-up (scipy's ``linprog`` about a millisecond of Python around HiGHS, and its import tens of
milliseconds); here the programme is solved by the primal simplex method on the vertices of the
polytope, each step a small dense solve in the active rows and one product ``A d`` for the ratio
test over every row, so no row is ever dropped.

:func:`maximize` starts from a feasible point the caller knows (for the lattice: the current circle
with a small enough margin) and returns the optimum with its certificate: the active rows and their
multipliers ``lambda >= 0`` with ``A_active^T lambda = c``, every row satisfied. It says so when it
cannot certify one (an unbounded direction, too many steps, a singular active set); the caller then
asks a general solver.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["LinearProgramResult", "maximize"]

# A point violating no row by more than FEASIBILITY_TOL (in the units of b, the programme being
# scaled to order one) is feasible; a multiplier above -MULTIPLIER_TOL is non-negative; a row whose
# cosine with a direction is below DIRECTION_TOL does not block it (a row parallel to the active
# ones, e.g. a repeated row, would make them singular; moving along it changes its slack by that
# fraction of the step at most, and the optimum is checked against every row in the end).
FEASIBILITY_TOL = 1e-9
MULTIPLIER_TOL = 1e-11
DIRECTION_TOL = 1e-9
# Every multiplier above UNIQUE_TOL: no other point has the same objective, nor one within the dual
# feasibility tolerance of HiGHS (1e-7, its default), so a general solver finds this same vertex.
UNIQUE_TOL = 1e-7
# After this many steps without progress the leaving row is chosen by Bland's rule (the lowest
# index), which cannot cycle.
BLAND_AFTER = 20


@dataclass(frozen=True, eq=False)
class LinearProgramResult:
    """The outcome of :func:`maximize`.

    Attributes
    ----------
    success : bool
        True when ``x`` is a certified optimum (``message`` "optimal" at a vertex, "optimal face"
        when fewer rows than variables are active: the optimum is then not unique).
    x : (d,) float or None
        The optimal point (None unless ``success``).
    active : (k,) int or None
        The rows active at the optimum, linearly independent: ``k = d`` at a vertex, fewer on a face.
    multipliers : (k,) float or None
        Their multipliers: ``A[active].T @ multipliers == c``, all >= 0. A multiplier of zero means
        the optimum may not be unique (another vertex can have the same objective): see ``unique``.
    steps : int
        Simplex steps taken.
    message : str
        Why it failed, or ``"optimal"``.
    """

    success: bool
    x: np.ndarray | None
    active: np.ndarray | None
    multipliers: np.ndarray | None
    steps: int
    message: str

    @property
    def unique(self):
        """True when the optimum is certainly unique: a vertex whose every multiplier is positive
        (above ``UNIQUE_TOL``). Otherwise other points may be optimal too (an edge or a face of the
        polytope at the same height), and which of them a solver returns is its own choice."""
        return bool(self.success and len(self.active) == len(self.x) and np.all(self.multipliers > UNIQUE_TOL))


def _failed(message, steps):
    return LinearProgramResult(False, None, None, None, steps, message)


def maximize(c, A, b, x0, *, max_steps=500):
    """Maximise ``c . x`` subject to ``A x <= b``, from the feasible point ``x0``.

    Parameters
    ----------
    c : (d,) float
    A : (m, d) float
        The rows, scaled so that their coefficients and ``b`` are of order one; bounds on the
        variables are rows too.
    b : (m,) float
    x0 : (d,) float
        A point with ``A x0 <= b`` (within ``FEASIBILITY_TOL``).
    max_steps : int
        Simplex steps before giving up.

    Returns
    -------
    LinearProgramResult
        ``success`` False when ``x0`` is not feasible, the programme is unbounded, the steps run out
        or the active rows become singular.
    """
    c = np.asarray(c, dtype=np.float64)
    A = np.asarray(A, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    x = np.array(x0, dtype=np.float64)
    d = len(c)
    if A.ndim != 2 or A.shape[1] != d or A.shape[0] != len(b) or x.shape != (d,):
        raise ValueError(f"expected c (d,), A (m, d), b (m,), x0 (d,); got {c.shape}, {A.shape}, {b.shape}, {x.shape}")
    if (A @ x - b).max(initial=-np.inf) > FEASIBILITY_TOL:
        return _failed("the start is not feasible", 0)
    norms = np.linalg.norm(A, axis=1)
    active = []           # row indices, linearly independent, all with zero slack at x
    stalled = 0
    for step in range(max_steps + 1):
        # A direction that improves c and keeps the active rows (but at most one) satisfied.
        if active:
            rows = A[active]
            multipliers, *_ = np.linalg.lstsq(rows.T, c, rcond=None)
            direction = c - rows.T @ multipliers   # c's part outside the active rows' span
        else:
            multipliers, direction = np.zeros(0), c.copy()
        if np.linalg.norm(direction) <= 1e-12 * np.linalg.norm(c):
            # c lies in the active rows' span: optimal when no multiplier is negative.
            if np.all(multipliers >= -MULTIPLIER_TOL):
                if len(active) < d:
                    # The optimum is a face, not a vertex; any of its points is optimal.
                    return _done(A, b, x, active, multipliers, step, vertex=False)
                return _done(A, b, x, active, multipliers, step, vertex=True)
            negative = np.flatnonzero(multipliers < -MULTIPLIER_TOL)
            leave = (negative[np.argmin([active[i] for i in negative])] if stalled >= BLAND_AFTER
                     else int(np.argmin(multipliers)))
            kept = [row for i, row in enumerate(active) if i != leave]
            # Move along the leaving row's inward normal within the kept rows' null space.
            if kept:
                basis = A[kept]
                solution, *_ = np.linalg.lstsq(basis.T, A[active[leave]], rcond=None)
                direction = -(A[active[leave]] - basis.T @ solution)
            else:
                direction = -A[active[leave]].copy()
            active = kept
            if direction @ c <= 0:
                return _failed("the active rows are singular", step)
        if step == max_steps:
            break
        along = A @ direction
        blocking = along > DIRECTION_TOL * np.linalg.norm(direction) * norms
        if active:
            blocking[active] = False
        if not blocking.any():
            return _failed("the programme is unbounded", step)
        candidates = np.flatnonzero(blocking)
        slack = np.maximum(b[candidates] - A[candidates] @ x, 0.0)
        ratios = slack / along[candidates]
        smallest = ratios.min()
        # Ties (a degenerate vertex, common on a lattice): the lowest row index.
        enter = int(candidates[np.flatnonzero(ratios <= smallest + 1e-15)[0]])
        stalled = stalled + 1 if smallest <= 1e-15 else 0
        x = x + smallest * direction
        active.append(enter)
        if len(active) == d:
            # Re-solve the vertex from its rows: no drift from the accumulated steps.
            try:
                x = np.linalg.solve(A[active], b[active])
            except np.linalg.LinAlgError:
                return _failed("the active rows are singular", step)
    return _failed(f"no optimum within {max_steps} steps", max_steps)


def _done(A, b, x, active, multipliers, steps, *, vertex):
    """The certified result, or a failure when ``x`` violates a row."""
    if (A @ x - b).max() > FEASIBILITY_TOL:
        return _failed("the optimum violates a row", steps)
    return LinearProgramResult(True, x, np.asarray(active, dtype=np.intp), np.asarray(multipliers, dtype=np.float64),
                               steps, "optimal" if vertex else "optimal face")
