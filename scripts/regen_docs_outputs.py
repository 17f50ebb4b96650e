"""Regenerate the docs' outputs that are made by running holecli, from this checkout's real CLI.

    python scripts/regen_docs_outputs.py            # rewrite the docs' printed outputs and the pictures
    python scripts/regen_docs_outputs.py --check    # exit 1 when the docs' printed outputs are stale

What it regenerates:

* the output of the broken-pipe example (:data:`BROKEN_PIPE_PAGE`, "Broken pipes"): the ``sh`` block whose command pipes
  ``holecli batch`` into ``head`` is run with bash from the repository's root, ``holecli`` being this
  checkout's (``python -m holecli``), and the ``text`` block right after it is replaced by what it
  printed: stdout's lines, holecli's stderr line before the last one (the exit code, printed after
  the pipeline ends), the batch summary inside the error line shortened to ``(...)`` (it holds the
  run's wall time);
* ``docs/plot_panel.png``, the picture of :data:`PLOT_PAGE`, with :data:`PLOT_COMMAND` (the command the
  page gives under the picture); not compared by ``--check`` (a PNG differs with matplotlib's version);
* ``docs/report_page.png``, the README's picture of an HTML report: the README's shift (:data:`SHIFT_COMMANDS`,
  run in a temporary folder) reported and rendered by headless chromium (``scripts/report_screenshot.sh``);
  not compared either.

The other printed outputs of the README and the docs are checked, not rewritten, by
``tests/test_readme_examples.py``; the generated reference pages (every ``--help``, the record's
fields) are made at each build by ``scripts/docs_reference.py``.

Run it after a change of the outputs (records, messages, the plot's look) and commit what it wrote.
"""

from __future__ import annotations

import argparse
import os
import re
import stat
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
# The page that holds the broken-pipe example, and the page that shows the picture.
BROKEN_PIPE_PAGE = ROOT / "docs" / "reference" / "exit-codes.md"
PLOT_PAGE = ROOT / "docs" / "guide" / "plot.md"

# The plot page's picture and the command that draws it (the page shows the same command).
PLOT_FILE = "docs/plot_panel.png"
PLOT_COMMAND = ["detect", "sample_clouds/panel.ply", "--spec", "sample_clouds/panel_tolerances.toml", "--units", "mm",
                "--gauge-depth", "0.5", "--plot", PLOT_FILE, "-o", "/dev/null"]

# The README's picture of a report, and the shift it shows (the README's own commands).
README = ROOT / "README.md"
REPORT_FILE = ROOT / "docs" / "report_page.png"
SHIFT_COMMANDS = (
    "holecli simulate lot shift --parts 6 --panel sample_clouds/panel.toml --spacing 0.2 --defect 3/C1=diameter:+0.1 "
    "--defect 5/L1=missing -q",
    "holecli batch shift --spec sample_clouds/panel_tolerances.toml --store shift.sqlite --meta part=PANEL-60 "
    "-o shift.jsonl -q",
    "holecli report --store shift.sqlite --part PANEL-60 -o shift.html",
)

# The sh block of the broken-pipe example and the text block after it.
_BROKEN_PIPE = re.compile(r"(```sh\n(?P<command>holecli batch [^\n]*\| head[^\n]*)\n```\n\n```text\n)(?P<output>.*?)(```)",
                          re.DOTALL)


def _environment(shim_folder):
    """The environment of a docs command: ``holecli`` on PATH runs this checkout's CLI."""
    shim = Path(shim_folder) / "holecli"
    shim.write_text(f'#!/bin/sh\nPYTHONPATH="{ROOT}${{PYTHONPATH:+:$PYTHONPATH}}" exec "{sys.executable}" -m holecli "$@"\n')
    shim.chmod(shim.stat().st_mode | stat.S_IXUSR | stat.S_IXGRP | stat.S_IXOTH)
    return dict(os.environ, PATH=f"{shim_folder}{os.pathsep}{os.environ.get('PATH', '')}", COLUMNS="140")


