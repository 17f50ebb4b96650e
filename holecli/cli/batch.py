"""``holecli batch``: measure every scan of folders and files, in worker processes (:mod:`holecli.batch`).

The command checks its options and opens the output; :func:`run_batch` is the loop that writes each
record as it comes and keeps the display (:mod:`holecli.cli.progress`) up to date;
:class:`StopRequests` turns Ctrl-C and SIGTERM into a stop between records.
"""

from __future__ import annotations

import os
import re
import sys
import time
from contextlib import ExitStack
from functools import partial

import click

from holecli.cli.exits import (BATCH_EXIT_CODES_HELP, EXIT_BROKEN_PIPE, EXIT_INPUT, EXIT_INTERRUPTED, EXIT_USAGE, Failure,
                               broken_pipe, exit_code, run_guarded, write_stdout)
from holecli.cli.options import (Decimal, check_verbosity, decision_from_options, detection_option_decorators, detection_options,
                                 columns_option, fail_on_warning_option, input_format_option,
                                 inspection_from_options, nominal_from_options, read_spec,
                                 require_gauge_depth,
                                 reading_option_decorators, refuse_same_files, registration_option_decorators,
                                 tolerance_option_decorators,
                                 unit_choice, verbosity_option_decorators, with_decision)
from holecli.cli.options import check_fields, fields_option
from holecli.cli.progress import BatchDisplay, batch_summary, verbose_text
from holecli.cli.render import spec_units_line, warning_lines, zone_note_lines
from holecli.errors import LoadError


class StopRequests:
    """SIGINT and SIGTERM handling of ``holecli batch``.

    Before :meth:`defer`, either signal raises KeyboardInterrupt (nothing is written yet). After it,
    a signal only sets :attr:`signal`, which the batch loop checks between records: an exception can
    then never cut a record in the middle of its write.

    Use it as a context manager around the whole command: it installs its handler on entry (in the
    main thread only) and puts the previous handlers back on exit.

    Attributes
    ----------
    signal : int or None
        The number of the signal received after :meth:`defer`, or None.
    """

    SIGNALS = ("SIGINT", "SIGTERM")

    def __init__(self):
        self.signal = None
        self._deferred = False
        self._previous = {}

    def __enter__(self):
        import signal

        for name in self.SIGNALS:
            number = getattr(signal, name)
            try:
                self._previous[number] = signal.signal(number, self._handle)
            except ValueError:  # not the main thread: leave the signals alone
                pass
        return self

    def __exit__(self, *exc_info):
        import signal

        for number, handler in self._previous.items():
            signal.signal(number, handler)
        return False

    def defer(self):
        """From now on, a signal only sets :attr:`signal` (the loop stops between records)."""
        self._deferred = True

    def _handle(self, number, frame):
        if not self._deferred:
            from holecli import interrupts

            interrupts.record(number)
            raise KeyboardInterrupt
        self.signal = number


def unit_lines(record):
    """The stderr lines of a record's mistakes of units: each ``unit_mismatch`` warning of its holes
    (:func:`holecli.cli.render.warning_lines`) and its ``spec_units_assumed``
    (:func:`holecli.cli.render.spec_units_line`).

    Parameters
    ----------
    record : dict
        A ``batch`` record (not an error record).

    Returns
    -------
    list of str
    """
    from holecli.units import UNIT_MISMATCH

    lines = [line for line in warning_lines(record) if f": {UNIT_MISMATCH}: " in line]
    assumed = spec_units_line(record)
    return lines + ([assumed] if assumed else [])


