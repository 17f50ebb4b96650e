"""Tests of holecli.registration.consistency through register: simulated cells of 2 and 3 holes (issue 25)."""

import math

import numpy as np
import pytest

from holecli.pipeline import detect
from holecli.registration import register
from holecli.simulation.cell import random_cell, simulate_cell


def _register_cell(seed, holes, moved=None):
    spec = random_cell(seed, holes, targets=3, displaced=moved or {}, range_noise=0.005)
    cell = simulate_cell(spec, rng=seed)
    measured = [detect(scan.points).holes[0] for scan in cell.scans]
    return register(measured, cell.nominal, measured_names=[scan.name for scan in cell.scans])


@pytest.mark.parametrize("holes", [2, 3])
def test_clean_cells_raise_no_warning(holes):
    for seed in range(4):
        result = _register_cell(seed, holes)
        assert result.consistency.checked and result.consistency.consistent, result.consistency.reason
        # two holes: only the direction nothing can check (across their line) is said
        expected = ["unchecked_direction"] if holes == 2 else []
        assert [code for code, _ in result.warnings] == expected and not result.doubtful


def test_two_holes_one_moved_along_their_line_is_inconsistent_and_widened():
    spec = random_cell(7, 2)
    a, b = (np.array(hole.center) for hole in spec.holes)
    along = 0.2 * (b - a) / np.linalg.norm(b - a)
    result = _register_cell(7, 2, {"R2": tuple(along)})
    clean = _register_cell(7, 2)
    assert not result.consistency.consistent and result.doubtful
    assert [code for code, _ in result.warnings] == ["inconsistent_holes", "unchecked_direction"]
    assert "R1 or R2 is off" in result.warnings[0][1]
    assert result.consistency.added_sigma > 0.02
    widened = np.sqrt(np.diag(result.fit.covariance))
    tight = np.sqrt(np.diag(clean.fit.covariance))
    assert np.all(widened[3:] > 10 * tight[3:])


def test_three_holes_one_moved_is_named():
    angle = 1.0
    result = _register_cell(3, 3, {"R3": (0.1 * math.cos(angle), 0.1 * math.sin(angle))})
    assert not result.consistency.consistent
    assert result.consistency.suspects == ("R3",)
    assert "R3 is off" in result.warnings[0][1]


def test_floor_above_the_discrepancy_lets_it_pass():
    spec = random_cell(7, 2)
    a, b = (np.array(hole.center) for hole in spec.holes)
    along = 0.2 * (b - a) / np.linalg.norm(b - a)
    cell = simulate_cell(random_cell(7, 2, targets=3, displaced={"R2": tuple(along)}, range_noise=0.005), rng=7)
    measured = [detect(scan.points).holes[0] for scan in cell.scans]
    result = register(measured, cell.nominal, measured_names=["R1", "R2"], outlier_floor=0.5)
    assert result.consistency.consistent and [code for code, _ in result.warnings] == ["unchecked_direction"]
    below = register(measured, cell.nominal, measured_names=["R1", "R2"], outlier_floor=0.1)
    assert not below.consistency.consistent


def test_four_holes_two_moved_the_rest_after_the_outlier_is_still_tested():
    # leave-one-out names one moved hole; the three left still hold the other, which the test of the
    # final fit finds (it was a tight u with exit 0 after the outlier was left out)
    result = _register_cell(1, 4, {"R1": (0.2, 0.0), "R2": (0.0, 0.2)})
    assert result.outliers == ("R2",)
    assert [code for code, _ in result.warnings] == ["outlier", "inconsistent_holes"]
    assert result.consistency.suspects == ("R1",)
    assert result.consistency.added_sigma > 0.02
