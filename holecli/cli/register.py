"""``holecli register``: the rigid transform part (CAD) frame -> measuring frame from scans of reference holes.

Every SCAN is measured as ``holecli detect`` measures it; its holes are matched with the ``--spec``
file's nominal holes and :func:`holecli.registration.register` fits the transform. The result (JSON,
CSV or a table) goes to stdout or ``--output``, the corrected targets (``--targets``) to
``--targets-output``; both are written together (:func:`holecli.cli.outputs.write_outputs`) once the
whole registration succeeded: when either cannot be written, neither file is replaced. No output may
be a SCAN, the ``--spec`` or the ``--targets`` file, or the other output.
"""

from __future__ import annotations

import csv
import io as _stringio
import os
import sys

import click

from holecli.cli.exits import EXIT_INPUT, EXIT_USAGE, Failure, exit_code, run_guarded
from holecli.cli.options import Decimal, columns_option, detection_option_decorators, detection_options
from holecli.cli.outputs import write_outputs
from holecli.cli.render import NARROW_TABLE_BELOW, table_width
from holecli.cli.source import measure
from holecli.tally import Tally

REGISTER_EXIT_CODES_HELP = (
    "\b\nExit codes:\n"
    "  0  registered (and, with --max-residual, the verdict is pass)\n"
    "  1  internal error (a bug: please report it)\n"
    "  2  usage error (bad option or argument; a --name whose SCAN is not given or whose HOLE is not\n"
    "     in the spec; an output that is the same file as an input or as the other output)\n"
    "  3  input error: a SCAN or the --spec or --targets file is missing, unreadable or invalid, the\n"
    "     holes cannot be registered (too few to match, none matched, a fit that turns the part over:\n"
    "     normals_reversed), or an output cannot be written (then neither output is written)\n"
    "  4  a SCAN has no hole (nothing is written)\n"
    "  5  --max-residual: the verdict is fail (a used hole's residual exceeds it, an outlier was\n"
    "     named, or the holes are inconsistent); the output is still written\n"
    "  8  doubtful: a reference hole disagrees with the others or with the spec beyond the\n"
    "     uncertainties (warning outlier or inconsistent_holes, any count from 2 holes); the output\n"
    "     is still written, with widened uncertainties (5 takes precedence)\n"
    "  130  interrupted (Ctrl-C or SIGTERM)\n"
    "  141  broken pipe: the reader of the output (| head -1) stopped reading before its end"
)

SCHEMA = "holecli.register"
# The record's MAJOR version stays the integer ``schema_version`` it always was (a reader comparing it
# with 1 keeps working); ``schema_minor_version`` counts the keys added since (absent: 0). 1.1 (issue
# 24): ``notes``, the facts that make nothing doubtful (unmatched_hole, no_uncertainty), out of warnings.
# 1.2 (issue 25): ``consistency``, the test of the holes against their uncertainties (inconsistent_holes).
SCHEMA_VERSION = 1
SCHEMA_MINOR_VERSION = 2

CSV_HOLE_COLUMNS = ("name", "scan", "scan_hole", "used", "outlier", "measured_x", "measured_y", "measured_z",
                    "nominal_x", "nominal_y", "nominal_z", "residual_in_plane", "residual_along_normal",
                    "residual_normal_angle_deg")
CSV_TRANSFORM_COLUMNS = ("t_x", "t_y", "t_z", "q_w", "q_x", "q_y", "q_z", "roll_deg", "pitch_deg", "yaw_deg",
                         "u_t_x", "u_t_y", "u_t_z", "u_rot_x_deg", "u_rot_y_deg", "u_rot_z_deg", "rms",
                         "free_dofs", "verdict")
CSV_COLUMNS = CSV_HOLE_COLUMNS + CSV_TRANSFORM_COLUMNS