def e57_units_overridden(files, units):
    """The warning ``holecli: warning: batch: e57_units_overridden: ...`` when ``--units`` (``units``,
    other than metres) is given for a batch that mixes E57 files (metres by the standard) with others:
    the E57 files' records then say ``units`` too, as ``--units`` declares; else None."""
    if units is None or units == "m":
        return None
    e57 = [path for path in files if os.path.splitext(str(path))[1].lower() == ".e57"]
    if not e57 or len(e57) == len(files):
        return None
    return (f"holecli: warning: batch: e57_units_overridden: --units {units} is taken for the {len(e57)} E57 "
            f"file{'' if len(e57) == 1 else 's'} too (E57 is in metres by the standard): their records say "
            f"{units}; measure them in a batch of their own if they are in metres")


@click.command(epilog=BATCH_EXIT_CODES_HELP)
# (readable=False: a file that cannot be read gets its error record, as any bad file; not a usage error)
@click.argument("paths", metavar="PATH...", nargs=-1, required=True, type=click.Path(readable=False, path_type=str))
@click.option("--recursive", "-r", is_flag=True, help="Also take the clouds in the subfolders of each folder.")
@click.option("--pattern", metavar="GLOB", default=None,
              help="Take only the clouds in folders whose name matches GLOB (case-insensitive; a GLOB with "
                   "a / is matched against the path below the folder), e.g. 'part7_*'.")
@input_format_option("Read every file in this format, whatever its extension; a folder then contributes "
                     "every file (that --pattern matches), e.g. --input-format xyz --pattern '*.asc'.")
@columns_option
@click.option("--format", "fmt", type=click.Choice(["jsonl", "json", "csv"]), default="jsonl", show_default=True,
              help="JSON Lines (one detect record per file, each on one line; json is taken for it, the word "
                   "detect uses) or CSV (one row per hole).")
@fields_option(batch=True)
@click.option("--output", "-o", type=click.Path(dir_okay=False, allow_dash=True, path_type=str), default=None,
              help="Write the records to this file (each as soon as its file is measured; - is stdout) instead "
                   "of stdout.")
@click.option("--jobs", "-j", type=click.IntRange(min=1), default=None, metavar="N",
              help="Worker processes [default: the number of cores].")
@click.option("--cluster", "cluster_address", metavar="ADDRESS", default=None,
              help="Measure on a Dask cluster instead of local processes: local:N (N worker processes here, started "
                   "and stopped by holecli) or a scheduler's address, tcp://host:8786; the files must be readable "
                   "from the workers (a shared file system). With --output, OUTPUT.manifest records what is done "
                   "(path, size, SHA-256) for --resume; --file-timeout is not applied there (needs pip install "
                   "'holecli[cluster]').")
@click.option("--files-per-task", type=click.IntRange(min=1), default=None, metavar="K",
              help="With --cluster: files measured in one task [default: max(1, min(256, ceil(files / (4 x "
                   "workers))))].")
@click.option("--resume", is_flag=True,
              help="Keep the records already in --output, skip their files and append the others; refused (exit 2, "
                   "the file untouched) when the options differ from its first record's.")
@click.option("--overwrite", is_flag=True,
              help="Replace an --output that is not empty (without it, or --resume, such a file is refused and "
                   "left as it is).")
@click.option("--store", "store_location", metavar="LOCATION", default=None,
              help="Also add each record (error records too) to the results store LOCATION as it is written: an "
                   "SQLite file (created when missing) or postgresql://... (needs pip install 'holecli[postgres]'); "
                   "with --resume, the records already in --output are not added again.")
@click.option("--meta", "meta_pairs", metavar="KEY=VALUE", multiple=True, callback=lambda context, parameter, value:
              parse_meta(value),
              help="With --store: metadata of every record stored (part, serial, cell, operator, or another word; "
                   "VALUE at most 200 characters). Repeat for each key.")
@click.option("--plot", "plot_dir", type=click.Path(path_type=str), default=None, metavar="PLOTDIR",
              help="Also draw each scan's holes into PLOTDIR/<scan stem>.png (created; a stem met again gets -2, -3, "
                   "...), as holecli plot does, with the verdict when tolerances are given; PLOTDIR is never "
                   "measured (needs pip install 'holecli[plot]').")
