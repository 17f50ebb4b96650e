"""``holecli detect``: measure the holes of one scan and print the record (JSON, CSV or a table)."""

from __future__ import annotations

import sys

import click

from holecli.cli.exits import EXIT_CODES_HELP, EXIT_OUT_OF_TOLERANCE, EXIT_UNDECIDED, exit_code, run_guarded
from holecli.cli.options import (check_verbosity, columns_option, decision_from_options,
                                 detection_option_decorators,
                                 detection_options, fail_on_warning_option, input_format_option, nominal_from_options,
                                 inspection_from_options, read_spec, reading_option_decorators,
                                 refuse_same_files, registration_option_decorators, require_gauge_depth,
                                 tolerance_option_decorators,
                                 unit_choice,
                                 verbosity_option_decorators, with_decision)
from holecli.cli.options import check_fields, fields_option
from holecli.cli.outputs import write_outputs
from holecli.cli.render import (min_diameter_hint, refused_summary, render, scale_hint, spec_units_line, undecided_line,
                                unit_mismatch_hint, warning_lines, zone_note_lines)
from holecli.cli.source import check_stdin_format, measure
from holecli.tally import Tally


@click.command(epilog=EXIT_CODES_HELP)
@click.argument("scan", type=click.Path(allow_dash=True, path_type=str))
@input_format_option("Read SCAN in this format, whatever its extension (scan.asc as xyz); needed for - (stdin).")
@columns_option
@click.option("--format", "fmt", type=click.Choice(["json", "jsonl", "csv", "table"]), default="json", show_default=True,
              help="Output format: JSON record (indented), JSON Lines (the record on one compact line, as batch "
                   "writes it: for appending to a log), CSV (one row per hole) or a table for people (fitted to the "
                   "terminal, with U = k·u beside the values; a block per hole under 100 columns).")
@fields_option()
@click.option("--output", "-o", type=click.Path(dir_okay=False, allow_dash=True, path_type=str),
              help="Write the result to this file (a regular file atomically; - is stdout) instead of stdout; "
                   "with --plot, both are written or neither. Never SCAN, --spec or the --plot file.")
@click.option("--plot", "plot_file", type=click.Path(path_type=str), default=None, metavar="FILE.png|DIR/",
              help="Also draw the holes into this PNG, as holecli plot does, with the verdict when tolerances are "
                   "given; a folder (existing, or ending with /: created) gets SCAN's stem .png "
                   "(needs pip install 'holecli[plot]').")
@click.option("--explain", is_flag=True,
              help="Also list every candidate that is not a hole, with the check that refused it "
                   "(\"rejected\" in JSON, a second table with --format table).")
