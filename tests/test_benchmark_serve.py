"""benchmarks/serve.py: one --quick run prints every figure (the full benchmark takes about ten minutes)."""

import importlib.util
import io
import json
import os
import subprocess
import sys

import pytest

from tests.conftest import REPO_ROOT


@pytest.fixture(scope="module")
def bench():
    spec = importlib.util.spec_from_file_location("benchmark_serve", REPO_ROOT / "benchmarks" / "serve.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # its dataclass looks its module up there
    try:
        spec.loader.exec_module(module)
        yield module
    finally:
        del sys.modules[spec.name]


@pytest.fixture(scope="module")
def figures():
    """The JSON of a --quick run (its servers started and stopped by the script itself)."""
    result = subprocess.run([sys.executable, str(REPO_ROOT / "benchmarks" / "serve.py"), "--quick", "--json",
                             "--requests", "16", "--rounds", "2"], capture_output=True, text=True, timeout=900,
                            env=dict(os.environ, PYTHONPATH=str(REPO_ROOT)), cwd=REPO_ROOT)
    assert result.returncode == 0, result.stderr[-3000:]
    return json.loads(result.stdout)


@pytest.mark.slow
def test_a_quick_run_gives_every_figure_and_stops_its_servers_cleanly(figures):
    names = ["sim 10^3", "sim 10^4", "table1"]
    assert list(figures["baseline"]) == names and list(figures["one_shot"]) == names
    for name in names:
        assert figures["baseline"][name]["p50_ms"] > 0 and figures["baseline"][name]["cpu_p50_ms"] >= 0
        assert figures["one_shot"][name]["p50_ms"] > figures["baseline"][name]["p50_ms"] / 10
    channels = ["HTTP path", "HTTP upload"] + ["TCP path"] * figures["channels"]["tcp"] \
        + ["OPC UA path"] * figures["channels"]["opcua"]
    assert [(row["scan"], row["channel"]) for row in figures["latency"]] == [(n, c) for n in names for c in channels]
    for row in figures["latency"]:
        assert row["requests"] == 2 and row["p99_ms"] >= row["p50_ms"] > 0
        assert row["pass"] == (row["p50_ms"] - row["in_process_p50_ms"] <= 10.0)
        assert (row["server_processing_p50_ms"] is not None) == row["channel"].startswith("HTTP")
        for key in ("outside_service_p50_ms", "worker_measuring_p50_ms"):
            assert (row[key] is not None) == row["channel"].startswith("HTTP")
    assert [run["workers"] for run in figures["throughput"]["runs"]] == [1, 2]
    assert [run["processes"] for run in figures["throughput"]["in_process"]] == [1, 2]
    assert all(run["scans_per_s"] > 0 for run in figures["throughput"]["runs"] + figures["throughput"]["in_process"])
    soak = figures["soak"]
    assert soak["requests"] == 16 and soak["errors"] == 0 and soak["rss_before_mb"] > 0
    assert figures["store"][0]["engine"].startswith("SQLite") and figures["store"][0]["inserts_per_s"] > 0
    assert figures["stops"] == [[1, 0], [2, 0]] and figures["goals"]["clean_stops"]


@pytest.mark.slow
def test_the_tables_print_every_section_of_the_figures(bench, figures):
    out = io.StringIO()
    for section in (bench._print_baselines, bench._print_latency, bench._print_throughput, bench._print_soak,
                    bench._print_store, bench._print_stops):
        section(figures, out)
    text = out.getvalue()
    for heading in ("1. Baselines", "2. Latency", "3. Throughput", "4. Soak", "5. The store's insert rate",
                    "servers stopped with SIGTERM: --workers 1: exit 0, --workers 2: exit 0"):
        assert heading in text
    assert text.count("PASS") + text.count("FAIL") == len(figures["latency"]) + 2
    assert "ratio --workers 2 / --workers 1" in text and "the machine's own, 2 processes / 1" in text
    assert "in-process, 2 processes" in text and "serve --workers 2" in text and "growth" in text


def test_a_docs_page_without_the_block_is_refused_before_anything_runs(bench, tmp_path, capsys):
    page = tmp_path / "page.md"
    page.write_text("# no markers\n", encoding="utf-8")
    with pytest.raises(SystemExit) as exit_:
        bench.main(["--quick", "--docs-page", str(page)])
    assert exit_.value.code == 2
    assert "no line '<!-- BEGIN benchmark: serve -->'" in capsys.readouterr().err