@click.option("--explain", is_flag=True,
              help="Records also list every candidate that is not a hole, with the check that refused it "
                   "(\"rejected\"; JSON Lines only).")
@click.option("--file-timeout", type=Decimal(min=0), default=600, show_default=True, metavar="SECONDS",
              help="A file not measured within SECONDS gets an error record and the batch goes on (a reader or "
                   "library looping on a damaged file); 0: no limit.")
@reading_option_decorators
@detection_option_decorators
@tolerance_option_decorators
@registration_option_decorators(plain_name=False)
@fail_on_warning_option
@verbosity_option_decorators
def batch(paths, recursive, pattern, input_format, columns, fmt, fields, output, jobs, cluster_address, files_per_task,
          resume, overwrite, store_location,
          meta_pairs, plot_dir, explain, file_timeout,
          scan_index,
          units, output_units,
          method, view_dir, min_diameter, max_holes, full_only, gauge_depth, spec_file, decision_rule, coverage_factor,
          registration_file, name_pairs, fail_on_warning, quiet, verbose, **nominal_options):
    """Measure every point cloud in the folders and files PATH.

    A folder contributes the .ply, .pcd, .csv, .txt, .xyz, .e57, .las and .laz files directly in it (any case; with
    --recursive also those below it), in sorted order; a file named on the command line is measured
    as it is. Each record (the JSON of holecli detect) is written as soon as its file is measured; a
    file that cannot be measured gives {"file": ..., "error": ...} and the batch goes on. Progress and
    a summary go to stderr (with the count of holes with warnings, per code; the warnings themselves
    are in the records). Ctrl-C or SIGTERM stop cleanly; --resume then finishes the run.

    \b
    Examples:
      holecli batch scans/ --output results.jsonl
      holecli batch scans/ --recursive --pattern 'panel7_*' --format csv -o panel7.csv
      holecli batch scans/ --format csv --fields file,hole,diameter,u_diameter,in_tolerance -o shift.csv
      holecli batch scans/ --spec part.toml --jobs 4 -o shift.jsonl
      holecli batch scans/ --spec part.toml -o shift.jsonl --resume
      holecli batch scans/ --spec part.toml --decision-rule guarded --coverage-factor 2 -o shift.jsonl
      holecli batch scans/*.ply --nominal-diameter 3 --tolerance 0.02 | jq -c 'select(.verdict.in_tolerance | not)'
      holecli batch scans/ --input-format xyz --pattern '*.asc' -o -
      holecli batch scans/ -q -o results.jsonl
      holecli batch scans/ --spec part.toml -o shift.jsonl --plot shift_plots/
      holecli batch cell/R1.ply cell/R3.ply --spec part.toml --registration registration.json
      holecli batch scans/ --spec part.toml --store results.sqlite --meta part=P7 --meta cell=C2
      holecli batch /shared/scans/ --spec part.toml --cluster tcp://scheduler:8786 -o /shared/shift.jsonl
    """
    check_verbosity(quiet, verbose)
    # --output-units without --units is checked on the files found, in the body (all E57 is fine)
    choice = unit_choice(units, output_units if units is not None else None)
    options = detection_options(method, view_dir, min_diameter, max_holes, full_only, gauge_depth)
    if input_format is not None:
        options["input_format"] = input_format
    if columns is not None:
        options["columns"] = columns
    # the tolerance options (--nominal-diameter, ..., --max-perpendicularity) by their parameter names
    nominal = nominal_from_options(spec_file, **nominal_options)
    decision = decision_from_options(decision_rule, coverage_factor, nominal is not None or spec_file is not None)
    require_gauge_depth(nominal, gauge_depth)
    if fmt == "json":  # detect's word: a batch's records are JSON, one per line
        fmt = "jsonl"
    if resume and (output is None or output == "-"):
        raise click.UsageError("--resume needs --output (the file to go on with)")
    if resume and overwrite:
        raise click.UsageError("--resume keeps the output's records and --overwrite replaces them: give one")
    if explain and fmt == "csv":
        raise click.UsageError("--explain needs --format jsonl (CSV has one row per hole)")
    check_fields(fields, fmt)
    if fields is not None and resume:
        # resuming reads each earlier file's verdict from the whole header's columns
        raise click.UsageError("--resume needs the whole CSV (it reads the earlier files' verdicts from its columns): "
                               "drop --fields")
    if cluster_address is not None and jobs is not None:
        raise click.UsageError("--jobs is for local worker processes; with --cluster the cluster's workers measure "
                               "(local:N for N of them here)")
    if cluster_address is not None:
        from holecli.batch.cluster import ClusterError, parse_address

        try:
            parse_address(cluster_address)
        except ClusterError as error:
            raise click.BadParameter(str(error).removeprefix(f"--cluster {cluster_address}: "),
                                     param_hint="'--cluster'") from None
    if files_per_task is not None and cluster_address is None:
        raise click.UsageError("--files-per-task needs --cluster")
    if meta_pairs and store_location is None:
        raise click.UsageError("--meta needs --store (the metadata is stored with each record)")
    if output == "-":  # stdout, as without --output
        output = None

    def body(stop):
        with ExitStack() as stack:
            return measure_batch(stop, stack)

    def measure_batch(stop, stack):
        from holecli import batch as batching
        from holecli.io import SUPPORTED_EXTENSIONS

        store = None
        # the output never replaces the spec or a file named to be measured (issue 23, item 4)
        store_file = None if store_location is None or is_database_url(store_location) else store_location
        refuse_same_files([("--spec", spec_file), ("--registration", registration_file),
                           *(("PATH", path) for path in paths)], [("-o/--output", output), ("--store", store_file)])
        spec = with_decision(read_spec(spec_file) if spec_file is not None else nominal, decision)
        require_gauge_depth(spec, gauge_depth, spec_file)
        spec = inspection_from_options(spec, spec_file, registration_file, name_pairs)
        if plot_dir is not None:
            from holecli.cli.plot import require_matplotlib

            require_matplotlib()  # before anything: a missing extra is said at once (the workers inherit it)
        unlistable = []
        try:
            files = batching.find_scans(paths, recursive=recursive, pattern=pattern,
                                        # (the store's file and its WAL are never measured either)
                                        exclude=([output] if output else []) + store_files(store_file),
                                        input_format=input_format,
                                        # its PNGs are never measured (with --input-format they would be)
                                        exclude_folders=[plot_dir] if plot_dir is not None else (),
                                        unlistable=unlistable)
        except LoadError as error:
            raise Failure(str(error), EXIT_INPUT) from None
        if not files and not unlistable:
            what = "files" if input_format else f"point-cloud files ({', '.join(SUPPORTED_EXTENSIONS)})"
            raise Failure(f"{', '.join(paths)}: no {what}" + (f" matching {pattern!r}" if pattern else "") + " found",
                          EXIT_INPUT)
        from holecli.inspection import tied_hole_name

        for scan, hole in name_pairs:  # before the output is opened: a --name that ties nothing is a typo
            if not any(tied_hole_name(str(file), [(scan, hole)], ())[0] for file in files):
                raise Failure(f"--name {scan}={hole}: {scan} is none of the files found", EXIT_USAGE)
        units_now = choice
        if output_units is not None and units is None:
            try:
                units_now = unit_choice(None, output_units, files)
            except click.UsageError as error:
                raise Failure(f"{error.message}; not every file is .e57", EXIT_USAGE) from None
        if not quiet:
            overridden = e57_units_overridden(files, units_now.file)
            if overridden:
                click.echo(overridden, err=True)
        # lengths on the command line are in the output unit: the pipeline wants the file's
        options_now = dict(options, min_diameter=units_now.to_file_units(min_diameter),
                           gauge_depth=units_now.to_file_units(gauge_depth)) if method != "paper" else options
        if store_location is not None:  # before the output is opened (and emptied): nothing is measured without it
            store = stack.enter_context(open_results_store(store_location))
        measure = None
        if cluster_address is not None:  # before the output is opened (and emptied): nothing is measured without it
            measure = start_cluster(stack, cluster_address, files_per_task, verbose)
        plots = None
        if plot_dir is not None:  # before the output is opened (and emptied): nothing is measured without it
            from holecli.cli.plot import make_plot_folder

            make_plot_folder(plot_dir)
            plots = batching.plot_files(files, plot_dir)  # every file, in order: a resumed run names them alike
        output_file = None
        try:
            if output is not None:
                try:
                    expected = _run_provenance(batching, method, view_dir, min_diameter, max_holes, full_only,
                                               gauge_depth, input_format, scan_index, units_now, spec)
                    output_file = batching.BatchOutput(output, fmt, resume=resume, overwrite=overwrite,
                                                       expected=expected)
                except (batching.ResumeError, batching.OutputBusyError) as error:
                    raise Failure(str(error), EXIT_INPUT) from None
                except (batching.OutputNotEmptyError, batching.ResumeOptionsError) as error:
                    raise Failure(str(error), EXIT_USAGE) from None
                except OSError as error:
                    action = "resume" if resume else "write output"
                    raise Failure(f"{output}: cannot {action}: {error.strerror or error}", EXIT_INPUT) from None
                write, earlier, header = output_file.write, output_file.earlier, output_file.needs_header
            else:
                write, earlier, header = write_stdout, [], True
            after_write = None
            if measure is not None and output_file is not None:
                earlier, fingerprints, after_write = open_manifest(stack, output, files, earlier, resume)
                measure = partial(measure, fingerprints=fingerprints)
            todo = batching.files_to_do(files, earlier)
            # a subfolder that cannot be listed: an error record (once, with --resume), before the files
            done = {summary.path for summary in earlier}
            unlisted = [batching.error_record(folder, message) for folder, message in unlistable
                        if batching.resolved_path(folder) not in done]
            return run_batch(batching, todo, options_now, spec, jobs or batching.default_jobs(), write, fmt, header,
                             earlier, output, stop, explain, scan=scan_index,
                             units=units_now if units_now.file or units_now.output else None, quiet=quiet,
                             verbose=verbose, fail_on_warning=fail_on_warning,
                             plots=None if plots is None else {path: plots[path] for path in todo},
                             file_timeout=file_timeout, unlisted=unlisted, fields=fields,
                             store=store, meta=meta_pairs, measure=measure, after_write=after_write)
        finally:
            if output_file is not None:
                output_file.close()

    with StopRequests() as stop:
        sys.exit(run_guarded(body, stop))


