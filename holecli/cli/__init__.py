"""The ``holecli`` command line: a thin layer over :mod:`holecli.io` and :func:`holecli.detect_file`.

stdout carries data only; messages go to stderr. Heavy modules (scipy, open3d, rich) are imported
inside the commands so that ``holecli --help`` stays fast.

Where things are:

=========================  ===========================================================================
``holecli.cli``            the click group :func:`main` (the ``holecli`` program's entry point, run by
                           :mod:`holecli.__main__` once the signal handlers are installed); it imports
                           a command's module when the command runs (:data:`COMMAND_MODULES`)
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

from collections.abc import MutableMapping
from importlib import import_module

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


# The commands, each in its module, imported when the command runs or is listed: ``holecli detect``
# does not load batch's, simulate's, serve's, ... modules.
COMMAND_MODULES = {"detect": "holecli.cli.detect", "batch": "holecli.cli.batch", "simulate": "holecli.cli.simulate",
                   "plot": "holecli.cli.plot", "register": "holecli.cli.register", "info": "holecli.cli.info",
                   "report": "holecli.cli.report", "serve": "holecli.cli.serve"}


class LazyCommands(MutableMapping):
    """A group's commands by name, each imported from its module at the first look-up.

    Iterating gives the names without importing anything; ``commands[name]`` (and ``.get``,
    ``.items()``) imports the module of that command: ``holecli.cli.NAME``'s ``NAME``.

    Parameters
    ----------
    modules : dict
        Command name -> the module that defines it under that name.
    """

    def __init__(self, modules):
        self._modules = dict(modules)
        self._loaded = {}

    def __getitem__(self, name):
        if name not in self._loaded:
            if name not in self._modules:
                raise KeyError(name)
            self._loaded[name] = getattr(import_module(self._modules[name]), name)
        return self._loaded[name]

    def __setitem__(self, name, command):
        self._loaded[name] = command

    def __delitem__(self, name):
        if name not in self:
            raise KeyError(name)
        self._loaded.pop(name, None)
        self._modules.pop(name, None)

    def __iter__(self):
        return iter({**self._modules, **self._loaded})

    def __len__(self):
        return len({**self._modules, **self._loaded})

    def __contains__(self, name):
        return name in self._modules or name in self._loaded


class LazyGroup(click.Group):
    """A click group whose commands are imported when asked for (click's "lazily loading subcommands").

    Listing the commands (``--help``, completion) imports them all, running one imports that one
    only. The two look-ups click makes are overridden, as click's documentation does it; the
    commands live in a :class:`LazyCommands`, so that ``group.commands`` still names them all.

    Parameters
    ----------
    lazy_commands : dict, optional
        Command name -> the module that defines it under that name.
    """

    def __init__(self, *args, lazy_commands=None, **kwargs):
        super().__init__(*args, **kwargs)
        commands, self.commands = self.commands, LazyCommands(lazy_commands or {})
        self.commands.update(commands)

    def list_commands(self, ctx):
        return sorted(self.commands)

    def get_command(self, ctx, cmd_name):
        return self.commands.get(cmd_name)


@click.group(cls=LazyGroup, lazy_commands=COMMAND_MODULES, context_settings=CONTEXT, epilog=EXIT_CODES_HELP)
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
    # Only the command that runs reads its defaults (looking at the others would import them all).
    name = context.invoked_subcommand
    command = context.command.get_command(context, name) if name else None
    if command is None:
        return
    missing = set(chosen) - {param.name for param in command.params}
    if missing:  # a command without --verbose refuses a global -v rather than ignoring it
        raise click.UsageError(f"holecli {name} has no --{missing.pop()}")
    defaults = dict(context.default_map or {})
    defaults[name] = {**defaults.get(name, {}), **chosen}
    context.default_map = defaults
