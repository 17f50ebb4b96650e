"""``holecli report``: the quality records of a lot of measurements (HTML report, QIF, first-article and
characteristic tables), from detect/batch JSON Lines or from a results store."""

from __future__ import annotations

import json
import os
import re
import sys

import click

from holecli.cli.exits import EXIT_INPUT, EXIT_OK, EXIT_USAGE, Failure, run_guarded
from holecli.cli.options import check_verbosity, verbosity_option_decorators

EXIT_NOTHING = 4
"""No measurement to report (no record in the files, none in the store matching the filters)."""

REPORT_EXIT_CODES_HELP = (
    "\b\nExit codes:\n"
    "  0  the report was written (whatever the parts' verdicts: it reports them)\n"
    "  1  internal error (a bug: please report it)\n"
    "  2  usage error (bad option or argument)\n"
    "  3  input error: a RESULTS file cannot be read or holds a line that is not a holecli record,\n"
    "     the --store cannot be opened or holds no store, the output cannot be written\n"
    "  4  nothing to report: no record in RESULTS, or none in the --store matching the filters\n"
    "  130  interrupted (Ctrl-C, SIGTERM): nothing is written\n"
    "  141  the reader of the output went away"
)

FORMATS = ("html", "qif", "fai", "csv")

# The format an output file's extension implies when --format is not given.
_FORMAT_BY_EXTENSION = {".html": "html", ".htm": "html", ".qif": "qif", ".xml": "qif", ".csv": "csv"}


@click.command(epilog=REPORT_EXIT_CODES_HELP)
@click.argument("results", nargs=-1, type=click.Path(allow_dash=True, path_type=str))
@click.option("--store", "store_location", metavar="PATH|URL", default=None,
              help="Report the measurements of this results store (an SQLite file or postgresql://...; "
                   "read only) instead of RESULTS files; with --part, --serial, --since, --until.")
@click.option("--part", default=None, help="With --store: only the measurements of this part (its metadata).")
@click.option("--serial", default=None, help="With --store: only the measurements of this serial number.")
@click.option("--since", default=None, metavar="DATE[THH:MM[:SS]]",
              help="With --store: only those received at or after this time (ISO-8601, UTC), e.g. 2026-12-04T06:00.")
@click.option("--until", default=None, metavar="DATE[THH:MM[:SS]]",
              help="With --store: only those received at or before it (a date alone: to the end of that day).")
@click.option("--format", "fmt", type=click.Choice(FORMATS), default=None,
              help="html: the inspection report (one self-contained page); qif: QIF 3.0 results (XML); "
                   "fai: the AS9102 Form 3 rows (CSV); csv: a row per characteristic [default: from -o's "
                   "extension (.html, .qif/.xml, .csv), else html].")
@click.option("-o", "--output", default=None, metavar="FILE",
              help="Write the report to FILE (atomically: all or nothing; - is stdout) [default: stdout].")
@click.option("--title", default=None, help="The HTML report's title [default: 'Inspection report' and the parts].")
@click.option("--no-pictures", is_flag=True,
              help="HTML: leave out the picture of each hole (the tables and charts stay).")
@click.option("--scan-pictures", type=click.IntRange(min=0), default=50, show_default=True, metavar="N",
              help="HTML: also draw, for up to N holes that failed, are undecided or carry a warning, the points "
                   "of the scan around the hole (read again from the record's file, where it still is), so that "
                   "a chip, a burr or lubricant can be told from a bad hole; 0: none.")
@click.option("--order", type=click.Choice(("read", "name")), default="read", show_default=True,
              help="The measurement order of the charts: as read (the lines of RESULTS in turn, a store's by "
                   "the time received) or by the scans' file names (batch --jobs N writes its lines in the "
                   "order the files finish: name order is the files' order).")
@click.option("--part-number", default=None,
              help="fai and qif: the part number where the records' metadata has none.")
