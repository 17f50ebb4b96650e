"""The README's and the docs' shell examples run as printed.

Every fenced block tagged ``sh``, ``bash`` or ``shell`` of README.md and of every page of the docs site
(``docs/**/*.md``, :data:`DOCUMENTS`) is run, in order, each in a fresh
temporary folder holding copies of the repository's ``sample_clouds/``, ``docs/`` and ``scripts/`` (so
that the examples' relative paths work and nothing is ever written into the repository), with the
repository's ``holecli`` first on ``PATH`` (the folder of the Python running the tests) and this
checkout on ``PYTHONPATH``. The test is parametrized per block, its id the document, the block's line
and section. The grammar is the same in every document; a block continues only a block of its own
document.

The grammar of a block
----------------------
- **Commands.** A block is a list of commands. A command is a line, joined with the next ones while it
  ends in ``\\`` or a quote is open (a multi-line ``jq`` program). Each command runs alone in
  ``bash -o pipefail -c COMMAND`` (with stdin empty), in the block's folder: files it writes are there
  for the next command, shell state (variables, ``cd``, ``$PIPESTATUS``) is not; a pipeline's exit
  code is therefore that of its last failing command, and ``cmd; echo ${PIPESTATUS[0]}`` must be one
  line.
- **Expected exit code.** A command's comments say it: the comment at the end of its line, a comment
  line at column 0 right above it, and indented comment lines right below it. ``exit N`` (or ``exit
  code N``) in them is the expected code; without it the command must exit 0.
- **Printed output.** A ``text`` (or untagged) block that follows the shell block with only blank lines
  between is what the block prints: stdout and stderr of its commands, in order. It is compared with
  doctest's ``ELLIPSIS`` rule: ``...`` stands for any text (a timing, a path, a count in a message).

Markers
-------
HTML comments, not shown on the rendered page but visible in the Markdown source, on the lines
directly above a block's opening fence (no blank line between), one directive each:

- ``<!-- example: not run (REASON) -->``: the block is not run (it installs packages, needs the network
  or a machine's folders, runs for minutes). REASON is required; at most ``MAX_NOT_RUN`` blocks in
  all the documents together.
- ``<!-- example: xfail (REASON) -->``: the block is run and must fail (a strict xfail): a known bug of
  holecli, named in REASON. It fails the test once the bug is fixed, so that the marker goes.
- ``<!-- example: setup: COMMANDS -->``: bash commands run in the block's folder first, which must exit
  0: they make the files a block's placeholder names stand for (``scan.ply``, ``scans/``,
  ``part.toml``). ``$REPO`` is the repository's root there (for files outside the folders copied).
- ``<!-- example: continues (REASON) -->``: the block runs in the folder of the block above it that
  is run (that block and those it continues are run first), for a block that uses what another wrote.
- ``<!-- example: run -->``: a non-shell block that is run too (``python`` runs a ``python`` block,
  which must exit 0), for a block that a shell block continues.

An untagged or ``console`` block that starts like a command (``holecli ...``, ``$ ...``) and is not
the output of the block above is an error: tag it ``sh`` (to be run) or ``text`` (a synopsis). So is
a marker that is not directly above a block, an unknown directive, or ``run`` on a non-python block.
"""

import dataclasses
import doctest
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

REPO_ROOT = Path(__file__).resolve().parents[1]
README = REPO_ROOT / "README.md"
# Every document whose examples are run: the README, then the docs site's pages.
DOCUMENTS = [README, *sorted((REPO_ROOT / "docs").rglob("*.md"))]

SHELL_LANGS = {"sh", "bash", "shell"}
OUTPUT_LANGS = {"", "text"}
# The repository's folders an example may name by a relative path; copied into each block's folder.
COPIED_FOLDERS = ("sample_clouds", "docs", "scripts")
# Blocks that may be marked "not run", in all the documents together: few, each with its reason.
MAX_NOT_RUN = 10
COMMAND_TIMEOUT_S = 600

FENCE = re.compile(r"^(```+)\s*([\w+-]*)\s*$")
MARKER = re.compile(r"^<!--\s*example:\s*(.*?)\s*-->\s*$")
EXIT = re.compile(r"\bexit(?: code)? (\d+)\b")
LOOKS_LIKE_A_COMMAND = re.compile(r"^(\$ |holecli )")


