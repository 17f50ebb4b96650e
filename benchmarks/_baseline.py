"""A baseline revision of holecli, checked out beside the current one, for a same-run comparison.

The machines these benchmarks run on are shared: a figure measured an hour ago under another load is
not comparable with one measured now. ``--baseline REV`` measures each case on REV right after (or
before) the current code, in the same run, and prints the ratio.
"""

from __future__ import annotations

import contextlib
import subprocess
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


@contextlib.contextmanager
def baseline_checkout(revision):
    """A detached git worktree of ``revision`` in a temporary folder (``None`` for no revision), removed
    on exit."""
    if revision is None:
        yield None
        return
    folder = Path(tempfile.mkdtemp(prefix="holecli-baseline-"))
    subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "--detach", "-q", str(folder), revision], check=True)
    try:
        yield folder
    finally:
        subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force", str(folder)], check=False)
