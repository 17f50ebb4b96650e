"""benchmarks/register.py: its measure function on two cells (the full benchmark takes minutes)."""

import importlib.util
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def bench():
    spec = importlib.util.spec_from_file_location("benchmark_register", REPO / "benchmarks" / "register.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _check(row, targets):
    assert "error" not in row, row.get("error")
    assert row["translation_um"] <= targets["translation_um"]
    assert row["rotation_deg"] <= targets["rotation_deg"]
    far = [e for e, d in zip(row["target_um"], row["reach_mm"]) if d >= 250.0]
    assert far and max(far) <= targets["far_target_um"]
    assert len(row["target_um"]) == 10 and all(e >= 0 for e in row["target_um"])


def test_a_clean_cell_registers_within_the_targets_and_names_no_outlier(bench):
    row = bench.measure((23, False, False))  # 3 holes, countersunk, no hole moved
    _check(row, bench.TARGETS)
    assert row["holes"] == 3 and row["outliers"] == [] and row["moved"] == []


def test_the_moved_hole_of_a_cell_is_named_as_the_outlier(bench):
    row = bench.measure((3, True, False))  # 4 holes, one drilled 0.2 mm off
    _check(row, bench.TARGETS)
    assert row["holes"] >= 4 and len(row["moved"]) == 1
    assert row["outliers"] == row["moved"]


def test_pass_3_flags_a_moved_hole_from_three_holes_and_not_a_clean_cell(bench):
    cells = bench.measure_consistency(0)
    assert len(cells) == len(bench.COUNTS) * (1 + len(bench.MOVES))
    assert all("error" not in cell for cell in cells)
    assert not any(cell["flagged"] for cell in cells if cell["move"] == 0.0)
    assert all(cell["flagged"] for cell in cells if cell["move"] >= 0.1 and cell["holes"] >= 3)
    assert all(cell["named"] for cell in cells if cell["move"] and cell["holes"] >= 4)