def start_cluster(stack, address, task_size, verbose):
    """``--cluster``: the Dask client of ``address`` (:func:`holecli.batch.cluster.cluster_client`),
    closed by ``stack``, and the measuring function of :func:`run_batch` on it.

    Raises
    ------
    Failure
        With the input-error code, when Dask is missing or the cluster cannot be reached.
    """
    from holecli.batch.cluster import ClusterError, cluster_client, measure_on_cluster

    try:
        client = stack.enter_context(cluster_client(address, verbose=verbose))
    except ClusterError as error:
        raise Failure(str(error), EXIT_INPUT) from None
    return partial(measure_on_cluster, client=client, task_size=task_size)


def open_manifest(stack, output, files, earlier, resume):
    """``--cluster`` with ``--output``: the manifest beside the output (:class:`holecli.batch.manifest.Manifest`),
    closed by ``stack``; with ``resume``, the ``earlier`` records whose files changed since (by the
    manifest) are left out, so that those files are measured again.

    Returns
    -------
    (list of FileSummary, dict, callable)
        The earlier records still done; the ``fingerprints`` for
        :func:`holecli.batch.cluster.measure_on_cluster` to fill; the ``after_write`` of
        :func:`run_batch`, which adds a record's file to the manifest with its fingerprint.

    Raises
    ------
    Failure
        With the input-error code, when the manifest cannot be opened.
    """
    from holecli.batch.manifest import Manifest, manifest_path
    from holecli.measure import resolved_path

    path = manifest_path(output)
    try:
        manifest = stack.enter_context(Manifest(path, resume=resume))
    except OSError as error:
        raise Failure(f"{path}: cannot open the manifest: {error.strerror or error}", EXIT_INPUT) from None
    if resume:
        by_path = {resolved_path(file): file for file in files}
        changed = manifest.changed(by_path[summary.path] for summary in earlier if summary.path in by_path)
        earlier = [summary for summary in earlier if summary.path not in changed]
    fingerprints = {}

    def after_write(record):
        fingerprint = fingerprints.pop(record["file"], None)
        if fingerprint is not None:
            manifest.add(record["file"], fingerprint)

    return earlier, fingerprints, after_write