@dataclasses.dataclass
class Block:
    """A fenced block of a document, with its markers and the output block printed under it."""

    line: int                     # 1-based line of the opening fence
    lang: str
    text: str
    heading: str
    markers: list
    output: str | None = None     # the text of the block under it that shows what it prints
    document: str = "README.md"   # the file it is in, relative to the repository's root

    def directive(self, name):
        """The argument of the marker ``name`` (``""`` when it has none), or None without that marker."""
        for marker in self.markers:
            if marker == name or marker.startswith(name + " ") or marker.startswith(name + ":"):
                return marker[len(name):].lstrip(":").strip()
        return None

    @property
    def runs(self):
        return (self.lang in SHELL_LANGS or self.directive("run") is not None) and self.directive("not run") is None


@dataclasses.dataclass
class Command:
    source: str
    comments: list

    @property
    def expected_exit(self):
        codes = {int(code) for comment in self.comments for code in EXIT.findall(comment)}
        if len(codes) > 1:
            raise ValueError(f"{self.source!r}: its comments give several exit codes {sorted(codes)}")
        return codes.pop() if codes else 0


def parse_readme(text, document="README.md"):
    """The fenced blocks of a Markdown text, in order, and the problems of their markers.

    Parameters
    ----------
    text : str
        The Markdown.
    document : str
        Its file's path relative to the repository's root, for the blocks and the messages.

    Returns
    -------
    blocks : list of Block
    problems : list of str
        Markers that are not directly above a block, unknown directives, blocks that look like shell
        sessions but are not tagged as such.
    """
    lines = text.split("\n")
    blocks, problems, heading, index = [], [], "(top)", 0
    while index < len(lines):
        line = lines[index]
        fence = FENCE.match(line)
        if line.startswith("#"):
            heading = line.lstrip("#").strip()
        elif MARKER.match(line):
            following = index
            while following < len(lines) and MARKER.match(lines[following]):
                following += 1
            if following >= len(lines) or not FENCE.match(lines[following]):
                problems.append(f"{document}:{index + 1}: a marker not directly above a block: {line}")
        if not fence:
            index += 1
            continue
        end = index + 1
        while end < len(lines) and lines[end].rstrip() != fence.group(1):
            end += 1
        markers, above = [], index - 1
        while above >= 0 and MARKER.match(lines[above]):
            markers.insert(0, MARKER.match(lines[above]).group(1))
            above -= 1
        block = Block(index + 1, fence.group(2), "\n".join(lines[index + 1:end]), heading, markers,
                      document=document)
        blocks.append(block)
        index = end + 1
    for previous, block in zip(blocks, blocks[1:]):
        closing_fence = previous.line + previous.text.count("\n") + 1   # its 0-based index
        between = lines[closing_fence + 1:block.line - 1]
        if previous.lang in SHELL_LANGS and block.lang in OUTPUT_LANGS and not "".join(between).strip():
            previous.output = block.text + "\n"
    for block in blocks:
        for marker in block.markers:
            name = re.match(r"(not run|xfail|setup|continues|run)\b", marker)
            if name is None:
                problems.append(f"{document}:{block.line}: unknown marker directive {marker!r}")
            elif name.group(1) == "run" and block.lang != "python":
                problems.append(f"{document}:{block.line}: 'run' is for python blocks (shell blocks run anyway)")
            elif name.group(1) in ("not run", "xfail") and not re.fullmatch(r"\w+( \w+)? \(.+\)", marker):
                problems.append(f"{document}:{block.line}: {name.group(1)!r} needs its reason in parentheses")
        first = block.text.lstrip("\n").split("\n", 1)[0]
        if block.lang in ("", "console") and LOOKS_LIKE_A_COMMAND.match(first) and block.output is None:
            problems.append(f"{document}:{block.line}: a block that starts like a command is tagged "
                            f"{block.lang or 'nothing'}: tag it sh (run) or text (a synopsis)")
    return blocks, problems


def _scan_line(line, quote):
    """Split a line into its code and its comment, carrying the open quote (None, "'" or '"')."""
    index, escaped = 0, False
    while index < len(line):
        char = line[index]
        if escaped:
            escaped = False
        elif quote == "'":
            quote = None if char == "'" else quote
        elif char == "\\":
            escaped = True
        elif quote == '"':
            quote = None if char == '"' else quote
        elif char in "'\"":
            quote = char
        elif char == "#" and (index == 0 or line[index - 1].isspace()):
            return line[:index], line[index:], quote
        index += 1
    return line, "", quote


def split_commands(text):
    """The commands of a shell block and the comments that go with each (see the module's docstring)."""
    commands, pending, current, comments, quote = [], [], [], [], None
    for line in text.split("\n"):
        if not current:
            stripped = line.strip()
            if not stripped:
                pending = []
                continue
            if stripped.startswith("#"):
                if line[0].isspace() and commands:
                    commands[-1].comments.append(stripped)
                else:
                    pending.append(stripped)
                continue
        code, comment, quote = _scan_line(line, quote)
        current.append(line)
        if comment:
            comments.append(comment)
        if quote is None and not code.rstrip().endswith("\\"):
            commands.append(Command("\n".join(current), pending + comments))
            current, comments, pending = [], [], []
    if current:
        commands.append(Command("\n".join(current), pending + comments))
    return commands


