"""scripts/regen_docs_outputs.py: the docs' broken-pipe output is what the real CLI prints (the script's
--check), and the script finds and replaces it."""

import importlib.util

from tests.conftest import REPO_ROOT


def _script():
    spec = importlib.util.spec_from_file_location("regen_docs_outputs", REPO_ROOT / "scripts" / "regen_docs_outputs.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_docs_broken_pipe_output_is_current():
    assert _script().main(["--check"]) == 0


def test_a_stale_output_is_replaced_by_the_real_one():
    script = _script()
    text = script.BROKEN_PIPE_PAGE.read_text(encoding="utf-8")
    match = script._BROKEN_PIPE.search(text)
    stale = text[:match.start("output")] + '{"file":"sample_clouds/countersunk_outliers.xyz","points":11\n' \
        + text[match.end("output"):]
    assert stale != text
    assert script.regenerate_page(stale) == text