def parse_meta(pairs) -> dict:
    """The ``--meta KEY=VALUE`` options as a dict (:func:`holecli.store.schema.check_meta`'s rules).

    Parameters
    ----------
    pairs : tuple of str

    Returns
    -------
    dict

    Raises
    ------
    click.BadParameter
        For a pair without ``=``, a KEY that is not a word or given twice, a VALUE over 200 characters.
    """
    if not pairs:
        return {}
    from holecli.store.schema import check_meta

    meta = {}
    for pair in pairs:
        key, equals, value = pair.partition("=")
        if not equals or not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", key):
            raise click.BadParameter(f"{pair!r} is not KEY=VALUE with KEY a word (letters, digits, _), e.g. part=P7",
                                     param_hint="'--meta'")
        if key in meta:
            raise click.BadParameter(f"{key} is given twice", param_hint="'--meta'")
        meta[key] = value
    try:
        check_meta(meta)
    except ValueError as error:
        raise click.BadParameter(str(error), param_hint="'--meta'") from None
    return meta


def is_database_url(location) -> bool:
    """Whether a ``--store`` LOCATION names a PostgreSQL database rather than an SQLite file."""
    from holecli.store import POSTGRES_SCHEMES

    return location.lower().startswith(POSTGRES_SCHEMES)


