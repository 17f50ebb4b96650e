"""The examples in the docstrings of holecli.io run as doctests, from the root of the repository."""

import doctest
import importlib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
MODULES = ["holecli.io", "holecli.io.formats", "holecli.io.cloud", "holecli.io.stream", "holecli.io.write",
           "holecli.io.ply", "holecli.io.pcd", "holecli.io.text", "holecli.io._common", "holecli.io.info"]


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples(name, monkeypatch):
    monkeypatch.chdir(ROOT)  # the examples name sample files relative to the repository's root
    module = importlib.import_module(name)
    result = doctest.testmod(module, optionflags=doctest.ELLIPSIS, report=True)
    assert result.failed == 0, f"{result.failed} of {result.attempted} examples in {name} failed"


def test_load_points_has_an_example_that_runs():
    from holecli.io import load_points

    tests = doctest.DocTestFinder().find(load_points, "load_points")
    assert sum(len(test.examples) for test in tests) >= 3