def example_environment():
    """os.environ with this checkout's holecli first: its Python's folder on PATH, the checkout on PYTHONPATH."""
    bin_dir = str(Path(sys.executable).parent)
    return dict(os.environ, PATH=bin_dir + os.pathsep + os.environ.get("PATH", ""), PYTHONPATH=str(REPO_ROOT))


def prepare_folder(folder):
    """Copies of the repository's folders the examples name by relative paths."""
    for name in COPIED_FOLDERS:
        shutil.copytree(REPO_ROOT / name, folder / name)


def _tail(text, lines=12):
    """The last lines of a command's output, for a failure message."""
    return "\n".join(text.rstrip("\n").split("\n")[-lines:])


def _run(argv, folder, env):
    completed = subprocess.run(argv, cwd=folder, env=env, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                               stderr=subprocess.STDOUT, timeout=COMMAND_TIMEOUT_S)
    return completed.returncode, completed.stdout.decode("utf-8", "replace")


def run_block(block, folder, env):
    """Run a block in folder: its setup, then each command. Returns (problems, printed output)."""
    problems, printed = [], []
    setup = block.directive("setup")
    if setup:
        code, out = _run(["bash", "-o", "pipefail", "-c", setup], folder, dict(env, REPO=str(REPO_ROOT)))
        if code != 0:
            return [f"setup `{setup}` exited {code}:\n{_tail(out)}"], ""
    if block.lang not in SHELL_LANGS:
        code, out = _run([sys.executable, "-c", block.text], folder, env)
        if code != 0:
            problems.append(f"the {block.lang} block exited {code}:\n{_tail(out)}")
        return problems, out
    for command in split_commands(block.text):
        code, out = _run(["bash", "-o", "pipefail", "-c", command.source], folder, env)
        printed.append(out)
        if code != command.expected_exit:
            problems.append(f"`{command.source}` exited {code}, {block.document} says {command.expected_exit}:\n"
                            f"{_tail(out)}")
    printed = "".join(printed)
    if block.output is not None and not doctest.OutputChecker().check_output(block.output, printed,
                                                                               doctest.ELLIPSIS):
        problems.append(f"the block printed\n{printed}\nwhere {block.document} shows\n{block.output}")
    return problems, printed


def chain_of(block, blocks):
    """The blocks to run, in order, for block: those it continues (recursively, in its document), then itself."""
    chain = [block]
    while chain[0].directive("continues") is not None:
        before = [other for other in blocks if other.document == chain[0].document and other.line < chain[0].line
                  and other.runs]
        assert before, f"{chain[0].document}:{chain[0].line}: continues no block"
        chain.insert(0, before[-1])
    return chain


def parse_documents(paths):
    """The blocks and the problems of every document in ``paths``, in order."""
    blocks, problems = [], []
    for path in paths:
        found, wrong = parse_readme(path.read_text(encoding="utf-8"), path.relative_to(REPO_ROOT).as_posix())
        blocks += found
        problems += wrong
    return blocks, problems


BLOCKS, PROBLEMS = parse_documents(DOCUMENTS)


def _slug(text):
    return re.sub(r"[^A-Za-z0-9.=-]+", "-", text).strip("-")[:50]


def _params(blocks):
    for block in blocks:
        if not block.runs:
            continue
        marks = [pytest.mark.xfail(strict=True, reason=block.directive("xfail"))] \
            if block.directive("xfail") is not None else []
        document = "" if block.document == "README.md" else _slug(block.document.removeprefix("docs/")[:-3]) + "-"
        yield pytest.param(block, id=f"{document}L{block.line}-{_slug(block.heading)}", marks=marks)


@pytest.mark.slow
@pytest.mark.parametrize("block", list(_params(BLOCKS)))
def test_readme_example_runs_as_printed(block, tmp_path):
    env = example_environment()
    prepare_folder(tmp_path)
    problems = []
    for link in chain_of(block, BLOCKS):
        found, _ = run_block(link, tmp_path, env)
        problems += [f"{link.document}:{link.line} ({link.heading}): {problem}" for problem in found]
    assert not problems, "\n\n".join(problems)