def store_files(path) -> list:
    """An SQLite store's file and the WAL files SQLite keeps beside it (none for None)."""
    return [] if path is None else [path, path + "-wal", path + "-shm"]


def open_results_store(location):
    """The results store of ``--store`` (:func:`holecli.store.open_store`), open.

    Raises
    ------
    Failure
        With the input-error code, naming the store, when it cannot be opened.
    """
    from holecli.store import StoreError, open_store

    try:
        return open_store(location)
    except StoreError as error:  # psycopg missing for a postgresql:// store too
        raise Failure(str(error), EXIT_INPUT) from None


def store_record(store, record, meta):
    """Add a batch record to the results store (source ``batch``, ``processing_ms`` its
    ``timing.elapsed_ms``); a record that cannot be JSON (a NaN: a bug) is stored, and should be
    written, as its error record (:func:`unwritable_record`).

    Returns
    -------
    dict
        The record stored.

    Raises
    ------
    Failure
        With the input-error code, when the store cannot add it.
    """
    from holecli.store import StoreError

    elapsed = (record.get("timing") or {}).get("elapsed_ms")
    try:
        try:
            store.add(record, meta=meta, source="batch", processing_ms=elapsed)
        except ValueError as error:
            record = unwritable_record(record, error)
            store.add(record, meta=meta, source="batch")
    except StoreError as error:
        raise Failure(str(error), EXIT_INPUT) from None
    return record


def unwritable_record(record, error):
    """The error record written instead of a record that cannot be JSON (a NaN in it: a bug)."""
    return {"file": record["file"], "error": f"{record['file']}: internal error (a bug: please "
                                             f"report it): the record cannot be written: {error}"}


