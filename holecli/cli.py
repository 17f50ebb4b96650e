"""The ``holecli`` command line: a thin layer over :mod:`holecli.io` and :func:`holecli.detect`.

stdout carries data only; messages go to stderr. Heavy modules (scipy, open3d, rich) are imported
inside the commands so that ``holecli --help`` stays fast.
"""

from __future__ import annotations

import io as _stringio
import sys
import time

import click

from holecli import __version__
from holecli.errors import HoleCliError, LoadError

# Exit codes: documented here, in every --help and in the README.
EXIT_OK = 0
EXIT_INTERNAL = 1
EXIT_USAGE = 2  # click's own
EXIT_INPUT = 3
EXIT_NO_HOLE = 4
EXIT_INTERRUPTED = 130

EXIT_CODES_HELP = (
    "\b\nExit codes:\n"
    "  0  a hole was measured\n"
    "  1  internal error (a bug: please report it)\n"
    "  2  usage error (bad option or argument)\n"
    "  3  input error: the file is missing, unreadable, malformed or has too few points;\n"
    "     or the output file cannot be written\n"
    "  4  no hole found (the record is still printed, with \"holes\": [])\n"
    "  130  interrupted (Ctrl-C)"
)

CONTEXT = {"help_option_names": ["-h", "--help"], "max_content_width": 100}


class Failure(Exception):
    """A failure already phrased for the user: ``Error: <message>`` and an exit code."""

    def __init__(self, message, code):
        super().__init__(message)
        self.code = code


def fail(message, code):
    click.echo(f"Error: {message}", err=True)
    sys.exit(code)


def run_guarded(function, *args, **kwargs):
    """Run a command body, turning every expected failure into one line on stderr and an exit code."""
    try:
        return function(*args, **kwargs)
    except Failure as failure:
        fail(str(failure), failure.code)
    except KeyboardInterrupt:
        click.echo("Error: interrupted", err=True)
        sys.exit(EXIT_INTERRUPTED)
    except BrokenPipeError:
        # The reader of stdout went away (e.g. `| head`): nothing more to say to it.
        sys.stderr.close()
        sys.exit(EXIT_OK)


@click.group(context_settings=CONTEXT, epilog=EXIT_CODES_HELP)
@click.version_option(__version__, "--version", "-V", prog_name="holecli")
def main():
    """Measure drilled holes in 3D scans: center, diameter and surface normal.

    \b
    Examples:
      holecli detect scan.ply
      holecli detect scan.csv --format table
      holecli simulate scene.ply
    """


def measure_file(path, method):
    """Read ``path`` and run the pipeline; returns the detection with file and dropped counts set."""
    from dataclasses import replace

    from holecli.io import read_cloud
    from holecli.pipeline import detect as run_detect

    try:
        cloud = read_cloud(path)
    except LoadError as error:
        raise Failure(str(error), EXIT_INPUT) from None
    try:
        detection = run_detect(cloud.points, method=method)
    except HoleCliError as error:
        raise Failure(f"{path}: {error}", EXIT_INPUT) from None
    return replace(detection, file=str(path), dropped_points=cloud.dropped)


def render(records, fmt):
    """The text of ``records`` (detection dicts) in the requested format."""
    from holecli import report

    if fmt == "json":
        return "".join(report.to_json(record) for record in records)
    if fmt == "csv":
        buffer = _stringio.StringIO()
        report.write_csv(records, buffer)
        return buffer.getvalue()
    return render_table(records)


def render_table(records):
    from rich.console import Console
    from rich.table import Table

    buffer = _stringio.StringIO()
    console = Console(file=buffer, width=140, force_terminal=False, color_system=None)
    for record in records:
        plane = record["plane"]
        table = Table(title=f"{record['file']}  ({record['points']} points, method {record['method']})",
                      caption=f"plane rms {plane['rms']:.4g}, {record['elapsed_ms']:.1f} ms")
        for column in ("hole", "center x", "center y", "center z", "diameter", "normal", "rim pts",
                       "fit rms", "partial"):
            table.add_column(column, justify="right")
        for hole in record["holes"]:
            table.add_row(
                str(hole["index"]), *(f"{v:.4f}" for v in hole["center"]), f"{hole['diameter']:.4f}",
                "(" + ", ".join(f"{v:.4f}" for v in hole["normal"]) + ")", str(hole["rim_points"]),
                f"{hole['fit_rms']:.2g}", "yes" if hole.get("partial") else "no",
            )
        if not record["holes"]:
            table.add_row("-", "", "", "", "no hole found", "", "", "", "")
        console.print(table)
    return buffer.getvalue()


def emit(text, output):
    """Write ``text`` to stdout, or atomically to ``output``."""
    if output is None:
        click.echo(text, nl=False)
        return
    from holecli.outfile import write_text_atomic

    try:
        write_text_atomic(output, text)
    except OSError as error:
        raise Failure(f"{output}: cannot write output: {error.strerror or error}", EXIT_INPUT) from None


@main.command(epilog=EXIT_CODES_HELP)
@click.argument("scan", type=click.Path(path_type=str))
@click.option("--format", "fmt", type=click.Choice(["json", "csv", "table"]), default="json", show_default=True,
              help="Output format: JSON record, CSV (one row per hole) or a table for people.")
@click.option("--output", "-o", type=click.Path(dir_okay=False, path_type=str),
              help="Write the result to this file (atomically) instead of stdout.")
@click.option("--method", type=click.Choice(["paper", "robust"]), default="paper", show_default=True,
              help="Detection method.")
def detect(scan, fmt, output, method):
    """Measure the hole in SCAN (.ply, .pcd, .csv, .txt or .xyz).

    Prints center, diameter and normal of the hole as JSON (units those of the file).

    \b
    Examples:
      holecli detect scan.ply
      holecli detect scan.csv --format csv --output result.csv
    """

    def body():
        detection = measure_file(scan, method)
        record = detection.to_dict()
        emit(render([record], fmt), output)
        return EXIT_OK if record["holes"] else EXIT_NO_HOLE

    code = run_guarded(body)
    if code == EXIT_NO_HOLE:
        click.echo(f"holecli: no hole found in {scan}", err=True)
    sys.exit(code)
