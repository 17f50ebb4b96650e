"""``holecli info``: what a scan holds (points, extent, columns or fields, spacing, unit), before measuring it."""

from __future__ import annotations

import os

import click

from holecli.cli.exits import EXIT_INPUT, EXIT_OK, Failure, run_guarded, write_stdout
from holecli.cli.options import check_verbosity, columns_option, input_format_option, verbosity_option_decorators
from holecli.cli.source import STDIN, check_stdin_format, read_stdin
from holecli.errors import HoleCliError
from holecli.measure import failure_message

INFO_EXIT_CODES_HELP = (
    "\b\nExit codes:\n"
    "  0  the file was read and described\n"
    "  1  internal error (a bug)\n"
    "  2  usage error\n"
    "  3  the file cannot be read (the same one-line errors as detect)\n"
    "  130  interrupted (Ctrl-C, SIGTERM)\n"
    "  141  the reader of the output went away"
)


def render_info(info, fmt):
    """The text of ``info`` (:func:`holecli.io.info.describe_cloud`): indented JSON, or lines for people.

    Parameters
    ----------
    info : dict
    fmt : {"json", "table"}

    Returns
    -------
    str
        Ending in a newline.
    """
    if fmt == "json":
        from holecli import report

        return report.to_json(info)
    from holecli.cli.progress import columns_text

    def number(value):
        return "-" if value is None else f"{value:.6g}"

    def triple(values):
        return ", ".join(number(value) for value in values)

    points, units = info["points"], info["units"]
    lines = [
        f"file        {info['file']}",
        f"format      {info['format'] or '-'}",
        f"points      {points['total']} ({points['finite']} finite, {points['dropped']} dropped: NaN, infinite "
        f"or flagged invalid)",
        f"min         {triple(info['extent']['min'])}",
        f"max         {triple(info['extent']['max'])}",
        f"dimensions  {triple(info['dimensions'])}",
        f"spacing     {number(info['point_spacing'])} (median nearest-neighbour distance)",
    ]
    if info["columns"] is not None:
        lines.append(f"columns     {columns_text(info['columns'])}")
    if info["fields"] is not None:
        lines.append(f"fields      {', '.join(info['fields'])}")
    declared = f"{units['declared']} (from {units['declared_by']})" if units["declared"] else "not declared"
    lines.append(f"unit        {declared}")
    lines.append(f"unit guess  {units['guess'] or '-'}: {units['guess_reason']}")
    return "\n".join(lines) + "\n"


@click.command(epilog=INFO_EXIT_CODES_HELP)
@click.argument("scan", type=click.Path(allow_dash=True, path_type=str))
@input_format_option("Read SCAN in this format, whatever its extension (scan.asc as xyz); needed for - (stdin).")
@columns_option
@click.option("--units", type=click.Choice(("mm", "m", "in")), default=None,
              help="The unit of the file's coordinates, when you know it (said as declared; the guess is "
                   "still made).")
@click.option("--format", "fmt", type=click.Choice(["json", "table"]), default="json", show_default=True,
              help="JSON (indented) or lines for people.")
@verbosity_option_decorators
def info(scan, input_format, columns, units, fmt, quiet, verbose):
    """Describe SCAN (.ply, .pcd, .csv, .txt, .xyz, .e57, .las or .laz; - reads it from stdin, with
    --input-format) before measuring it: its points (total, finite, dropped), extent and dimensions,
    the columns read as x, y, z (text tables) or the fields it holds (PLY, PCD, LAS), the point
    spacing (median distance to the nearest neighbour, on a sample of 2000 points), the unit the file
    declares (E57: m; a text header such as x_mm: mm) and a guess of the unit from the scale (only a
    guess: give --units to detect). Lengths in the file's unit. It says nothing on stderr but errors
    (-q and -v change nothing).

    \b
    Examples:
      holecli info scan.ply
      holecli info scan.csv --format table
      holecli info scan.csv --columns x_mm,y_mm,z_mm
      holecli info scan.asc --input-format xyz
    """
    check_verbosity(quiet, verbose)
    check_stdin_format(scan, input_format)

    def body():
        # (the readers import numpy: not at holecli --help)
        from holecli.io import STDIN_NAME, read_cloud
        from holecli.io.info import describe_cloud, file_fields

        try:
            if scan == STDIN:
                cloud = read_stdin(input_format, columns=columns)
                fields = None if cloud.columns is None or cloud.columns.header is None else list(cloud.columns.header)
            else:
                cloud = read_cloud(scan, input_format=input_format, columns=columns)
                extension = "." + input_format if input_format else os.path.splitext(scan)[1].lower()
                fields = file_fields(scan, extension, cloud.columns)
        except HoleCliError as error:
            raise Failure(failure_message(STDIN_NAME if scan == STDIN else scan, error), EXIT_INPUT) from None
        write_stdout(render_info(describe_cloud(cloud, fields, input_format, units), fmt))

    run_guarded(body)
    raise SystemExit(EXIT_OK)