class NamePair(click.ParamType):
    """``--name SCAN=HOLE``."""

    name = "SCAN=HOLE"

    def convert(self, value, param, ctx):
        if isinstance(value, tuple):
            return value
        scan, sep, hole = str(value).rpartition("=")
        if not sep or not scan or not hole:
            self.fail(f"{value!r}: expected SCAN=HOLE (a scan given as argument, a hole name of the spec)", param, ctx)
        return scan, hole


def _scan_names(scans, pairs, hole_names, spec_file):
    """{scan: hole name or None}: ``--name`` first, else the file stem when it is a spec hole's name."""
    from holecli.inspection import scan_stem  # (not at holecli --help: it imports holecli.tolerance)

    names = {}
    for scan, hole in pairs:
        matches = [s for s in scans if scan in (s, os.path.basename(s), scan_stem(s))]
        if not matches:
            raise Failure(f"--name {scan}={hole}: {scan} is not one of the SCAN arguments", EXIT_USAGE)
        if hole not in hole_names:
            raise Failure(f"--name {scan}={hole}: no hole {hole!r} in {spec_file} (its holes: "
                          f"{', '.join(hole_names)})", EXIT_USAGE)
        for match in matches:
            names[match] = hole
    for scan in scans:
        if scan not in names:
            names[scan] = scan_stem(scan) if scan_stem(scan) in hole_names else None
    return names


def render_csv(record):
    """One row per matched hole (:data:`CSV_HOLE_COLUMNS`), the transform repeated on every row
    (:data:`CSV_TRANSFORM_COLUMNS`); empty cells for values not known."""
    buffer = _stringio.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(CSV_COLUMNS)
    from holecli.report import csv_cell

    transform, uncertainty = record["transform"], record["uncertainty"]
    common = [*transform["translation"], *transform["quaternion_wxyz"], *transform["roll_pitch_yaw_deg"],
              *uncertainty["translation"], *uncertainty["rotation_deg"], record["rms"], record["free_dofs"],
              record["verdict"]]
    for hole in record["holes"]:
        residual = hole["residual"]
        row = [hole["name"], hole["scan"], hole["scan_hole"], hole["used"], hole["outlier"], *hole["measured_center"],
               *hole["nominal_center"], residual["in_plane"], residual["along_normal"], residual["normal_angle_deg"],
               *common]
        writer.writerow([csv_cell(value) for value in row])
    return buffer.getvalue()