@verbosity_option_decorators
def report(results, store_location, part, serial, since, until, fmt, output, title, no_pictures, scan_pictures, order,
           part_number, quiet, verbose):
    """Report a lot of measurements: detect/batch JSON Lines RESULTS (- reads stdin; an indented
    detect --format json record too), or a results store's measurements (--store).

    The HTML report (one file, nothing loaded from the network when viewed) has a summary of the
    parts and their verdicts, a table per measurement (each hole's characteristics: nominal,
    tolerance, measured, deviation, U, decision, the amount out of tolerance and the reason), a
    picture of each hole, and per characteristic over the lot the control charts (individuals and
    moving range in measurement order, X-bar and R where a part's holes share a nominal) with the
    Western Electric rules marked, a histogram against the tolerance, Cp, Cpk, Pp, Ppk with their
    confidence intervals and the test uncertainty ratio.

    \b
    Examples:
      holecli report shift.jsonl -o shift.html
      holecli report shift.jsonl --format qif -o shift.qif
      holecli report shift.jsonl --format fai --part-number PN-4711 -o fai.csv
      holecli report shift.jsonl --format csv -o characteristics.csv
      holecli report --store results.sqlite --part P7 --since 2026-12-04T06:00 -o shift.html
      holecli batch scans/ --spec part.toml | holecli report - --no-pictures -o lot.html
    """
    check_verbosity(quiet, verbose)
    fmt = fmt or _FORMAT_BY_EXTENSION.get(os.path.splitext(output or "")[1].lower(), "html")
    if store_location is not None and results:
        raise click.UsageError("give RESULTS files or --store, not both")
    if store_location is None and not results:
        raise click.UsageError("give RESULTS files (detect/batch JSON Lines, - for stdin) or --store")
    if store_location is None:
        for name, value in (("--part", part), ("--serial", serial), ("--since", since), ("--until", until)):
            if value is not None:
                raise click.UsageError(f"{name} filters a --store's measurements: give --store")
    if results.count("-") > 1:
        raise click.UsageError("- (stdin) can be given once")
    if no_pictures and fmt != "html":
        raise click.UsageError("--no-pictures is for --format html")
    if title is not None and fmt != "html":
        raise click.UsageError("--title is for --format html")

    def body():
        from holecli.cli.files import refuse_same_files
        from holecli.cli.outputs import emit

        refuse_same_files([("RESULTS", path) for path in results], [("-o/--output", output)])
        if store_location is not None:
            entries = _store_entries(store_location, part=part, serial=serial, since=since, until=until)
            inputs = [_store_text(store_location, part, serial, since, until)]
        else:
            entries = [entry for path in results for entry in read_results(path)]
            inputs = list(results)
        if not entries:
            where = f"the store {inputs[0]}" if store_location is not None else ", ".join(results)
            raise Failure(f"nothing to report: no measurement in {where}", EXIT_NOTHING)
        from holecli.quality.lot import lot_from_records

        try:
            lot = lot_from_records(entries)  # checked in the order read, so that an error names its line
            if order == "name":
                entries.sort(key=lambda entry: _natural_key(entry["record"]["file"]))
                lot = lot_from_records(entries)
        except ValueError as error:
            raise Failure(str(error), EXIT_INPUT) from None
        views = {}
        if fmt == "html" and not no_pictures and scan_pictures:
            views = scan_views(lot, scan_pictures)
        content = render(lot, fmt, title=title, pictures=not no_pictures, part_number=part_number, inputs=inputs,
                         scan_views=views)
        emit(content, output, "the report")
        if not quiet:
            summary = lot.summary()
            verdicts = ", ".join(f"{count} {word}" for word, count in summary["verdicts"].items() if count)
            click.echo(f"report: {_count(summary['measurements'], 'measurement')} ({verdicts}), "
                       f"{_count(summary['holes'], 'hole')}, {_count(summary['characteristics'], 'characteristic')} "
                       f"-> {output or 'stdout'} ({fmt})", err=True)

    run_guarded(body)
    raise SystemExit(EXIT_OK)


