"""benchmarks/_docs_table.py: the blocks of the validation pages that the benchmarks write with ``--docs``."""

import importlib.util
import os
import stat

import pytest

from tests.conftest import REPO_ROOT

from benchmarks._docs_table import (  # noqa: I001  (benchmarks/ is a folder of scripts beside holecli)
    DocsBlockError, check_block, command_line, format_block, markers, recording, replace_block, write_block)

PAGE = """# A page

Text before, with a `code span` and trailing spaces   
<!-- BEGIN benchmark: demo -->

```
old table
```

<!-- END benchmark: demo -->

Text after.
<!-- BEGIN benchmark: other -->
kept as it is
<!-- END benchmark: other -->
"""

# Every block a benchmark writes, on the page it writes to.
BLOCKS = {
    "accuracy.md": ["accuracy", "realistic"],
    "peers.md": ["peers"],
    "registration.md": ["register", "register-consistency"],
    "speed.md": ["speed", "pattern_speed", "serve", "report"],
}


def _outside(text, name):
    """The page without the lines between block ``name``'s markers."""
    begin, end = markers(name)
    return text[:text.index(begin) + len(begin)], text[text.index(end):]


def test_the_block_is_replaced_and_the_rest_of_the_page_is_byte_identical():
    new = replace_block(PAGE, "demo", format_block("python benchmarks/demo.py --seeds 1", "a  b\n1  2\n"))
    assert "`python benchmarks/demo.py --seeds 1`\n\n```\na  b\n1  2\n```\n" in new
    assert "old table" not in new
    assert _outside(new, "demo") == _outside(PAGE, "demo")
    assert replace_block(new, "demo", "x") == replace_block(PAGE, "demo", "x")  # idempotent: only the block moves


def test_a_crlf_page_keeps_its_line_ends():
    page = PAGE.replace("\n", "\r\n")
    new = replace_block(page, "demo", "line 1\nline 2")
    assert "\n" not in new.replace("\r\n", "")
    assert _outside(new, "demo") == _outside(page, "demo")


@pytest.mark.parametrize("page, message", [
    (PAGE.replace("<!-- BEGIN benchmark: demo -->\n", ""), "no line '<!-- BEGIN benchmark: demo -->'"),
    (PAGE.replace("<!-- END benchmark: demo -->\n", ""), "no line '<!-- END benchmark: demo -->'"),
    (PAGE + "<!-- BEGIN benchmark: demo -->\n", "2 lines '<!-- BEGIN benchmark: demo -->', expected exactly one"),
    (PAGE + "<!-- END benchmark: demo -->\n", "2 lines '<!-- END benchmark: demo -->', expected exactly one"),
    (PAGE.replace("<!-- BEGIN benchmark: demo -->", "@@").replace("<!-- END benchmark: demo -->",
                                                                 "<!-- BEGIN benchmark: demo -->")
     .replace("@@", "<!-- END benchmark: demo -->"), "comes before"),
])
def test_missing_repeated_or_swapped_markers_are_refused(page, message):
    with pytest.raises(DocsBlockError, match=message.replace("(", r"\(")):
        replace_block(page, "demo", "new", where="page.md")


def test_a_name_is_not_matched_inside_another_or_inside_a_line():
    page = PAGE.replace("<!-- BEGIN benchmark: demo -->", "<!-- BEGIN benchmark: demo-two -->")
    with pytest.raises(DocsBlockError, match="no line '<!-- BEGIN benchmark: demo -->'"):
        replace_block(page, "demo", "new")
    page = PAGE.replace("<!-- BEGIN benchmark: demo -->", "see <!-- BEGIN benchmark: demo --> here")
    with pytest.raises(DocsBlockError, match="no line"):
        replace_block(page, "demo", "new")


def test_write_block_replaces_the_file_whole_and_keeps_its_mode(tmp_path):
    page = tmp_path / "page.md"
    page.write_bytes(PAGE.encode())
    os.chmod(page, 0o640)
    write_block(page, "demo", "fresh")
    assert page.read_bytes().decode() == replace_block(PAGE, "demo", "fresh")
    assert stat.S_IMODE(os.stat(page).st_mode) == 0o640
    assert sorted(p.name for p in tmp_path.iterdir()) == ["page.md"]  # no temporary file left


def test_write_block_leaves_a_refused_page_untouched(tmp_path):
    page = tmp_path / "page.md"
    page.write_bytes(PAGE.encode())
    with pytest.raises(DocsBlockError, match=str(page).replace("\\", r"\\") + ": no line"):
        write_block(page, "missing", "fresh")
    assert page.read_bytes() == PAGE.encode()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["page.md"]


def test_the_command_line_leaves_out_the_docs_options():
    assert command_line("accuracy.py", ["--seeds", "1", "--docs", "--heavy"]) == \
        "python benchmarks/accuracy.py --seeds 1 --heavy"
    assert command_line("peers.py", ["--suite", "a b", "--docs-page", "x.md", "--docs-page=y.md"]) == \
        "python benchmarks/peers.py --suite 'a b'"


def test_recording_prints_and_keeps_a_copy(capsys):
    with recording() as printed:
        print("row 1")
        print("row 2", flush=True)
    print("after")
    assert printed.text == "row 1\nrow 2\n"
    assert capsys.readouterr().out == "row 1\nrow 2\nafter\n"


@pytest.mark.parametrize("page, names", BLOCKS.items())
def test_every_validation_page_marks_each_block_its_benchmarks_write(page, names):
    for name in names:
        check_block(REPO_ROOT / "docs" / "validation" / page, name)


def _benchmark(name):
    spec = importlib.util.spec_from_file_location(f"benchmark_{name}", REPO_ROOT / "benchmarks" / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_accuracy_with_docs_writes_its_command_and_the_table_it_printed(tmp_path, capsys):
    source = REPO_ROOT / "docs" / "validation" / "accuracy.md"
    page = tmp_path / "accuracy.md"
    page.write_bytes(source.read_bytes())
    _benchmark("accuracy").main(["--seeds", "1", "--docs-page", str(page)])
    printed = capsys.readouterr().out
    table = printed[:printed.index("targets:")].strip("\n")
    assert table.startswith("Table I protocol, 1 seeds per level") and "robust --view-dir 0,0,-1" in table
    written, original = page.read_text(encoding="utf-8"), source.read_text(encoding="utf-8")
    begin, end = markers("accuracy")
    block = written[written.index(begin) + len(begin):written.index(end)]
    assert block == f"\n\n`python benchmarks/accuracy.py --seeds 1`\n\n```\n{table}\n```\n\n"
    assert _outside(written, "accuracy") == _outside(original, "accuracy")


def test_a_page_without_the_block_is_refused_before_the_benchmark_runs(tmp_path, capsys):
    page = tmp_path / "page.md"
    page.write_text("# no markers\n", encoding="utf-8")
    with pytest.raises(SystemExit) as exit_:
        _benchmark("realistic").main(["--seeds", "50", "--docs-page", str(page)])
    assert exit_.value.code == 2
    captured = capsys.readouterr()
    assert captured.out == "" and "no line '<!-- BEGIN benchmark: realistic -->'" in captured.err
    assert page.read_text(encoding="utf-8") == "# no markers\n"
