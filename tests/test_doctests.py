"""The Examples sections of the public API's docstrings run as printed (from the repository's root,
where ``sample_clouds/`` is)."""

import doctest
import importlib
import re

import pytest

# Modules whose docstrings hold examples, and the least number of examples each must hold (so that
# a docstring that loses its Examples section fails here rather than passing as "0 of 0").
MODULES = {"holecli.measure": 1, "holecli.pipeline": 2, "holecli.schema": 1}
MODULES["holecli.quality.spc"] = 4  # the charts, the run rules and capability on published examples


@pytest.mark.parametrize("name", sorted(MODULES))
def test_docstring_examples_run_as_printed(name, repo_root, monkeypatch):
    monkeypatch.chdir(repo_root)
    module = importlib.import_module(name)
    finder = doctest.DocTestFinder()
    tests = [test for test in finder.find(module) if test.examples]
    assert len(tests) >= MODULES[name], [test.name for test in tests]
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS)
    for test in tests:
        runner.run(test)
    results = runner.summarize(verbose=False)
    assert results.failed == 0, f"{results.failed} of {results.attempted} examples of {name} failed (see above)"


def test_the_docs_detect_file_example_prints_what_the_docs_say(repo_root, monkeypatch, capsys):
    # The Python API page's first example, and the output printed under it.
    section = (repo_root / "docs" / "guide" / "python.md").read_text(encoding="utf-8")
    match = re.search(r"```python\n(.*?)```\n\nprints\n\n```\n(.*?)```\n", section, re.DOTALL)
    assert match is not None and "detect_file(" in match.group(1)
    monkeypatch.chdir(repo_root)
    exec(compile(match.group(1), "docs/guide/python.md", "exec"), {})
    assert capsys.readouterr().out == match.group(2)


def test_every_docstring_example_of_the_package_runs_as_printed(repo_root, monkeypatch):
    # pytest --doctest-modules over holecli/, as a test: an example anywhere in the package that goes
    # stale (the schema's version, a renamed field) fails here, not only in the modules listed above
    import pkgutil

    import holecli

    monkeypatch.chdir(repo_root)
    finder = doctest.DocTestFinder()
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS)
    names = [info.name for info in pkgutil.walk_packages(holecli.__path__, "holecli.")
             if info.name != "holecli.__main__"]  # the program itself: it runs when imported as __main__ only
    for name in names:
        for test in finder.find(importlib.import_module(name)):
            if test.examples:
                runner.run(test)
    results = runner.summarize(verbose=False)
    assert results.attempted >= 26, results  # the examples there were when this test was written
    assert results.failed == 0, f"{results.failed} of {results.attempted} examples failed (see above)"
