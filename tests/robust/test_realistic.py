"""A representative subset of the realistic suite (``benchmarks/realistic.py``): built panels of every
class scanned by the laser profiler, one scene per class (seed 0, whose parameters are drawn, not
picked). Bounds, per scene: every hole whose edge is inside the scan found, nothing reported on slots,
bosses or plain material, center and diameter within 0.2 of the point pitch (issue 9's micrometre
targets are the benchmark's, over many seeds)."""

import importlib.util
from pathlib import Path

import pytest

pytestmark = pytest.mark.slow  # the quick loop: pytest -m "not slow"

_PATH = Path(__file__).resolve().parents[2] / "benchmarks" / "realistic.py"
_SPEC = importlib.util.spec_from_file_location("realistic", _PATH)
realistic = importlib.util.module_from_spec(_SPEC)
_SPEC.loader.exec_module(realistic)


@pytest.mark.parametrize("kind", realistic.CLASSES)
def test_one_scene_of_each_class(kind):
    result = realistic.measure(kind, 0)
    assert result["found"] == result["expected"], result
    assert result["extra"] == 0, result
    bound_um = 0.2 * result["pitch"] * 1e3
    assert all(error <= bound_um for error in result["center"]), result
    assert all(abs(error) <= bound_um for error in result["diameter"]), result
