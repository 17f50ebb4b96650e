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


class FloatTuple(click.ParamType):
    """Comma-separated numbers, e.g. ``0,0,1`` (spaces allowed)."""

    def __init__(self, count, names):
        self.count = count
        self.name = names

    def convert(self, value, param, ctx):
        if isinstance(value, tuple):
            return value
        parts = [part.strip() for part in str(value).split(",")]
        try:
            numbers = tuple(float(part) for part in parts)
        except ValueError:
            self.fail(f"expected {self.count} comma-separated numbers ({self.name}), got {value!r}", param, ctx)
        if len(numbers) != self.count or not all(abs(n) < float("inf") for n in numbers):
            self.fail(f"expected {self.count} comma-separated finite numbers ({self.name}), got {value!r}",
                      param, ctx)
        return numbers


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


def measure_file(path, options):
    """Read ``path`` and run the pipeline with ``options`` (keyword arguments of ``detect``).

    Returns the detection with ``file`` and ``dropped_points`` set; raises :class:`Failure`.
    """
    from dataclasses import replace

    from holecli.io import read_cloud
    from holecli.pipeline import detect as run_detect

    try:
        cloud = read_cloud(path)
    except LoadError as error:
        raise Failure(str(error), EXIT_INPUT) from None
    try:
        detection = run_detect(cloud.points, **options)
    except HoleCliError as error:
        raise Failure(f"{path}: {error}", EXIT_INPUT) from None
    return replace(detection, file=str(path), dropped_points=cloud.dropped)


def detection_options(method, view_dir, min_diameter, max_holes, full_only):
    """The ``detect`` keyword arguments of the command-line options; usage error for paper + options."""
    if method == "paper":
        given = [name for name, value in (("--view-dir", view_dir), ("--min-diameter", min_diameter),
                                          ("--max-holes", max_holes), ("--full-only", full_only or None))
                 if value is not None]
        if given:
            raise click.UsageError(f"{', '.join(given)} cannot be used with --method paper")
        return {"method": "paper"}
    return {"method": method, "view_dir": view_dir, "min_diameter": min_diameter, "max_holes": max_holes,
            "full_only": full_only}


def detection_option_decorators(function):
    """The detection options shared by ``detect`` and ``batch``."""
    options = [
        click.option("--method", type=click.Choice(["robust", "paper"]), default="robust", show_default=True,
                     help="robust: every hole, robust to noise and clutter, bias-corrected; "
                          "paper: the published method (one hole, clean data)."),
        click.option("--view-dir", type=FloatTuple(3, "X,Y,Z"), default=None,
                     help="Sensor viewing direction: slide points along it onto the plane instead of "
                          "projecting orthogonally (e.g. 0,0,1)."),
        click.option("--min-diameter", type=click.FloatRange(min=0), default=None,
                     help="Smallest hole diameter reported, file units [default: 6 gap scales of the "
                          "sampling, see README]."),
        click.option("--max-holes", type=click.IntRange(min=1), default=None,
                     help="Report at most N holes (the largest)."),
        click.option("--full-only", is_flag=True, help="Leave out holes cut by the border of the scan."),
    ]
    for option in reversed(options):
        function = option(function)
    return function


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
@detection_option_decorators
def detect(scan, fmt, output, method, view_dir, min_diameter, max_holes, full_only):
    """Measure the holes in SCAN (.ply, .pcd, .csv, .txt or .xyz).

    Prints center, diameter and normal of every hole as JSON (units those of the file).

    \b
    Examples:
      holecli detect scan.ply
      holecli detect scan.csv --format csv --output result.csv
      holecli detect scan.pcd --view-dir 0,0,1 --full-only --format table
    """
    options = detection_options(method, view_dir, min_diameter, max_holes, full_only)

    def body():
        detection = measure_file(scan, options)
        record = detection.to_dict()
        emit(render([record], fmt), output)
        return EXIT_OK if record["holes"] else EXIT_NO_HOLE

    code = run_guarded(body)
    if code == EXIT_NO_HOLE:
        click.echo(f"holecli: no hole found in {scan}", err=True)
    sys.exit(code)


@main.command(epilog="\b\nExit codes: 0 written, 2 usage error, 3 the scene or the output is invalid.")
@click.argument("output", type=click.Path(dir_okay=False, path_type=str))
@click.option("--diameter", type=click.FloatRange(min=0, min_open=True), default=3.0, show_default=True,
              help="Hole diameter (ignored when --hole is given).")
@click.option("--center", type=FloatTuple(2, "X,Y"), default="1,1", show_default=True,
              help="Hole center in the surface frame (ignored when --hole is given).")
@click.option("--hole", "holes", type=FloatTuple(3, "X,Y,DIAMETER"), multiple=True,
              help="A hole X,Y,DIAMETER in the surface frame; repeat for several holes.")
@click.option("--no-hole", is_flag=True, help="Scan a plain surface without any hole.")
@click.option("--spacing", type=click.FloatRange(min=0, min_open=True), default=0.0908, show_default=True,
              help="Point spacing h (along a scan line).")
@click.option("--extent", type=FloatTuple(4, "XMIN,XMAX,YMIN,YMAX"), default="-3,5,-3,5", show_default=True,
              help="Scanned patch in the surface frame.")