def render_table(record, width=None):
    """The ``--format table`` text: the transform with its uncertainties, then one row per hole.

    Parameters
    ----------
    record : dict
        A ``register`` record.
    width : int, optional
        The width of the text (default: the terminal's, :func:`holecli.cli.render.table_width`); under
        :data:`holecli.cli.render.NARROW_TABLE_BELOW` the transform is one row per quantity, its three
        values over their standard uncertainties.

    Returns
    -------
    str
        No line longer than ``width``.
    """
    from rich.console import Console
    from rich.table import Table

    width = table_width() if width is None else width
    buffer = _stringio.StringIO()
    console = Console(file=buffer, width=width, force_terminal=False, color_system=None)

    def number(value, digits=4):
        return "-" if value is None else f"{value:.{digits}f}"

    transform, uncertainty = record["transform"], record["uncertainty"]
    quaternion = ", ".join(f"{v:.8f}" for v in transform["quaternion_wxyz"])
    free = ("free: " + ", ".join(record["free_dofs"])) if record["free_dofs"] else None
    title = f"part -> measuring frame ({len(record['holes'])} holes, spec {record['spec']['file']})"
    if width < NARROW_TABLE_BELOW:
        table = Table(title=title, caption=free)
        table.add_column("quantity", justify="left", no_wrap=True)
        table.add_column("x, y, z; u x, y, z", justify="left")
        table.add_row("translation", ", ".join(number(v) for v in transform["translation"]) + "\nu "
                      + ", ".join(number(v, 6) for v in uncertainty["translation"]))
        table.add_row("roll/pitch/yaw deg", ", ".join(number(v, 5) for v in transform["roll_pitch_yaw_deg"]) + "\nu "
                      + ", ".join(number(v, 6) for v in uncertainty["rotation_deg"]))
        table.add_row("quaternion w,x,y,z", quaternion)
    else:
        table = Table(title=title, caption=free)
        for column in ("quantity", "x", "y", "z", "u x", "u y", "u z"):
            table.add_column(column, justify="left" if column == "quantity" else "right")
        table.add_row("translation", *(number(v) for v in transform["translation"]),
                      *(number(v, 6) for v in uncertainty["translation"]))
        table.add_row("roll/pitch/yaw deg", *(number(v, 5) for v in transform["roll_pitch_yaw_deg"]),
                      *(number(v, 6) for v in uncertainty["rotation_deg"]))
        table.add_row("quaternion w,x,y,z", quaternion, "", "", "", "", "")
    console.print(table)
    verdict = record["verdict"]
    caption = f"rms {number(record['rms'], 6)}"
    if record["max_residual"] is not None:
        caption += f"; max residual {record['max_residual']:g}: {verdict.upper()}"
        if record["failed"]:
            caption += " (" + "; ".join(record["failed"]) + ")"
    holes = Table(title="residuals after the fit", caption=caption)
    for column in ("hole", "scan", "used", "in plane", "along normal", "normal deg"):
        holes.add_column(column, justify="left" if column in ("hole", "scan", "used") else "right",
                         no_wrap=column in ("hole", "used"))
    for hole in record["holes"]:
        residual = hole["residual"]
        holes.add_row(hole["name"], f"{hole['scan']} #{hole['scan_hole']}",
                      "OUTLIER" if hole["outlier"] else "yes", number(residual["in_plane"], 6),
                      number(residual["along_normal"], 6), number(residual["normal_angle_deg"], 4))
    console.print(holes)
    return buffer.getvalue()


def verbose_lines(record):
    """What ``register --verbose`` says on stderr after each scan's account: the match (how, the holes
    left unmatched) and, per matched hole, the scan and hole it is, whether it was used and its residuals.

    Parameters
    ----------
    record : dict
        A ``register`` record.

    Returns
    -------
    list of str
        Lines starting with ``holecli: ``.

    Examples
    --------
    >>> record = {"match": {"method": "names", "ambiguous": False, "unmatched_measured": [],
    ...                     "unmatched_nominal": ["A5"]}, "rms": 0.0001, "dof": 3, "free_dofs": [],
    ...           "holes": [{"name": "A1", "scan": "A1.ply", "scan_hole": 0, "used": True, "outlier": False,
    ...                      "residual": {"in_plane": 0.00012, "along_normal": 1e-07, "normal_angle_deg": 6e-06}}]}
    >>> print("\\n".join(verbose_lines(record)))
    holecli: register: match by names, 1 hole; spec holes not measured: A5
    holecli:   A1 = A1.ply hole 0: used; residual 0.00012 in plane, 1e-07 along normal, 6e-06 deg
    holecli:   rms 0.0001, 3 degrees of freedom left, no free rotation or translation
    """
    match = record["match"]
    count = len(record["holes"])
    line = f"holecli: register: match by {match['method']}, {count} hole{'' if count == 1 else 's'}"
    if match.get("ambiguous"):
        line += " (ambiguous: other pairings fit as well)"
    if match.get("unmatched_nominal"):
        line += "; spec holes not measured: " + ", ".join(map(str, match["unmatched_nominal"]))
    if match.get("unmatched_measured"):
        line += "; measured holes matching no spec hole: " + ", ".join(
            f"{item['scan']} hole {item['scan_hole']}" for item in match["unmatched_measured"])
    lines = [line]
    for hole in record["holes"]:
        residual = hole["residual"]
        used = "OUTLIER, left out" if hole["outlier"] else ("used" if hole["used"] else "not used")
        lines.append(f"holecli:   {hole['name']} = {hole['scan']} hole {hole['scan_hole']}: {used}; residual "
                     f"{residual['in_plane']:.3g} in plane, {residual['along_normal']:.3g} along normal, "
                     f"{residual['normal_angle_deg']:.3g} deg")
    free = ", ".join(record.get("free_dofs") or ()) or "no free rotation or translation"
    rms = "-" if record.get("rms") is None else f"{record['rms']:.3g}"
    lines.append(f"holecli:   rms {rms}, {record.get('dof')} degrees of freedom left, {free}")
    return lines


