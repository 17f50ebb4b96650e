"""The benchmarks' tables on the validation pages: each page marks a benchmark's block, and ``--docs`` rewrites it.

A block on a page (docs/validation/*.md) lies between two marker lines::

    <!-- BEGIN benchmark: NAME -->
    ...
    <!-- END benchmark: NAME -->

NAME is the benchmark's name, plus a qualifier when it writes several blocks (``register-consistency``).
A benchmark run with ``--docs`` puts there the command line that produced it, in a code span, then the
table it printed, in a fenced block. The page is written whole to a temporary file beside it and moved over
it (``os.replace``), so a reader never sees half a page; a page whose markers are missing or repeated is
refused, before the benchmark runs, with a message naming the page and the marker.
"""

from __future__ import annotations

import contextlib
import io
import os
import shlex
import stat
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parents[1]
VALIDATION = REPO_ROOT / "docs" / "validation"


class DocsBlockError(ValueError):
    """A page's markers for a block are missing, repeated or out of order."""


def markers(name):
    """The BEGIN and END marker lines (without their line ends) of the block ``name``."""
    return f"<!-- BEGIN benchmark: {name} -->", f"<!-- END benchmark: {name} -->"


def _marker_lines(text, marker):
    """Offsets of the lines of ``text`` that are exactly ``marker`` (surrounding blanks allowed)."""
    offsets, start = [], 0
    for line in text.splitlines(keepends=True):
        if line.strip() == marker:
            offsets.append((start, start + len(line)))
        start += len(line)
    return offsets


def _span(text, name, where):
    """(end of the BEGIN line, start of the END line) of the block ``name``; ``where`` names the page."""
    begin, end = markers(name)
    found = {marker: _marker_lines(text, marker) for marker in (begin, end)}
    for marker, lines in found.items():
        if not lines:
            raise DocsBlockError(f"{where}: no line '{marker}': mark the block of benchmark {name!r} first")
        if len(lines) > 1:
            raise DocsBlockError(f"{where}: {len(lines)} lines '{marker}', expected exactly one")
    (_, after_begin), (before_end, _) = found[begin][0], found[end][0]
    if before_end < after_begin:
        raise DocsBlockError(f"{where}: '{end}' comes before '{begin}'")
    return after_begin, before_end


def replace_block(text, name, block, where="the page"):
    """``text`` with the lines between the markers of block ``name`` replaced by ``block``.

    Parameters
    ----------
    text : str
        The page.
    name : str
        The block's name, as in its markers.
    block : str
        The new content (Markdown); a blank line is kept on each side of it, inside the markers.
    where : str
        The page's name, for the error message.

    Returns
    -------
    str
        The page; everything outside the markers is unchanged, byte for byte.

    Raises
    ------
    DocsBlockError
        When a marker is missing, repeated, or END comes before BEGIN.
    """
    start, stop = _span(text, name, where)
    newline = "\r\n" if "\r\n" in text[:start] else "\n"
    body = block.strip("\n").replace("\n", newline)
    return text[:start] + newline + body + newline + newline + text[stop:]


def _read(page):
    with open(page, encoding="utf-8", newline="") as handle:  # newline="": keep the page's line ends as they are
        return handle.read()


def check_block(page, name):
    """Raise :class:`DocsBlockError` unless ``page`` holds exactly one block ``name`` (OSError if unreadable)."""
    _span(_read(page), name, str(page))


def write_block(page, name, block):
    """Replace block ``name`` of the file ``page`` by ``block``, atomically (a temporary file, then os.replace)."""
    page = Path(page)
    text = replace_block(_read(page), name, block, where=str(page))
    handle, temporary = tempfile.mkstemp(prefix=f".{page.name}.", suffix=".tmp", dir=page.parent)
    try:
        with os.fdopen(handle, "w", encoding="utf-8", newline="") as out:
            out.write(text)
        os.chmod(temporary, stat.S_IMODE(os.stat(page).st_mode))
        os.replace(temporary, page)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(temporary)
        raise


def format_block(command, table):
    """A block's Markdown: ``command`` in a code span, a blank line, ``table`` in a fenced block."""
    return f"`{command}`\n\n```\n{table.strip(chr(10))}\n```\n"


def command_line(script, argv):
    """``python benchmarks/SCRIPT ARGS`` as it was run, without ``--docs`` and ``--docs-page PATH``."""
    kept, skip = [], False
    for arg in argv:
        if skip:
            skip = False
        elif arg == "--docs":
            pass
        elif arg == "--docs-page":
            skip = True
        elif not arg.startswith("--docs-page="):
            kept.append(arg)
    return shlex.join(["python", f"benchmarks/{script}", *kept])


def add_docs_options(parser, page):
    """Add ``--docs`` (write the table into its block of ``page``) and ``--docs-page PATH`` to ``parser``."""
    shown = Path(page).relative_to(REPO_ROOT) if Path(page).is_relative_to(REPO_ROOT) else page
    parser.add_argument("--docs", action="store_true",
                        help=f"write the table, with this command line, into its block of {shown}")
    parser.add_argument("--docs-page", type=Path, metavar="PATH", default=None,
                        help=f"write the block into PATH instead of {shown} (implies --docs)")
    parser.set_defaults(docs_default_page=Path(page))


@dataclass(frozen=True)
class DocsTarget:
    """Where a run writes its blocks, and the command line it puts above them."""

    page: Path
    command: str

    def write(self, name, table):
        """Write ``table`` (the printed text) into block ``name`` of the page, under the command line."""
        write_block(self.page, name, format_block(self.command, table))
        print(f"wrote block {name!r} of {self.page}", file=sys.stderr)


def docs_target(parser, args, argv, script, names):
    """The run's :class:`DocsTarget`, or None without ``--docs``; its blocks ``names`` checked now.

    The check comes before the benchmark runs, so that a page without its markers fails in a second, not
    after the run; a failure is the parser's usage error (exit status 2).
    """
    if not (args.docs or args.docs_page):
        return None
    page = args.docs_page or args.docs_default_page
    try:
        for name in names:
            check_block(page, name)
    except (DocsBlockError, OSError) as error:
        parser.error(str(error))
    return DocsTarget(Path(page), command_line(script, sys.argv[1:] if argv is None else argv))


class _Tee(io.TextIOBase):
    """Writes through to ``stream`` and keeps a copy."""

    def __init__(self, stream):
        self.stream, self.parts = stream, []

    def write(self, text):
        self.parts.append(text)
        return self.stream.write(text)

    def flush(self):
        self.stream.flush()

    @property
    def text(self):
        return "".join(self.parts)


@contextlib.contextmanager
def recording():
    """Print to stdout as usual and keep a copy of it: ``with recording() as printed: ...; printed.text``."""
    tee = _Tee(sys.stdout)
    sys.stdout = tee
    try:
        yield tee
    finally:
        sys.stdout = tee.stream
