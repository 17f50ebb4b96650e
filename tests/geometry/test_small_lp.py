"""Tests of holecli.geometry.small_lp: the dense simplex of the lattice estimator's programmes, against
scipy's HiGHS and its own certificate."""

import numpy as np
import pytest
from scipy.optimize import linprog

from holecli.geometry.small_lp import FEASIBILITY_TOL, maximize


def certified(result, c, A, b):
    """The optimality certificate holds: every row satisfied, the active rows tight and independent,
    their multipliers non-negative and summing to c."""
    assert result.success, result.message
    assert (A @ result.x - b).max() <= FEASIBILITY_TOL
    rows = A[result.active]
    np.testing.assert_allclose(rows @ result.x, b[result.active], atol=1e-9)
    assert np.linalg.matrix_rank(rows) == len(result.active)
    assert np.all(result.multipliers >= -1e-11)
    np.testing.assert_allclose(rows.T @ result.multipliers, c, atol=1e-9)


def random_programme(rng, d, m):
    """m random rows around the origin (inside them) and a box, so that the programme is bounded."""
    normals = rng.normal(size=(m, d))
    A = np.vstack([normals, np.eye(d), -np.eye(d)])
    b = np.concatenate([rng.uniform(0.2, 1.0, m), np.full(2 * d, 3.0)])
    return rng.normal(size=d), A, b


def test_a_square():
    A = np.vstack([np.eye(2), -np.eye(2)])
    result = maximize([1.0, 2.0], A, np.ones(4), [0.0, 0.0])
    certified(result, np.array([1.0, 2.0]), A, np.ones(4))
    np.testing.assert_allclose(result.x, [1.0, 1.0])
    assert result.unique


@pytest.mark.parametrize("d", [2, 3, 4])
def test_the_optimum_of_highs_on_random_programmes(d):
    """The same objective as HiGHS to 1e-9 on 200 random programmes; the same point where the
    certificate says the optimum is unique (every multiplier positive), which is nearly always."""
    rng = np.random.default_rng(d)
    unique = 0
    for _ in range(200):
        c, A, b = random_programme(rng, d, int(rng.integers(5, 400)))
        result = maximize(c, A, b, np.zeros(d))
        certified(result, c, A, b)
        reference = linprog(-c, A_ub=A, b_ub=b, bounds=[(None, None)] * d, method="highs")
        assert reference.status == 0
        assert c @ result.x == pytest.approx(c @ reference.x, abs=1e-9)
        if result.unique:
            unique += 1
            np.testing.assert_allclose(result.x, reference.x, atol=1e-9)
    assert unique >= 190


def test_degenerate_vertices_and_repeated_rows():
    """Many rows through the optimal vertex (a pyramid with 40 faces meeting at its apex) and every
    row twice: the steps that stall do not cycle."""
    angles = np.linspace(0.0, 2.0 * np.pi, 40, endpoint=False)
    # Faces z <= 1 - (cos a x + sin a y): all pass through (0, 0, 1).
    A = np.column_stack([np.cos(angles), np.sin(angles), np.ones(40)])
    A = np.vstack([A, A, [[0.0, 0.0, -1.0]]])
    b = np.concatenate([np.ones(80), [5.0]])
    for c in ([0.0, 0.0, 1.0], [0.01, 0.0, 1.0], [0.3, -0.2, 1.0]):
        c = np.array(c)
        result = maximize(c, A, b, [0.0, 0.0, -5.0])
        certified(result, c, A, b)
        np.testing.assert_allclose(result.x, [0.0, 0.0, 1.0], atol=1e-12)


def test_an_optimal_face_is_not_unique():
    """Maximising x in the unit square: every point of the edge x = 1 is optimal."""
    A = np.vstack([np.eye(2), -np.eye(2)])
    result = maximize([1.0, 0.0], A, np.ones(4), [0.0, 0.3])
    certified(result, np.array([1.0, 0.0]), A, np.ones(4))
    assert result.x[0] == pytest.approx(1.0)
    assert not result.unique
    assert result.message == "optimal face"


def test_it_says_when_it_cannot_certify_an_optimum():
    A = np.vstack([np.eye(2), -np.eye(2)])
    infeasible = maximize([1.0, 0.0], A, np.ones(4), [2.0, 0.0])
    assert not infeasible.success and infeasible.message == "the start is not feasible" and infeasible.x is None
    unbounded = maximize([1.0, 0.0], A[1:], np.ones(3), [0.0, 0.0])
    assert not unbounded.success and unbounded.message == "the programme is unbounded"
    rng = np.random.default_rng(5)
    c, A, b = random_programme(rng, 4, 300)
    short = maximize(c, A, b, np.zeros(4), max_steps=1)
    assert not short.success and short.message == "no optimum within 1 steps"


def test_shapes_are_checked():
    with pytest.raises(ValueError, match=r"expected c \(d,\), A \(m, d\), b \(m,\), x0 \(d,\)"):
        maximize([1.0, 0.0], np.ones((3, 3)), np.ones(3), [0.0, 0.0])