def render(record, fmt):
    """The text of ``record`` as ``--format`` asks: JSON, CSV or a table."""
    if fmt == "json":
        from holecli import report

        return report.to_json(record)
    if fmt == "csv":
        return render_csv(record)
    return render_table(record)


def targets_in_units(targets, units):
    """``targets`` with their points in ``units`` (the scans', else the spec's declared one), when the
    targets file declares its own (``# units = in``) and ``units`` is known; else ``targets`` itself
    (their numbers taken in the scans' unit).

    Parameters
    ----------
    targets : holecli.io.targets.Targets
    units : {"mm", "m", "in"} or None

    Returns
    -------
    holecli.io.targets.Targets
    """
    import dataclasses

    from holecli.units import scale_factor

    if targets.units is None or units is None or targets.units == units:
        return targets
    return dataclasses.replace(targets, points=targets.points * scale_factor(targets.units, units), units=units)


def registration_tally(record):
    """The counts of a ``register`` record for :func:`holecli.cli.exits.exit_code`: a failed verdict
    (``--max-residual``) is out of tolerance; an outlier or inconsistent holes (a reference hole that
    disagrees) undecided.

    Parameters
    ----------
    record : dict
        A ``register`` record.

    Returns
    -------
    holecli.tally.Tally
    """
    doubtful = bool(record["outliers"]) or not (record["consistency"] or {"consistent": True})["consistent"]
    return Tally(files=1, holes=len(record["holes"]), out_of_tolerance=int(record["verdict"] == "fail"),
                 undecided=int(doubtful))


@click.command(epilog=REGISTER_EXIT_CODES_HELP)
@click.argument("scans", metavar="SCAN...", nargs=-1, required=True, type=click.Path(path_type=str))
@click.option("--spec", "spec_file", required=True, type=click.Path(dir_okay=False, path_type=str), metavar="FILE.toml",
              help="The part's nominal holes ([[hole]] name, center, normal, ...), in the part (CAD) frame.")
@click.option("--name", "name_pairs", type=NamePair(), multiple=True,
              help="SCAN's hole is the spec hole HOLE (repeatable); by default a scan whose file stem is a spec "
                   "hole's name is that hole, other scans' holes are matched by their mutual distances.")
@click.option("--targets", "targets_file", type=click.Path(dir_okay=False, path_type=str), default=None,
              metavar="FILE.csv",
              help="Nominal drilling targets in the part frame (header name,x,y,z,nx,ny,nz); needs --targets-output.")
@click.option("--targets-output", type=click.Path(dir_okay=False, allow_dash=True, path_type=str), default=None,
              metavar="FILE.csv",
              help="Write the targets mapped into the measuring frame here (name,x,y,z,nx,ny,nz,u_x,u_y,u_z,"
                   "u_normal_deg; - is stdout, then the result needs --output).")
@click.option("--max-residual", type=Decimal(min=0, min_open=True), default=None,
              help="Verdict: fail when a used hole's in-plane or along-normal residual exceeds this (file units), "
                   "or when an outlier is named.")
@click.option("--outlier-factor", type=Decimal(min=0, min_open=True), default=5.0, show_default=True,
              help="A hole is an outlier when the other holes place it more than this many standard "
                   "uncertainties from where it was measured (leave-one-out, 4 or more holes); the holes are "
                   "inconsistent when the fit's chi-square is as unlikely as this many (2 or more holes).")
