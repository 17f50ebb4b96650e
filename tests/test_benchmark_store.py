"""benchmarks/store.py: it runs (briefly) and prints its fields; insert_rate as other benchmarks call it."""

import importlib.util
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def bench():
    spec = importlib.util.spec_from_file_location("benchmark_store", REPO / "benchmarks" / "store.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_insert_rate_adds_real_records_one_transaction_each(bench, tmp_path, table1_record_file):
    records = [json.loads(table1_record_file.read_text())]
    row = bench.insert_rate(str(tmp_path / "results.sqlite"), records, 0.2)
    assert row["engine"] == "sqlite" and row["measurements"] >= 1 and row["holes"] == row["measurements"]
    assert row["per_second"] > 0 and 0 < row["p50_ms"] <= row["p99_ms"]
    from holecli.store import open_store

    with open_store(tmp_path / "results.sqlite") as store:
        assert store.count() == row["measurements"]


@pytest.fixture
def table1_record_file(tmp_path, repo_root):
    from holecli import measure_scan

    path = tmp_path / "table1.json"
    path.write_text(json.dumps(measure_scan(str(repo_root / "sample_clouds" / "table1.ply")).record))
    return path


def test_the_benchmark_prints_both_engines_as_json(postgres_store_url):
    result = subprocess.run([sys.executable, str(REPO / "benchmarks" / "store.py"), "--seconds", "0.3",
                             "--postgres", postgres_store_url, "--json"],
                            capture_output=True, text=True, timeout=120, cwd=REPO,
                            env=dict(os.environ, PYTHONPATH=str(REPO)))
    assert result.returncode == 0, result.stderr
    results = json.loads(result.stdout)
    assert [record["holes"] for record in results["records"]] == [4, 1]
    for engine in ("sqlite", "postgres"):
        row = results[engine]
        assert row["engine"] == engine and row["measurements"] >= 1 and row["per_second"] > 0
        assert set(row) == {"engine", "measurements", "seconds", "per_second", "holes", "characteristics",
                            "p50_ms", "p99_ms"}


def test_the_benchmark_prints_text(postgres_store_url):
    result = subprocess.run([sys.executable, str(REPO / "benchmarks" / "store.py"), "--seconds", "0.2",
                             "--postgres", postgres_store_url], capture_output=True, text=True, timeout=120,
                            cwd=REPO, env=dict(os.environ, PYTHONPATH=str(REPO)))
    assert result.returncode == 0, result.stderr
    lines = result.stdout.splitlines()
    assert lines[0].startswith("records: panel.ply (4 holes, 13 characteristics)")
    assert lines[1].startswith("SQLite, WAL, synchronous FULL: ") and "measurements/s" in lines[1]
    assert lines[2].startswith("PostgreSQL, fsync on: ") and "measurements/s" in lines[2]
