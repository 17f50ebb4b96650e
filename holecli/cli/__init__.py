"""The ``holecli`` command line: a thin layer over :mod:`holecli.io` and :func:`holecli.detect_file`.

stdout carries data only; messages go to stderr. Heavy modules (scipy, open3d, rich) are imported
inside the commands so that ``holecli --help`` stays fast.

Where things are:

=========================  ===========================================================================
``holecli.cli``            the click group :func:`main` (the ``holecli`` program's entry point, run by
                           :mod:`holecli.__main__` once the signal handlers are installed)
``holecli.cli.detect``     ``holecli detect``
``holecli.cli.render``     what ``detect`` prints (JSON, CSV, the table) and says about a record on stderr
``holecli.cli.batch``      ``holecli batch``: the command, its measuring loop and its stop on signals
``holecli.cli.register``   ``holecli register``: the part -> measuring frame transform from reference holes,
                           corrected targets (JSON, CSV, the table)
``holecli.cli.simulate``   ``holecli simulate``
``holecli.cli.plot``       ``holecli plot`` and ``detect --plot`` (matplotlib, imported when drawing)
``holecli.cli.info``       ``holecli info``: what a scan holds (:mod:`holecli.io.info` computes it)
``holecli.cli.options``    parameter types and the options ``detect`` and ``batch`` share
``holecli.cli.progress``   what ``holecli batch`` shows on stderr: progress bar, summary
``holecli.cli.exits``      exit codes, :class:`Failure`, :func:`run_guarded`, :func:`write_stdout`
=========================  ===========================================================================

The names of those modules that other code uses (the exit codes, :func:`run_guarded`,
:data:`MAX_SPEC_BYTES`, ...) can also be imported from here.
"""

from __future__ import annotations

import click

from holecli import __version__
from holecli.cli.exits import (BATCH_EXIT_CODES_HELP, EXIT_BROKEN_PIPE, EXIT_CODES_HELP, EXIT_FILE_FAILED, EXIT_INPUT,
                               EXIT_INTERNAL, EXIT_INTERRUPTED, EXIT_NO_HOLE, EXIT_OK, EXIT_OUT_OF_TOLERANCE, EXIT_UNDECIDED,
                               EXIT_USAGE, Failure,
                               fail, run_guarded, write_stdout)
from holecli.cli.options import (MAX_SPEC_BYTES, TOLERANCE_OPTION_NAMES, Decimal, FloatTuple, ToleranceBand,
                                 detection_option_decorators, detection_options, nominal_from_options, read_small_text,
                                 read_spec, tolerance_option_decorators)

__all__ = [
    "BATCH_EXIT_CODES_HELP", "CONTEXT", "EXIT_BROKEN_PIPE", "EXIT_CODES_HELP", "EXIT_FILE_FAILED", "EXIT_INPUT", "EXIT_INTERNAL",
    "EXIT_INTERRUPTED", "EXIT_NO_HOLE", "EXIT_OK", "EXIT_OUT_OF_TOLERANCE", "EXIT_UNDECIDED", "EXIT_USAGE",
    "MAX_SPEC_BYTES",
    "TOLERANCE_OPTION_NAMES", "Decimal", "Failure", "FloatTuple", "ToleranceBand", "detection_option_decorators",
    "detection_options", "fail", "main", "nominal_from_options", "read_small_text", "read_spec", "run_guarded",
    "tolerance_option_decorators", "write_stdout",
]

CONTEXT = {"help_option_names": ["-h", "--help"], "max_content_width": 100}


@click.group(context_settings=CONTEXT, epilog=EXIT_CODES_HELP)
@click.version_option(__version__, "--version", "-V", prog_name="holecli")
@click.option("--quiet", "-q", is_flag=True, help="As the command's --quiet: say nothing on stderr but errors.")
@click.option("--verbose", "-v", is_flag=True, help="As the command's --verbose: also say what the run chose.")
@click.pass_context
def main(context, quiet, verbose):
    """Measure drilled holes in 3D scans: center, diameter and surface normal.

    \b
    Examples:
      holecli detect scan.ply
      holecli detect scan.csv --format table
      holecli detect scan.ply --nominal-diameter 3 --tolerance +0.036/-0
      holecli batch scans/ --recursive --output results.jsonl
      holecli register A1.ply A2.ply A3.ply --spec part.toml
      holecli simulate scene.ply
      holecli plot scan.ply -o fit.png
      holecli info scan.csv --format table
      holecli -v detect scan.ply
    """
    global_verbosity(context, quiet, verbose)


def global_verbosity(context, quiet, verbose):
    """``holecli -q COMMAND`` / ``holecli -v COMMAND``: the command's own ``--quiet`` / ``--verbose``.

    They become the defaults of the command's options (click's ``default_map``), so that
    ``holecli -v detect x.ply`` is ``holecli detect -v x.ply``, and a global ``-q`` with the command's
    ``-v`` is refused as the two together are.

    Parameters
    ----------
    context : click.Context
        The group's context.
    quiet, verbose : bool

    Raises
    ------
    click.UsageError
        When both are given.
    """
    from holecli.cli.options import check_verbosity

    check_verbosity(quiet, verbose)
    chosen = {name: True for name, value in (("quiet", quiet), ("verbose", verbose)) if value}
    if not chosen:
        return
    defaults = dict(context.default_map or {})
    for name, command in context.command.commands.items():
        params = {param.name for param in command.params}
        missing = set(chosen) - params
        if missing:  # a command without --verbose refuses a global -v rather than ignoring it
            if context.invoked_subcommand == name:
                raise click.UsageError(f"holecli {name} has no --{missing.pop()}")
            continue
        defaults[name] = {**defaults.get(name, {}), **chosen}
    context.default_map = defaults


# The commands, each in its module (imported after main, which none of them needs).
from holecli.cli import batch, detect, info, plot, register, report, serve, simulate  # noqa: E402

main.add_command(detect.detect)
main.add_command(batch.batch)
main.add_command(simulate.simulate)
main.add_command(plot.plot)
main.add_command(register.register)
main.add_command(info.info)
main.add_command(report.report)
main.add_command(serve.serve)