@reading_option_decorators
@detection_option_decorators
@tolerance_option_decorators
@registration_option_decorators(plain_name=True)
@fail_on_warning_option
@verbosity_option_decorators
def detect(scan, input_format, columns, fmt, fields, output, plot_file, explain, scan_index, units, output_units,
           method, view_dir, min_diameter, max_holes, full_only, gauge_depth, spec_file, decision_rule,
           coverage_factor, registration_file, name_pairs, fail_on_warning, quiet, verbose, **nominal_options):
    """Measure the holes in SCAN (.ply, .pcd, .csv, .txt, .xyz, .e57, .las or .laz; - reads it from
    stdin, with --input-format).

    Prints center, diameter and normal of every hole as JSON (units those of the file, or
    --output-units). With tolerance options or --spec, every checked hole also gets its deviations
    and "in_tolerance", and the record a "verdict".

    \b
    Examples:
      holecli detect scan.ply
      holecli detect scan.csv --format csv --output result.csv
      holecli detect scan.ply --format csv --fields file,hole,diameter,u_diameter
      holecli detect scan.pcd --view-dir 0,0,-1 --full-only --format table
      holecli detect scan.ply --nominal-diameter 3 --tolerance +0.036/-0
      holecli detect scan.ply --nominal-diameter 3 --tolerance +0.036/-0 --decision-rule guarded
      holecli detect scan.ply --nominal-center 3.65,5.14,5.53 --position-tolerance 0.1 \\
          --nominal-normal 0.18,-0.5,0.85 --max-tilt 1
      holecli detect scan.ply --countersink-angle 100 --countersink-angle-tolerance 1 \\
          --countersink-diameter 7 --countersink-diameter-tolerance +0.1/-0 --max-perpendicularity 0.5
      holecli detect scan.ply --gauge-depth 0.5
      holecli detect scan.ply --spec part.toml --format table
      holecli detect R1.ply --spec part.toml --registration registration.json
      holecli detect left.ply --spec part.toml --name R1
      holecli detect scan.ply --explain --format table
      holecli detect scan.ply --plot fit.png
      holecli detect scan.ply --nominal-diameter 3 --tolerance +0.036/-0 --plot plots/
      cat scan.ply | holecli detect - --input-format ply -o -
      holecli detect scan.asc --input-format xyz
      holecli detect scan.csv --columns x_mm,y_mm,z_mm
      holecli detect site.e57 --scan 1 --output-units mm
      holecli detect scan.ply --units m --output-units mm --nominal-diameter 3 --tolerance 0.02
      holecli detect scan.ply -v
      holecli detect scan.ply --fail-on-warning rim_gap,points_inside,near_border

    A hole's warnings (a result that may be wrong: rim_gap, points_inside, ...) are also said on
    stderr, one line each (not with --quiet); its notes (why a value is null: bore_not_seen, ...) are
    in the record's notes, and on stderr with --verbose.
    """
    check_verbosity(quiet, verbose)
    check_fields(fields, fmt)
    check_stdin_format(scan, input_format)
    if explain and fmt == "csv":
        raise click.UsageError("--explain needs --format json or table (CSV has one row per hole)")
    choice = unit_choice(units, output_units, [scan])
    # lengths on the command line are in the output unit: the pipeline wants the file's
    options = detection_options(method, view_dir, choice.to_file_units(min_diameter), max_holes, full_only,
                                choice.to_file_units(gauge_depth))
    if input_format is not None:
        options["input_format"] = input_format
    if columns is not None:
        options["columns"] = columns
    # the tolerance options (--nominal-diameter, ..., --max-perpendicularity) by their parameter names
    nominal = nominal_from_options(spec_file, **nominal_options)
    decision = decision_from_options(decision_rule, coverage_factor, nominal is not None or spec_file is not None)
    require_gauge_depth(nominal, gauge_depth)

    refused = []  # the checks that refused candidates, for "no hole found"
    far = []  # (distance, name) when no measured hole lies near any spec hole
    scaled = []  # (factor, scan unit, spec unit) when they would, in other units

    def body():
        from holecli.cli.progress import DetectStatus
        plot_path = None
        if plot_file is not None:
            from holecli.cli.plot import plot_path_of

            plot_path = plot_path_of(plot_file, scan)
        # before anything is read or made: no output may replace an input or another output
        refuse_same_files([("SCAN", scan), ("--spec", spec_file), ("--registration", registration_file)],
                          [("-o/--output", output), ("--plot", plot_path)])
        spec = with_decision(read_spec(spec_file) if spec_file is not None else nominal, decision)
        require_gauge_depth(spec, gauge_depth, spec_file)
        inspection = inspection_from_options(spec, spec_file, registration_file, name_pairs, [scan])
        if plot_file is not None:
            from holecli.cli.plot import plot_destination, require_matplotlib

            require_matplotlib()  # before the detection: a missing extra is said at once
            plot_path = plot_destination(plot_file, scan)  # and a folder that cannot be made
        with DetectStatus(scan, quiet=quiet) as status:
            run_options = {**options, "progress": status.stage} if status.shown else options
            measurement = measure(scan, run_options, scan_index, units=choice, spec=inspection, explain=explain,
                                  plot=plot_file is not None)
        record = measurement.record
        refused.extend(rejection.check for rejection in measurement.detection.rejected)
        if spec is not None:
            from holecli.tolerance import far_from_spec, unit_scale_match

            far.append(far_from_spec(record, measurement.spec))
            scaled.append(unit_scale_match(record, measurement.spec))
        outputs = [(output, render([record], fmt, fields), "output")]
        if plot_file is not None:
            from holecli.cli.plot import PLOT_WHAT, plot_png

            outputs.append((plot_path, plot_png(measurement), PLOT_WHAT))
        # the record and the picture together: when either cannot be written, neither is
        write_outputs(outputs)
        return record

    record = run_guarded(body)
    if verbose:
        from holecli.cli.progress import verbose_text

        click.echo(verbose_text(record), err=True, nl=False)
    if not quiet:
        for line in warning_lines(record):
            click.echo(line, err=True)
        assumed = spec_units_line(record)
        if assumed:
            click.echo(assumed, err=True)
        if not verbose:  # (--verbose says every note)
            for line in zone_note_lines(record):
                click.echo(line, err=True)
    if not quiet and not record["holes"]:
        why = refused_summary(refused, explain) if method == "robust" else ""  # (the paper's has no candidates)
        click.echo(f"holecli: no hole found in {record['file']}{why}{min_diameter_hint(record, min_diameter)}",
                   err=True)
    code = exit_code(Tally.of([record]), fail_on_warning)
    verdict = record.get("verdict")
    if code == EXIT_OUT_OF_TOLERANCE and not quiet:
        missing = f", missing: {', '.join(str(name) for name in verdict['missing'])}" if verdict["missing"] else ""
        not_measured = sum(any(check.endswith("_not_measured") for check in hole.get("failed_checks") or ())
                           for hole in record["holes"])
        unmeasured = f" ({not_measured} with a check not measured)" if not_measured else ""
        undecided = f", {verdict['undecided']} undecided" if verdict["undecided"] else ""
        hint = ""
        if far and far[0] is not None:
            distance, name = far[0]
            hint = (f" (no measured hole lies near a spec hole: the nearest is {distance:.4g} from {name}; are the "
                    f"scan and the spec in the same frame and unit? holecli register gives the frame, --units "
                    f"the unit)")
            if scaled and scaled[0] is not None:
                hint = hint[:-1] + "; " + scale_hint(*scaled[0]) + ")"
        click.echo(f"holecli: out of tolerance: {verdict['out_of_tolerance']} of {verdict['checked']} checked "
                   f"holes{unmeasured}{undecided}{missing} in {record['file']}{hint}{unit_mismatch_hint(record)}",
                   err=True)
    if code == EXIT_UNDECIDED and not quiet:
        click.echo(undecided_line(record), err=True)
    sys.exit(code)