def test_every_shell_block_is_run_or_marked_not_run_with_a_reason():
    assert not PROBLEMS, "\n".join(PROBLEMS)
    shell = [block for block in BLOCKS if block.lang in SHELL_LANGS]
    not_run = [block for block in shell if block.directive("not run") is not None]
    run = [block for block in shell if block.runs]
    assert len(run) + len(not_run) == len(shell) and len(run) >= 15, (len(run), len(not_run), len(shell))
    assert len(not_run) <= MAX_NOT_RUN, [f"{block.document}:{block.line}" for block in not_run]
    for block in not_run:
        assert block.directive("not run").startswith("(") and len(block.directive("not run")) > 5, block.line


def test_the_docs_pages_examples_are_run_too():
    documents = {block.document for block in BLOCKS if block.runs}
    assert "README.md" in documents and {"docs/guide/detect.md", "docs/guide/batch.md"} <= documents, documents
    assert all(path.suffix == ".md" for path in DOCUMENTS[1:]) and len(DOCUMENTS) > 20, DOCUMENTS


# The grammar itself, on made-up blocks (these fail if the runner stops checking what it claims to).

def test_commands_join_continuations_and_quotes_and_take_their_comments():
    text = ("# the first: exit 5\n"
            "holecli a \\\n    --b 1   # not this one's code\n"
            "holecli c | jq '\n  .x # inside quotes\n'\n"
            "                 # 2. below it, exit 3\n"
            "cp a b && holecli d   # exit 0\n")
    commands = split_commands(text)
    assert [command.source for command in commands] == [
        "holecli a \\\n    --b 1   # not this one's code", "holecli c | jq '\n  .x # inside quotes\n'",
        "cp a b && holecli d   # exit 0"]
    assert [command.expected_exit for command in commands] == [5, 3, 0]


def test_a_wrong_exit_code_a_wrong_output_and_a_failed_setup_are_reported(tmp_path):
    env = example_environment()
    wrong_code = Block(1, "sh", "exit 3   # exit 4\ntrue", "t", [])
    problems, _ = run_block(wrong_code, tmp_path, env)
    assert len(problems) == 1 and "exited 3, README.md says 4" in problems[0]
    wrong_output = Block(1, "sh", "echo one; echo two >&2", "t", [], output="one\nthree\n")
    assert run_block(wrong_output, tmp_path, env)[0]
    right_output = Block(1, "sh", "echo one; echo two >&2", "t", [], output="one\nt...\n")
    assert run_block(right_output, tmp_path, env) == ([], "one\ntwo\n")
    failed_setup = Block(1, "sh", "true", "t", ["setup: false"])
    assert "setup `false` exited 1" in run_block(failed_setup, tmp_path, env)[0][0]


def test_a_text_block_right_under_a_shell_block_is_its_output():
    text = "```sh\necho a\necho b\n```\n\n```text\na\nb\n```\n\nprose\n\n```sh\ntrue\n```\nprose\n```text\nx\n```\n"
    blocks, problems = parse_readme(text)
    assert not problems and [block.output for block in blocks] == ["a\nb\n", None, None, None]


def test_markers_must_sit_above_a_block_name_a_known_directive_and_give_a_reason():
    text = ("# S\n\n<!-- example: not run -->\n```sh\ntrue\n```\n\n<!-- example: skip (x) -->\n```sh\ntrue\n```\n"
            "<!-- example: not run (x) -->\n\n```sh\ntrue\n```\nprose\n```\nholecli detect x.ply\n```\n")
    blocks, problems = parse_readme(text)
    assert [block.output for block in blocks] == [None] * 4
    assert len(blocks) == 4 and len(problems) == 4, problems
    assert "reason" in problems[1] and "unknown" in problems[2] and "not directly above" in problems[0]
    assert "tag it sh" in problems[3]


def test_an_xfail_block_is_a_strict_xfail_and_a_not_run_block_is_not_a_test():
    text = ("# S\n<!-- example: xfail (a bug) -->\n```sh\ntrue\n```\n<!-- example: not run (x) -->\n```sh\ntrue\n```\n"
            "<!-- example: run -->\n```python\nprint(1)\n```\n<!-- example: continues -->\n```sh\ntrue\n```\n")
    blocks, problems = parse_readme(text)
    assert not problems
    params = list(_params(blocks))
    assert [param.values[0].line for param in params] == [3, 11, 15]
    (mark,) = params[0].marks
    assert mark.name == "xfail" and mark.kwargs == {"strict": True, "reason": "(a bug)"}
    assert [link.line for link in chain_of(blocks[3], blocks)] == [11, 15]


def test_a_block_continues_only_a_block_of_its_own_document():
    first, _ = parse_readme("```sh\ntrue\n```\n", "docs/a.md")
    second, _ = parse_readme("<!-- example: continues (x) -->\n```sh\ntrue\n```\n", "docs/b.md")
    with pytest.raises(AssertionError, match="docs/b.md:2: continues no block"):
        chain_of(second[0], first + second)