def render(lot, fmt, *, title=None, pictures=True, part_number=None, inputs=(), scan_views=None):
    """The report of ``lot`` in ``fmt``: text (html, fai, csv) or bytes (qif)."""
    if fmt == "html":
        from holecli.quality.html import html_report

        return html_report(lot, title=title, pictures=pictures, inputs=list(inputs), scan_views=scan_views or {})
    if fmt == "qif":
        from holecli.quality.qif import qif_document

        return qif_document(lot, part_number=part_number, spec=lot_spec(lot))
    from holecli.quality import tables

    if fmt == "fai":
        return tables.csv_text(tables.fai_table(lot, part_number=part_number))
    return tables.csv_text(tables.characteristic_table(lot))


def lot_spec(lot):
    """The spec every record of ``lot`` was checked against, read again for its nominal centers and
    normals (QIF's features): when the records name one spec file, by path and SHA-256, that is still
    there with the same SHA-256 and none of them was mapped by a registration (whose nominals are in
    another frame). Else None: the features then stand at the measured centers, and QIF says so.
    """
    from holecli.cli.files import read_spec

    named = set()
    for m in lot.measurements:
        tolerances = (m.record.get("options") or {}).get("tolerances")
        if "error" in m.record or tolerances is None:
            continue
        if tolerances.get("registration") is not None:
            return None
        named.add((tolerances.get("spec_file"), tolerances.get("spec_sha256")))
    if len(named) != 1:
        return None
    ((path, sha256),) = named
    if not path or not sha256 or path == "-":
        return None
    try:
        spec = read_spec(path)
    except Failure:
        return None
    return spec if spec.sha256 == sha256 else None


def scan_views(lot, limit) -> dict:
    """The pictures of the scan around the doubtful holes: those with a check that failed or is undecided,
    or with a warning, in measurement order, at most ``limit``.

    Each scan is read again from its record's ``path`` (batch) or ``file``, once for all its holes.

    Returns
    -------
    dict
        ``{(measurement order, hole index): view}``: :func:`holecli.quality.scan_views.hole_view`'s dict,
        or ``{"unavailable": why}`` when the scan cannot be read any more, is not the record's, or
        matplotlib (the extra ``plot``) is missing.
    """
    from holecli.errors import HoleCliError
    from holecli.io import read_cloud
    from holecli.quality.scan_views import hole_view
    from holecli.units import scale_factor

    wanted = []
    for m in lot.measurements:
        holes = m.record.get("holes") or []
        doubtful = {c.hole_index for c in m.characteristics if c.decision in ("fail", "undecided") and c.hole_index
                    is not None}
        doubtful |= {hole.get("index", n) for n, hole in enumerate(holes) if isinstance(hole, dict) and hole.get("warnings")}
        wanted.extend((m, index) for index in sorted(doubtful))
    views, clouds = {}, {}
    for m, index in wanted[:limit]:
        hole = next((h for n, h in enumerate(m.record["holes"]) if h.get("index", n) == index), None)
        if hole is None:
            continue
        file = m.record.get("path") or m.record.get("file")
        if file not in clouds:
            clouds.clear()  # a measurement's holes come together: one scan in memory at a time
            try:
                cloud = read_cloud(file)
            except (HoleCliError, OSError, ValueError) as error:
                clouds[file] = (None, f"the scan {m.record.get('file')} cannot be read now ({error})")
            else:
                if not m.units or cloud.units == m.units:
                    clouds[file] = (cloud.points, None)
                elif cloud.units:
                    clouds[file] = (cloud.points * scale_factor(cloud.units, m.units), None)
                else:  # --units/--output-units: the record does not say which unit the file's numbers are in
                    clouds[file] = (None, f"the record is in {m.units} and the scan {m.record.get('file')} declares "
                                          f"no unit: the unit of its points is not known")
        points, why = clouds[file]
        if points is None:
            views[(m.order, index)] = {"unavailable": why}
            continue
        spacing = (m.record.get("scales") or {}).get("point_spacing")
        try:
            view = hole_view(points, hole, spacing=spacing)
        except ImportError:
            return {key: {"unavailable": "pictures of the scan need matplotlib: pip install 'holecli[plot]'"}
                    for key in [(m.order, index) for m, index in wanted[:limit]]}
        views[(m.order, index)] = view or {"unavailable": f"the scan {m.record.get('file')} holds no point around "
                                                         f"this hole (it is not the scan this record measured)"}
    return views


