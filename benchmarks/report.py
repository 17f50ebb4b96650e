"""Time to report a lot with ``holecli report``: 1,000 parts of 10 holes each, from JSON Lines and from a store.

The records are real measurements: ``--measured`` simulated splice strips (benchmarks/data/splice.toml: 10
countersunk fastener holes; a 0.2 mm profiler, a cell's scatter, a seed per part, and a few parts drilled
wrong: oversize, off position, cut too deep, a hole not drilled) measured by ``holecli batch`` against
benchmarks/data/splice_tolerances.toml (5 characteristics a hole). The lot of ``--parts`` parts reports
these records in turn, each under a serial of its own (part_0001.ply, ...): a report's time depends on
the number of records, holes and characteristics, not on their values. The same lot goes into an
SQLite results store (one measurement a second). The measured records and their scans are kept in
``--cache`` (default: a folder under the system's temporary folder), so that a second run measures
nothing; the HTML reports draw the scan around the doubtful holes from them (the default
``--scan-pictures 50``).

Then each report is made as a user makes it, ``holecli report ...`` in a process of its own, timed by
wall clock and by the CPU time of the process (``resource.getrusage(RUSAGE_CHILDREN)``):

- JSON Lines to HTML (with the pictures of each hole), to HTML ``--no-pictures``, to QIF, to the AS9102
  Form 3 rows (``fai``) and to the characteristic table (``csv``);
- the SQLite store to HTML.

Goal (issue 28): each under 10 s. It prints the size of each output too.

Run:  python benchmarks/report.py [--parts 1000] [--measured 40] [--cache DIR] [--json] [--docs]

``--docs`` writes the table into the block ``report`` of docs/validation/speed.md.
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from benchmarks._docs_table import VALIDATION, add_docs_options, docs_target, recording  # noqa: E402

GOAL_SECONDS = 10.0
PANEL = ROOT / "benchmarks" / "data" / "splice.toml"
SPEC = ROOT / "benchmarks" / "data" / "splice_tolerances.toml"

# Parts drilled wrong (part number from 1 within the measured set: those beyond --measured are left out).
DEFECTS = ("3/H03=diameter:+0.08", "7/H05=position:0.15", "11/H08=missing", "17/H02=countersink:+0.06",
           "23/H09=diameter:-0.07", "31/H06=position:0.12")

# The reports timed: (name, source, extra arguments, output suffix).
CASES = (
    ("JSON Lines -> html", "jsonl", ["--format", "html"], ".html"),
    ("JSON Lines -> html --no-pictures", "jsonl", ["--format", "html", "--no-pictures"], ".html"),
    ("JSON Lines -> qif", "jsonl", ["--format", "qif"], ".qif"),
    ("JSON Lines -> fai", "jsonl", ["--format", "fai"], ".csv"),
    ("JSON Lines -> csv", "jsonl", ["--format", "csv"], ".csv"),
    ("store -> html", "store", ["--format", "html"], ".html"),
)


def holecli(*args, **options):
    """Run ``python -m holecli ARGS`` from this checkout."""
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.run([sys.executable, "-m", "holecli", *map(str, args)], env=env, **options)


def measured_records(cache, count) -> list:
    """``count`` real records of splice strips (simulated and measured once, then read from ``cache``,
    which keeps the scans too: the HTML report reads those of the doubtful holes again)."""
    import shutil

    cache = Path(cache)
    done = cache / f"measured_{count}.jsonl"
    lot = cache / f"lot_{count}"
    if not done.exists() or not lot.is_dir():
        cache.mkdir(parents=True, exist_ok=True)
        shutil.rmtree(lot, ignore_errors=True)
        defects = [argument for defect in DEFECTS if int(defect.split("/")[0]) <= count
                   for argument in ("--defect", defect)]
        holecli("simulate", "lot", lot, "--parts", count, "--panel", PANEL, "--spacing", "0.2",
                "--range-noise", "0.002", *defects, "-q", check=True)
        output = cache / f"measured_{count}.part"
        batch = holecli("batch", lot, "--spec", SPEC, "-o", output, "-q")
        if batch.returncode not in (0, 5, 8):
            raise RuntimeError(f"holecli batch ended with {batch.returncode}")
        records = sorted((json.loads(line) for line in output.read_text().splitlines()), key=lambda r: r["file"])
        output.write_text("".join(json.dumps(record) + "\n" for record in records))
        os.replace(output, done)
    return [json.loads(line) for line in done.read_text().splitlines()]


def build_lot(records, parts, folder) -> tuple:
    """The JSON Lines file and the SQLite store of a lot of ``parts`` parts made of ``records`` in turn."""
    from holecli.store import open_store

    folder = Path(folder)
    jsonl, store = folder / "lot.jsonl", folder / "lot.sqlite"
    start = datetime.datetime(2026, 12, 4, 6, 0, tzinfo=datetime.timezone.utc)
    with open(jsonl, "w") as lines, open_store(store) as opened:
        for number in range(parts):
            # its own name; "path" (batch's absolute path) still names the measured scan, which the report reads
            record = dict(records[number % len(records)], file=f"scans/part_{number + 1:04d}.ply")
            lines.write(json.dumps(record) + "\n")
            opened.add(record, meta={"part": "SPLICE-10", "serial": f"SN-{number + 1:04d}"},
                       received=start + datetime.timedelta(seconds=number), source="batch")
    return jsonl, store


def time_report(arguments, output) -> dict:
    """Run ``holecli report ARGUMENTS -o OUTPUT`` once: wall and CPU seconds, the output's size."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    started = time.perf_counter()
    result = holecli("report", *arguments, "-o", output, "-q", capture_output=True, text=True)
    wall = time.perf_counter() - started
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if result.returncode != 0:
        raise RuntimeError(f"holecli report {' '.join(map(str, arguments))}: exit {result.returncode}: {result.stderr}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return {"wall_s": wall, "cpu_s": cpu, "bytes": os.path.getsize(output)}


def run(args, progress=None) -> dict:
    """Build the lot and time every case; the figures as a dict."""
    records = measured_records(args.cache, args.measured)
    holes = sum(len(record.get("holes") or ()) for record in records) / len(records)
    rows = []
    with tempfile.TemporaryDirectory() as folder:
        jsonl, store = build_lot(records, args.parts, folder)
        if progress:
            print(f"the lot: {args.parts} parts ({args.measured} measured splice strips in turn, "
                  f"{holes:.1f} holes each, 5 characteristics a hole), JSON Lines {os.path.getsize(jsonl) / 1e6:.1f} MB",
                  file=progress)
            print(f"goal: each report under {GOAL_SECONDS:g} s (wall clock, the whole process)\n", file=progress)
            print(f"{'report':<34} {'wall s':>7} {'CPU s':>7} {'output':>10}  goal", file=progress)
        for name, source, extra, suffix in CASES:
            inputs = [jsonl] if source == "jsonl" else ["--store", store]
            figures = time_report([*inputs, *extra], Path(folder) / f"out{suffix}")
            row = {"report": name, **figures, "pass": figures["wall_s"] <= GOAL_SECONDS}
            rows.append(row)
            if progress:
                print(f"{name:<34} {row['wall_s']:>7.2f} {row['cpu_s']:>7.2f} {_size(row['bytes']):>10}  "
                      f"{'pass' if row['pass'] else 'FAIL'}", file=progress)
    return {"parts": args.parts, "measured": args.measured, "holes_per_part": holes, "rows": rows,
            "goal_s": GOAL_SECONDS, "all_pass": all(row["pass"] for row in rows)}


def _size(count) -> str:
    return f"{count / 1e6:.1f} MB" if count >= 1e5 else f"{count / 1e3:.0f} kB"


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--parts", type=int, default=1000, help="parts in the lot [1000]")
    parser.add_argument("--measured", type=int, default=40, help="splice strips simulated and measured [40]")
    parser.add_argument("--cache", default=os.path.join(tempfile.gettempdir(), "holecli-report-benchmark"),
                        help="where the measured records are kept between runs")
    parser.add_argument("--json", action="store_true", help="print one JSON object instead of text")
    add_docs_options(parser, VALIDATION / "speed.md")
    args = parser.parse_args(argv)
    if args.parts < 1 or args.measured < 1:
        parser.error("--parts and --measured must be at least 1")
    docs = docs_target(parser, args, argv, "report.py", ["report"])
    if args.json:
        figures = run(args)
        print(json.dumps(figures, indent=1))
    else:
        with recording() as printed:
            figures = run(args, progress=sys.stdout)
        if docs:
            docs.write("report", printed.text)
    return 0 if figures["all_pass"] else 1


if __name__ == "__main__":
    sys.exit(main())