@click.option("--pattern", type=click.Choice(["grid", "stripes", "jittered", "random"]), default="grid",
              show_default=True, help="Sampling pattern.")
@click.option("--line-pitch", type=click.FloatRange(min=0, min_open=True), default=None,
              help="Distance between scan lines for --pattern stripes [default: 3 x spacing].")
@click.option("--scan-angle", type=float, default=0.0, show_default=True,
              help="Direction of the scan lines in the surface frame, degrees.")
@click.option("--rotation", type=FloatTuple(3, "AX,AY,AZ"), default="32,0,20", show_default=True,
              help="Rotation in degrees about x, then y, then z (world axes).")
@click.option("--translation", type=FloatTuple(3, "X,Y,Z"), default="3,4,5", show_default=True,
              help="Translation after the rotation.")
@click.option("--noise-z", type=click.FloatRange(min=0), default=0.0, show_default=True,
              help="Gaussian noise sigma on the world z coordinate (the paper's noise).")
@click.option("--noise-normal", type=click.FloatRange(min=0), default=0.0, show_default=True,
              help="Gaussian noise sigma along the surface normal.")
@click.option("--inside-points", type=click.IntRange(min=0), default=0, show_default=True,
              help="Random points inside each hole (reflections; the paper's Fig. 5 uses 10 and 100).")
@click.option("--countersink", type=click.FloatRange(min=0, min_open=True), default=None,
              help="Countersink diameter at the surface (100-degree cone) for every hole.")
@click.option("--bore-depth", type=click.FloatRange(min=0), default=0.0, show_default=True,
              help="Depth of bore-wall points below the surface (0: none).")
@click.option("--outliers", type=click.FloatRange(min=0, max=1), default=0.0, show_default=True,
              help="Fraction of gross outliers.")
@click.option("--ragged", type=click.FloatRange(min=0), default=0.0, show_default=True,
              help="Amplitude of a ragged outer border (0: straight).")
@click.option("--nan-points", type=click.IntRange(min=0), default=0, show_default=True,
              help="NaN rows to append, as a profiler writes for missed points.")
@click.option("--seed", type=int, default=0, show_default=True, help="Random seed.")
@click.option("--truth", "truth_path", type=click.Path(dir_okay=False, path_type=str), default=None,
              help="Where to write the ground truth [default: OUTPUT with .truth.json].")
def simulate(output, diameter, center, holes, no_hole, spacing, extent, pattern, line_pitch, scan_angle, rotation,
             translation, noise_z, noise_normal, inside_points, countersink, bore_depth, outliers, ragged,
             nan_points, seed, truth_path):
    """Write a synthetic scan to OUTPUT (.ply, .pcd, .csv, .txt or .xyz) and its ground truth.

    The defaults reproduce the paper's Table I scene: a 3 mm hole at (1, 1) on a 0.0908 mm grid
    over [-3, 5]^2, rotated (32, 0, 20) degrees and translated by (3, 4, 5).

    \b
    Examples:
      holecli simulate table1.ply
      holecli simulate noisy.csv --noise-z 0.0272 --seed 3
      holecli simulate stripes.pcd --pattern stripes --spacing 0.05 --line-pitch 0.15 \\
          --hole 0,0,3 --hole 5,0,4 --extent -3,8,-3,3
    """

    def body():
        import json
        from pathlib import Path

        from holecli import synth
        from holecli.io import SUPPORTED_EXTENSIONS, save_points
        from holecli.outfile import write_text_atomic

        if Path(output).suffix.lower() not in SUPPORTED_EXTENSIONS:
            raise Failure(f"{output}: unsupported extension (expected {', '.join(SUPPORTED_EXTENSIONS)})",
                          EXIT_INPUT)
        specs = () if no_hole else holes or ((center[0], center[1], diameter),)
        try:
            scene = synth.SceneSpec(
                holes=tuple(synth.HoleSpec(center=(x, y), diameter=d, countersink_diameter=countersink,
                                           bore_depth=bore_depth, inside_points=inside_points)
                            for x, y, d in specs),
                extent=extent, spacing=spacing, pattern=pattern, line_pitch=line_pitch,
                scan_angle_deg=scan_angle, rotation_deg=rotation, translation=translation,
                noise_world_z=noise_z, noise_normal=noise_normal, outlier_fraction=outliers,
                ragged_border=ragged, nan_points=nan_points)
            scan = synth.make_scan(scene, seed)
        except ValueError as error:
            raise Failure(f"{output}: invalid scene: {error}", EXIT_INPUT) from None
        truth = dict(scan.truth, seed=seed, file=Path(output).name)
        target = truth_path or str(Path(output).with_suffix(".truth.json"))
        try:
            save_points(output, scan.points)
            write_text_atomic(target, json.dumps(truth, indent=2) + "\n")
        except OSError as error:
            raise Failure(f"{output}: cannot write: {error.strerror or error}", EXIT_INPUT) from None
        click.echo(f"wrote {len(scan.points)} points to {output} and the ground truth to {target}", err=True)
        return EXIT_OK

    sys.exit(run_guarded(body))
