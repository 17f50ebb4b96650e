"""benchmarks/report.py: it measures real records once, reports a lot from JSON Lines and the store, and prints its table."""

import importlib.util
import json
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def bench():
    spec = importlib.util.spec_from_file_location("benchmark_report", REPO / "benchmarks" / "report.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_a_small_lot_is_reported_in_every_format(bench, tmp_path, capsys):
    code = bench.main(["--parts", "4", "--measured", "3", "--cache", str(tmp_path / "cache")])
    printed = capsys.readouterr().out
    assert code == 0, printed
    for name, *_ in bench.CASES:
        assert name in printed
    assert "the lot: 4 parts (3 measured splice strips in turn, 10.0 holes each" in printed
    # measured once: the cache holds the records and their scans, and a second run measures nothing
    records = (tmp_path / "cache" / "measured_3.jsonl").read_text().splitlines()
    assert len(records) == 3 and all(Path(json.loads(line)["path"]).is_file() for line in records)
    assert json.loads(records[2])["verdict"]["in_tolerance"] is False  # part 3: H03 drilled 0.08 mm large


def test_the_lot_repeats_the_measured_records_under_their_own_names(bench, tmp_path):
    records = [{"file": "a.ply", "path": "/x/a.ply", "holes": []}, {"file": "b.ply", "path": "/x/b.ply", "holes": []}]
    jsonl, store = bench.build_lot(records, 5, tmp_path)
    lines = [json.loads(line) for line in jsonl.read_text().splitlines()]
    assert [line["file"] for line in lines] == [f"scans/part_{n:04d}.ply" for n in range(1, 6)]
    assert [line["path"] for line in lines] == ["/x/a.ply", "/x/b.ply"] * 2 + ["/x/a.ply"]
    from holecli.store import open_store

    with open_store(store, create=False) as opened:
        answers = opened.answers()
    assert [a["meta"]["serial"] for a in answers] == [f"SN-{n:04d}" for n in range(1, 6)]