@click.option("--outlier-floor", type=Decimal(min=0), default=0.0, show_default=True,
              help="... and more than this far (file units); also the largest center discrepancy below which "
                   "holes are never inconsistent.")
@click.option("--format", "fmt", type=click.Choice(["json", "csv", "table"]), default="json", show_default=True,
              help="Output format: JSON, CSV (one row per hole, the transform in columns) or a table for people.")
@click.option("--output", "-o", type=click.Path(dir_okay=False, allow_dash=True, path_type=str), default=None,
              help="Write the result to this file (atomically; - is stdout) instead of stdout; with "
                   "--targets-output, both are written or neither.")
@columns_option
@detection_option_decorators
@click.option("--quiet", "-q", is_flag=True, help="Say nothing on stderr but errors (no warnings, notes or verdict line).")
@click.option("--verbose", "-v", is_flag=True,
              help="Also say on stderr what each scan's measurement chose (as detect -v), the match and each "
                   "hole's residuals.")
def register(scans, columns, spec_file, name_pairs, targets_file, targets_output, max_residual, outlier_factor, outlier_floor,
             fmt, output, method, view_dir, min_diameter, max_holes, full_only, gauge_depth, quiet, verbose):
    """Register a part: fit the rigid transform from the part (CAD) frame of --spec to the frame of the
    SCANs (a robot's, any measuring frame) from the part's reference holes.

    Each SCAN is measured as holecli detect measures it (one scan per reference hole, or a scan holding
    several). Its holes are matched with the spec's holes by name (a scan named after a hole, A1.ply
    for hole A1, or --name SCAN=HOLE), else by their mutual distances (3 or more holes). The fit is a
    weighted least squares on centers and normals; a hole that the others place far from where it was
    measured is named as an outlier and left out (4 or more holes), and holes that disagree with the
    spec beyond their uncertainties (any count from 2: the distance between two holes, their normals,
    the fit's residuals) give the warning inconsistent_holes, widened uncertainties and exit 8. With two holes the normals fix the rotation about
    the line through them; with one hole the rotation about its normal stays free (said in
    "free_dofs").

    \b
    Examples:
      holecli register A1.ply A2.ply A3.ply A4.ply --spec part.toml
      holecli register A1.ply A2.ply A3.ply --spec part.toml --max-residual 0.05 --format table
      holecli register left.ply right.ply --spec part.toml --name left.ply=A1 --name right.ply=A2
      holecli register panel.ply --spec part.toml --format csv -o registration.csv
      holecli register A*.ply --spec part.toml --targets targets.csv --targets-output corrected.csv
      holecli register A1.ply A2.ply A3.ply --spec part.toml -v
    """
    if quiet and verbose:
        raise click.UsageError("--quiet and --verbose cannot be combined")
    if targets_output is not None and targets_file is None:
        raise click.UsageError("--targets-output needs --targets")
    if targets_file is not None and targets_output is None:
        raise click.UsageError("--targets needs --targets-output (where to write the corrected targets)")
    if targets_output == "-" and (output is None or output == "-"):
        raise click.UsageError("--targets-output - and the result cannot both go to stdout: give --output FILE")
    options = detection_options(method, view_dir, min_diameter, max_holes, full_only, gauge_depth)
    if columns is not None:
        options["columns"] = columns

    def body():
        from holecli import __version__
        from holecli.cli.options import read_spec, refuse_same_files
        from holecli.errors import HoleCliError
        from holecli.registration import RegistrationError
        from holecli.registration import register as register_holes

        if "-" in scans:  # (measure reads a path here; stdin needs --input-format, which register has not)
            raise Failure("-: holecli register cannot read a scan from standard input: give each scan as a file",
                          EXIT_USAGE)
        # before anything is read: the robot's targets, the spec or a scan are never written over
        refuse_same_files([*(("SCAN", scan) for scan in scans), ("--spec", spec_file), ("--targets", targets_file)],
                          [("--targets-output", targets_output), ("-o/--output", output)])
        spec = read_spec(spec_file)
        hole_names = [hole.name for hole in spec.holes]
        names = _scan_names(scans, name_pairs, hole_names, spec_file)
        targets = None
        if targets_file is not None:
            from holecli.io.targets import read_targets

            try:
                targets = read_targets(targets_file)
            except HoleCliError as error:
                raise Failure(str(error), EXIT_INPUT) from None
        measured, measured_names, origin, scan_records = [], [], [], []
        for scan in scans:
            detection = measure(scan, options).detection
            scan_units = detection.units
            if verbose:
                from holecli.cli.progress import verbose_text

                accounts.append(verbose_text(detection.to_dict()))
            if not detection.holes:  # no registration without it: the exit code of a scan without a hole
                raise Failure(f"{scan}: no hole found", exit_code(Tally(files=1, without_hole=1)))
            name = names[scan]
            if name is not None and len(detection.holes) > 1:
                raise Failure(f"{scan}: is hole {name!r} but holds {len(detection.holes)} holes (give --max-holes 1, "
                              "or leave it unnamed to match its holes by distances)", EXIT_INPUT)
            for hole in detection.holes:
                measured.append(hole)
                measured_names.append(name)
                origin.append((scan, hole.index))
            scan_records.append({"file": scan, "holes": len(detection.holes), "name": name})
        # a spec that declares its unit, in the scans' when their format says it (E57: metres)
        from holecli.tolerance import spec_in_units

        spec = spec_in_units(spec, scan_units)
        if targets is not None:
            targets = targets_in_units(targets, scan_units or spec.units)
        try:
            result = register_holes(measured, spec.holes,
                                    measured_names=measured_names if any(measured_names) else None,
                                    max_residual=max_residual, outlier_factor=outlier_factor,
                                    outlier_floor=outlier_floor)
        except RegistrationError as error:
            raise Failure(f"{spec_file}: cannot register: {error}", EXIT_INPUT) from None
        record = {"schema": SCHEMA, "schema_version": SCHEMA_VERSION, "schema_minor_version": SCHEMA_MINOR_VERSION,
                  "holecli_version": __version__,
                  "units": "file units of the scans and the spec",
                  "spec": {"file": spec_file, "sha256": spec.sha256}, "scans": scan_records}
        registration = result.to_dict()
        for hole in registration["holes"]:
            hole["scan"], hole["scan_hole"] = origin[hole["measured_index"]]
        registration["match"]["unmatched_measured"] = [
            {"scan": origin[i][0], "scan_hole": origin[i][1]} for i in registration["match"]["unmatched_measured"]]
        record.update(registration)
        record["targets"] = None
        targets_text = None
        if targets is not None:
            from holecli.io.targets import format_targets

            rows = result.corrected_targets(targets)
            targets_text = format_targets(rows)
            record["targets"] = {"file": targets_file, "output": targets_output, "count": len(rows)}
        outputs = [] if targets_text is None else [(targets_output, targets_text, "the corrected targets")]
        outputs.append((output, render(record, fmt), "output"))
        # all or none: corrected targets are never replaced by a run that then fails to write its result
        write_outputs(outputs)
        return record

    accounts = []  # --verbose: what each scan's measurement chose
    record = run_guarded(body)
    if verbose:
        click.echo("".join(accounts) + "\n".join(verbose_lines(record)), err=True)
    if not quiet:
        for warning in record["warnings"]:
            click.echo(f"holecli: warning: register: {warning['code']}: {warning['message']}", err=True)
        for note in record["notes"]:
            click.echo(f"holecli: note: register: {note['code']}: {note['message']}", err=True)
    if record["verdict"] == "fail" and not quiet:
        click.echo(f"holecli: registration fails --max-residual {record['max_residual']:g}: "
                   + "; ".join(record["failed"]), err=True)
    sys.exit(exit_code(registration_tally(record)))