def broken_pipe_output(command):
    """What the docs' broken-pipe example prints, as the page shows it.

    Parameters
    ----------
    command : str
        The example's command line (bash).

    Returns
    -------
    str
        Its stdout's lines but the last, holecli's stderr (the batch summary shortened to ``(...)``),
        then stdout's last line (the exit code), each ending in a newline.
    """
    with tempfile.TemporaryDirectory() as shims:
        done = subprocess.run(["bash", "-c", command], cwd=ROOT, env=_environment(shims), capture_output=True,
                              text=True, timeout=300)
    out, err = done.stdout.splitlines(), done.stderr.splitlines()
    if len(out) < 2 or len(err) != 1 or not err[0].startswith("Error: stdout: broken pipe"):
        raise SystemExit(f"the broken-pipe example did not print what it should:\nstdout:\n{done.stdout}\nstderr:\n"
                         f"{done.stderr}")
    shortened = re.sub(r" \(\d+ files?: .*\)$", " (...)", err[0])
    return "\n".join([*out[:-1], shortened, out[-1]]) + "\n"


def regenerate_page(text):
    """``text`` (:data:`BROKEN_PIPE_PAGE`'s) with the broken-pipe example's output run anew."""
    match = _BROKEN_PIPE.search(text)
    if match is None:
        raise SystemExit(f"{BROKEN_PIPE_PAGE.relative_to(ROOT)}: the broken-pipe example (a sh block piping holecli batch into head, then a text "
                         "block) was not found")
    output = broken_pipe_output(match["command"])
    return text[:match.start("output")] + output + text[match.end("output"):]


def draw_plot():
    """Draw :data:`PLOT_FILE` with :data:`PLOT_COMMAND`."""
    with tempfile.TemporaryDirectory() as shims:
        subprocess.run(["holecli", *PLOT_COMMAND, "-q"], cwd=ROOT, env=_environment(shims), check=True, timeout=300)


def draw_report_page():
    """Draw :data:`REPORT_FILE`: the top of the README's shift report, 1280 x 1150 CSS pixels."""
    import shutil

    with tempfile.TemporaryDirectory() as shims, tempfile.TemporaryDirectory() as folder:
        shutil.copytree(ROOT / "sample_clouds", Path(folder) / "sample_clouds")
        env = _environment(shims)
        for command in SHIFT_COMMANDS:
            done = subprocess.run(["bash", "-c", command], cwd=folder, env=env, timeout=600)
            if done.returncode not in (0, 5):  # batch: 5, parts out of tolerance
                raise SystemExit(f"{command}: exit {done.returncode}")
        subprocess.run([str(ROOT / "scripts" / "report_screenshot.sh"), "shift.html", str(REPORT_FILE), "1280", "1150"],
                       cwd=folder, env=env, check=True, timeout=300)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--check", action="store_true", help="only say whether the docs' outputs are stale (exit 1)")
    args = parser.parse_args(argv)
    plot_page = PLOT_PAGE.read_text(encoding="utf-8")
    picture = PLOT_FILE.removeprefix("docs/")
    if picture not in plot_page or " ".join(PLOT_COMMAND[:2]) not in plot_page:
        raise SystemExit(f"{PLOT_PAGE.relative_to(ROOT)} no longer shows {picture} or its command: update PLOT_COMMAND")
    readme = README.read_text(encoding="utf-8")
    if REPORT_FILE.name not in readme or not all(command in readme for command in SHIFT_COMMANDS):
        raise SystemExit(f"README.md no longer shows {REPORT_FILE.name} or its shift's commands: update SHIFT_COMMANDS")
    page = BROKEN_PIPE_PAGE.read_text(encoding="utf-8")
    new = regenerate_page(page)
    name = BROKEN_PIPE_PAGE.relative_to(ROOT)
    if args.check:
        if new != page:
            print(f"{name}: the broken-pipe example's output is stale: run python scripts/regen_docs_outputs.py",
                  file=sys.stderr)
            return 1
        return 0
    if new != page:
        BROKEN_PIPE_PAGE.write_text(new, encoding="utf-8")
    draw_plot()
    draw_report_page()
    print(f"regenerated the broken-pipe example's output in {name}, {PLOT_FILE} and {REPORT_FILE.relative_to(ROOT)}",
          file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