def read_results(path) -> list:
    """The records of one RESULTS file, each as a lot entry ``{"record", "source", ...}``.

    A file is JSON Lines (a record per line, as batch and ``detect --format jsonl`` write them, blank
    lines skipped) or one JSON record (``detect --format json``, indented). The service's answers
    (``served_record``: a record with ``id``, ``received`` and ``meta``) keep their metadata.

    Raises
    ------
    Failure
        With the input code: the file cannot be read, is not UTF-8, or a line is not JSON
        (``FILE:LINE: not JSON (...)``).
    """
    shown = "stdin" if path == "-" else path
    try:
        if path == "-":
            data = sys.stdin.buffer.read()
        else:
            with open(path, "rb") as file:
                data = file.read()
    except OSError as error:
        raise Failure(f"{shown}: cannot read: {error.strerror or error}", EXIT_INPUT) from None
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as error:
        raise Failure(f"{shown}: not a text file of JSON records (not UTF-8 at byte {error.start})", EXIT_INPUT) \
            from None
    if text.lstrip().startswith("{") and "\n" in text.strip():
        try:
            one = json.loads(text)
        except json.JSONDecodeError:
            one = None  # JSON Lines, or damaged: read line by line below, which names the line
        if isinstance(one, dict):
            return [_entry(one, shown)]
    entries = []
    for number, line in enumerate(text.splitlines(), 1):
        if not line.strip():
            continue
        try:
            value = json.loads(line)
        except json.JSONDecodeError as error:
            raise Failure(f"{shown}:{number}: not JSON ({error.msg}); holecli report reads the JSON Lines of detect "
                          f"and batch", EXIT_INPUT) from None
        entries.append(_entry(value, f"{shown}:{number}"))
    return entries


def _entry(value, source) -> dict:
    """A lot entry of one JSON value; a service's answer keeps its id, time and metadata."""
    entry = {"record": value, "source": source}
    if isinstance(value, dict) and isinstance(value.get("meta"), dict) and "id" in value:
        entry.update(meta=value["meta"], id=str(value["id"]), received=value.get("received"))
    return entry


def _store_entries(location, **filters) -> list:
    """The lot entries of a store's measurements matching ``filters``, oldest first."""
    from holecli.store import StoreError, open_store

    try:
        with open_store(location, create=False) as store:
            answers = store.answers(**filters)
    except StoreError as error:
        raise Failure(str(error), EXIT_INPUT) from None
    except ValueError as error:
        raise Failure(str(error), EXIT_USAGE) from None
    entries = []
    for answer in answers:
        record = {key: value for key, value in answer.items()
                  if key not in ("id", "received", "processing_ms", "stored", "meta")}
        entries.append({"record": record, "source": answer["id"], "meta": answer["meta"], "id": answer["id"],
                        "received": answer["received"]})
    return entries


def _store_text(location, part, serial, since, until) -> str:
    """How the report names a store and its filters: ``results.sqlite (part P7, since 2026-12-04)``."""
    from holecli.store import redacted

    filters = [f"{name} {value}" for name, value in (("part", part), ("serial", serial), ("since", since),
                                                       ("until", until)) if value is not None]
    return redacted(location) + (f" ({', '.join(filters)})" if filters else "")


def _count(number, word) -> str:
    """``1 hole``, ``2 holes``."""
    return f"{number} {word}{'' if number == 1 else 's'}"


def _natural_key(text):
    """Sort ``part_2`` before ``part_10``."""
    return [(0, int(piece), "") if piece.isdigit() else (1, 0, piece) for piece in re.split(r"(\d+)", text)]
