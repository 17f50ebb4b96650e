"""Insert rate of the results store (holecli.store): SQLite (WAL, synchronous FULL) and PostgreSQL.

Measures real records (sample_clouds/panel.ply checked against panel_tolerances.toml: 4 holes and 13
characteristics; table1.ply unchecked: 1 hole), then adds them in turn to a new store for
``--seconds`` seconds each: every add is one transaction (a measurement row, its hole rows and
characteristic rows) committed before the next begins, as ``holecli serve`` and ``batch --store``
add them. It prints the measurements per second and the latency of one add (p50, p99) for an SQLite
file in a temporary folder and for a PostgreSQL database: the one of ``--postgres URL``, else a
throwaway server of Debian's package (tests/pgserver.py, fsync on, on this machine's disk).

:func:`insert_rate` is the measuring function, for other benchmarks (benchmarks/serve.py).

Run:  python benchmarks/store.py [--seconds 5] [--postgres URL] [--json]
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from contextlib import ExitStack
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from holecli.store import open_store  # noqa: E402
from holecli.store.schema import characteristic_rows, hole_rows  # noqa: E402


def real_records() -> list:
    """The records the benchmark stores: panel.ply with its tolerances, table1.ply without."""
    from holecli import measure_scan
    from holecli.cli.files import read_spec

    clouds = ROOT / "sample_clouds"
    spec = read_spec(str(clouds / "panel_tolerances.toml"))
    return [measure_scan(str(clouds / "panel.ply"), spec=spec, resolve_path=True).record,
            measure_scan(str(clouds / "table1.ply"), resolve_path=True).record]


def insert_rate(location, records, seconds) -> dict:
    """Add ``records`` in turn to the store at ``location`` for ``seconds`` seconds, one transaction each.

    Parameters
    ----------
    location : str
        A store (:func:`holecli.store.open_store`); measurements are added to what it holds.
    records : sequence of dict
        Records to add, in turn (at least one).
    seconds : float
        How long to add (at least one add is made).

    Returns
    -------
    dict
        ``engine``, ``measurements`` (added), ``seconds`` (wall), ``per_second`` (measurements per
        second), ``holes`` and ``characteristics`` (rows added), ``p50_ms`` and ``p99_ms`` (one add).
    """
    latencies, holes, characteristics = [], 0, 0
    with open_store(location) as store:
        started = time.perf_counter()
        while not latencies or time.perf_counter() - started < seconds:
            record = records[len(latencies) % len(records)]
            before = time.perf_counter()
            store.add(record, meta={"part": "bench", "serial": str(len(latencies))}, source="benchmark")
            latencies.append(time.perf_counter() - before)
            holes += len(hole_rows(record, ""))
            characteristics += len(characteristic_rows(record, ""))
        elapsed = time.perf_counter() - started
        engine = store.engine
    latencies.sort()
    return {"engine": engine, "measurements": len(latencies), "seconds": round(elapsed, 3),
            "per_second": round(len(latencies) / elapsed, 1), "holes": holes, "characteristics": characteristics,
            "p50_ms": round(1000 * latencies[len(latencies) // 2], 3),
            "p99_ms": round(1000 * latencies[min(len(latencies) - 1, int(0.99 * len(latencies)))], 3)}


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=5.0, help="adding time per engine [5]")
    parser.add_argument("--postgres", metavar="URL", default=None,
                        help="a PostgreSQL database to add to [default: a throwaway server of tests/pgserver.py]")
    parser.add_argument("--json", action="store_true", help="print one JSON object instead of text")
    args = parser.parse_args(argv)
    records = real_records()
    results = {"records": [{"file": os.path.basename(record["file"]), "holes": len(record["holes"]),
                            "characteristics": len(characteristic_rows(record, ""))} for record in records]}
    with tempfile.TemporaryDirectory(prefix="holecli-store-bench-") as folder:
        results["sqlite"] = insert_rate(os.path.join(folder, "results.sqlite"), records, args.seconds)
    with ExitStack() as stack:
        url = args.postgres
        if url is None:
            from tests.pgserver import NoPostgres, fresh_database, postgres_server

            try:
                url = stack.enter_context(fresh_database(stack.enter_context(postgres_server(fsync=True))))
            except NoPostgres as reason:
                results["postgres"] = {"skipped": str(reason)}
        if url is not None:
            results["postgres"] = insert_rate(url, records, args.seconds)
    if args.json:
        print(json.dumps(results))
        return
    print("records: " + ", ".join(f"{r['file']} ({r['holes']} hole{'' if r['holes'] == 1 else 's'}, "
                                  f"{r['characteristics']} characteristics)" for r in results["records"]))
    for engine, label in (("sqlite", "SQLite, WAL, synchronous FULL"), ("postgres", "PostgreSQL, fsync on")):
        row = results[engine]
        if "skipped" in row:
            print(f"{label}: skipped ({row['skipped']})")
            continue
        print(f"{label}: {row['per_second']:.0f} measurements/s ({row['measurements']} in {row['seconds']:.1f} s, "
              f"one transaction each with {row['holes']} hole and {row['characteristics']} characteristic rows in all); "
              f"one add p50 {row['p50_ms']:.2f} ms, p99 {row['p99_ms']:.2f} ms")


if __name__ == "__main__":
    main()
