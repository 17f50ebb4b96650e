"""benchmarks/uncertainty.py: its core on one or two scenes per suite, and the table's structure (the full
benchmark takes minutes)."""

import importlib.util
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def bench():
    spec = importlib.util.spec_from_file_location("benchmark_uncertainty", REPO / "benchmarks" / "uncertainty.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def cad_suite(tmp_path_factory):
    folder = tmp_path_factory.mktemp("cad")
    subprocess.run([sys.executable, str(REPO / "scripts" / "make_cad_suite.py"), str(folder), "--segments", "1024",
                    "--only", "plain_lattice_p100_n00"], check=True, stdout=subprocess.DEVNULL)
    return folder


def _check_row(row):
    assert len(row["center"]) == 2 and row["u_center"] > 0 and row["u_diameter"] > 0
    assert row["estimator"] in ("rim_fit", "lattice", "empty_circle", "cone")


def test_each_suite_gives_rows_and_one_line_of_the_table(bench, cad_suite):
    rows, counts = [], {}
    for kind, seed in (("synth_grid", 1000), ("scan_through", 1000)):
        found, missed, _ = bench.run_task((kind, seed))
        rows += found
        counts[kind.split("_")[0]] = missed
    bench._init({"view_dir": ["cad"], "scorer_path": None})
    scorer = bench.load_scorer()
    if scorer is None:  # the CAD suite is matched by the validation scorer: without it, no file suite
        pytest.skip("the validation scorer (../shared/validation/score.py) is absent")
    bench.RUN_OPTIONS["scorer"] = scorer
    files = bench.suite_tasks("cad", cad_suite, limit=1)
    if (bench.VALIDATION / "cases.json").exists():
        files += [t for t in bench.suite_tasks("validation", bench.VALIDATION) if "pflat_d3.2_fine" in t[1]][:1]
    for task in files:
        found, missed, error = bench.run_task(task)
        assert error is None
        rows += found
        counts[task[0]] = counts.get(task[0], 0) + missed
    assert {r["suite"] for r in rows} == set(counts)
    for row in rows:
        _check_row(row)
    cad = [r for r in rows if r["suite"] == "cad"]
    assert len(cad) == 3 and all(r["round"] for r in cad)  # 1024 segments: each edge has one diameter
    table = bench.suite_table(rows, counts, first_seed=1000)
    assert [t["suite"] for t in table] == [s for s in bench.SUITES if s in counts]
    for line in table:
        assert line["holes"] >= 1 and 0.0 <= line["center"] <= 1.0 and 0.0 <= line["diameter"] <= 1.0
        assert line["center_median"] >= 0 and line["diameter_median"] >= 0
        assert line["calibration"].startswith("held out")
    assert bench.calibration_note("synth", 0).startswith("calibrated on")
    text = bench.format_table(table)
    assert text.splitlines()[0].split()[:4] == ["suite", "holes", "center", "diameter"]
    assert len(text.splitlines()) == 2 + len(table)