def _run_provenance(batching, method, view_dir, min_diameter, max_holes, full_only, gauge_depth, input_format,
                    scan_index, units, spec):
    """The provenance cells this run's records will carry (:func:`holecli.batch.provenance_cells`), for
    ``--resume`` to compare with the output's first record: the options as given (lengths in the
    output unit, as the records give them), the unit, the tolerances."""
    from holecli.tolerance import describe

    spec = getattr(spec, "spec", spec)  # with --registration/--name: the spec of the Inspection
    options = {"method": method, "view_dir": None if view_dir is None else list(view_dir),
               "min_diameter": min_diameter, "max_holes": max_holes, "full_only": bool(full_only),
               "gauge_depth": gauge_depth, "input_format": input_format, "scan": scan_index,
               "tolerances": None if spec is None else describe(spec)}
    return batching.provenance_cells({"units": units.output or units.file, "options": options})


def run_batch(batching, todo, options, spec, jobs, write, fmt, header, earlier, output, stop, explain=False, scan=None,
              units=None, *, quiet=False, verbose=False, fail_on_warning=None, plots=None, file_timeout=None,
              unlisted=(), fields=None, store=None, meta=None, measure=None, after_write=None):
    """The measuring loop of ``holecli batch``: records out, progress and summary on stderr.

    Parameters
    ----------
    batching : module
        :mod:`holecli.batch` (imported by the caller, inside the guarded body).
    todo : list of str
        The files to measure in this run.
    options : dict
        Keyword arguments of :func:`holecli.detect_file`.
    spec : holecli.tolerance.Spec or None
        Tolerances to check.
    jobs : int
        Worker processes (at most one per file).
    write : callable
        Writes the text of one record at once (:meth:`holecli.batch.BatchOutput.write` or
        :func:`write_stdout`).
    fmt : {"jsonl", "csv"}
        The format of the records.
    header : bool
        Write the CSV header first.
    earlier : list of holecli.batch.FileSummary
        The files of the earlier run (``--resume``), counted in the summary.
    output : str or None
        The ``--output`` file, for messages.
    stop : StopRequests
        The signal handling of the command; deferred here, checked between records.
    explain : bool
        Records with their ``rejected`` list.
    scan : int, optional
        ``--scan``: the scan of each E57 file (default: every scan).
    units : holecli.units.UnitChoice, optional
        ``--units`` and ``--output-units``.
    quiet : bool
        ``--quiet``: no progress bar and no summary; only the files that failed and an interruption
        are said.
    verbose : bool
        ``--verbose``: the scales and stage times of every file (:func:`verbose_text`).
    fail_on_warning : frozenset, optional
        ``--fail-on-warning`` (see :func:`holecli.cli.exits.exit_code`).
    plots : dict, optional
        ``--plot``: ``{file: PNG}`` of the files to draw (:func:`holecli.batch.plot_files`), drawn
        where each is measured.
    file_timeout : float, optional
        ``--file-timeout``: seconds per file (None or 0: no limit), see :func:`holecli.batch.measure_all`.
    unlisted : sequence of dict
        The error records of the subfolders that could not be listed, written first.
    fields : tuple of str, optional
        ``--fields``: the CSV's columns (default :data:`holecli.report.BATCH_CSV_COLUMNS`).
    store : holecli.store.Store, optional
        ``--store``: each record is added to it (committed) before it is written.
    meta : dict, optional
        ``--meta``: the metadata stored with each record.
    measure : callable, optional
        ``--cluster``: measures instead of :func:`holecli.batch.measure_all` (``jobs`` and
        ``file_timeout`` are then not used), e.g. :func:`holecli.batch.cluster.measure_on_cluster`
        with its client; takes the files, options and spec and measure_all's other keywords.
    after_write : callable, optional
        Called with each record after it is written (the cluster's manifest).

    Returns
    -------
    int
        The exit code: :data:`EXIT_INTERRUPTED` when a signal stopped the run before its end,
        :data:`EXIT_BROKEN_PIPE` when the reader of the output went away (the run stops as when
        interrupted: the workers are ended, the records written so far are whole), else
        :func:`holecli.cli.exits.exit_code`.

    Raises
    ------
    Failure
        With the input-error code, when a record cannot be written or stored.
    BrokenPipeError
        When the reader of stdout went away before the first record (handled by :func:`run_guarded`).
    """
    from contextlib import closing

    tally = batching.Tally()
    for summary in earlier:
        tally.add(summary)
    def failed_write(error):
        return Failure(f"{output or 'stdout'}: cannot write output: {error.strerror or error}", EXIT_INPUT)

    try:
        writer = batching.RecordWriter(write, fmt, header=header,
                                       **({} if fields is None else {"columns": fields}))
    except BrokenPipeError:
        raise
    except OSError as error:
        raise failed_write(error) from None
    total = len(todo) + len(unlisted)
    display = BatchDisplay(total, spec is not None, quiet=quiet)
    started = time.monotonic()
    measured_now = 0

    def should_stop():
        display.update(measured_now, tally, time.monotonic() - started)
        return stop.signal is not None

    stop.defer()
    if measure is None:
        measured = batching.measure_all(todo, options, spec, jobs=min(jobs, max(1, len(todo))),
                                        should_stop=should_stop, explain=explain, scan=scan, units=units, plots=plots,
                                        file_timeout=file_timeout)
    else:
        measured = measure(todo, options, spec, should_stop=should_stop, explain=explain, scan=scan, units=units,
                           plots=plots)

    def every_record():
        yield from unlisted
        try:
            yield from measured
        finally:
            measured.close()

    records = every_record()
    reader_gone = False
    with display, closing(records):
        for record in records:
            try:
                if store is not None:  # stored first: a record in the output is in the store (--resume)
                    record = store_record(store, record, meta)
                try:
                    writer.write(record)
                except ValueError as error:  # a NaN in the record: a bug, but the batch goes on
                    record = unwritable_record(record, error)
                    writer.write(record)
                if after_write is not None:
                    after_write(record)
            except BrokenPipeError:
                # The reader of the output went away (`| head -1`): stop as when interrupted (the
                # workers are ended as the loop is left; every record written so far is whole).
                reader_gone = True
                break
            except OSError as error:
                raise failed_write(error) from None
            measured_now += 1
            tally.add(record)
            if "error" in record:
                display.message(f"holecli: failed: {record['error']}", error=True)
            else:
                if not quiet:  # the mistakes of units, said at once: every hole of the file is off by them
                    for line in unit_lines(record):
                        display.message(line, error=True)
                if not quiet and not verbose:  # checks a guarded decision can never pass (-v says every note)
                    for line in zone_note_lines(record):
                        display.message(line, error=True)
                if verbose:
                    display.message(verbose_text(record).rstrip("\n"))
    summary = batch_summary(tally, time.monotonic() - started, spec is not None, len(earlier), output)
    if reader_gone:
        name = output or "stdout"
        broken_pipe(name, f"Error: {name}: broken pipe (its reader stopped reading): holecli batch stopped after "
                          f"{measured_now} of {total} files ({summary})")
        # (a signal that came meanwhile still decides the code: 130 comes before 141)
        return EXIT_INTERRUPTED if stop.signal is not None else EXIT_BROKEN_PIPE
    if stop.signal is not None and measured_now < total:
        display.message(f"holecli batch: interrupted after {measured_now} of {total} files ({summary})."
                        + (f" The finished records are in {output}: run again with --resume to measure the rest."
                           if output else ""), error=True)
        return EXIT_INTERRUPTED
    display.message(f"holecli batch: {summary}")
    return exit_code(tally, fail_on_warning)
