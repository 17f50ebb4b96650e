"""holecli.simulation.files: simulate's writers of a scan, a cell and a lot."""

import json
import os

import numpy as np
import pytest

from holecli.io import load_points
from holecli.simulation.cell import random_cell, simulate_cell
from holecli.simulation.files import CannotWrite, LotPartError, write_cell, write_lot, write_scan
from holecli.simulation.lot import lot_parts
from holecli.simulation.panel import parse_panel_toml
from holecli.simulation.part import aimed_profiler
from holecli.tolerance import parse_spec
from tests.conftest import REPO_ROOT
from tests.simulation.test_part import DEFAULTS

PANEL = parse_panel_toml((REPO_ROOT / "sample_clouds" / "panel.toml").read_text())


def test_a_scan_and_its_truth_are_written_beside_each_other(tmp_path):
    points = np.array([[0.1, 0.2, 0.3], [1.0, 2.0, 3.0]])
    target = write_scan(str(tmp_path / "scan.ply"), points, {"holes": []}, float32=False)
    assert target == str(tmp_path / "scan.truth.json") and json.loads((tmp_path / "scan.truth.json").read_text())
    np.testing.assert_array_equal(load_points(str(tmp_path / "scan.ply")), points)


def test_a_cell_is_written_with_a_spec_the_tolerance_reader_takes(tmp_path):
    cell = simulate_cell(random_cell(1, 3), 1)
    truth = write_cell(tmp_path / "cell", cell, seed=1)
    names = sorted(os.listdir(tmp_path / "cell"))
    scans = [f"{scan.name}.ply" for scan in cell.scans]
    assert names == sorted(scans + ["part.toml", "targets.csv", "cell.truth.json"])
    assert truth["seed"] == 1 and json.loads((tmp_path / "cell" / "cell.truth.json").read_text()) == truth
    spec = parse_spec((tmp_path / "cell" / "part.toml").read_text())
    assert [hole.name for hole in spec.holes] == [hole.name for hole in cell.nominal]


def _aim(vertices):
    return aimed_profiler(vertices, **dict(DEFAULTS, spacing=0.4))


def test_a_lot_is_written_whole_with_its_manifest(tmp_path):
    seen = []
    parts = write_lot(str(tmp_path / "lot"), lot_parts(PANEL, 2, seed=3), _aim, {"panel": "panel.toml"},
                      progress=lambda name, points, truth: seen.append((name, points > 0)))
    assert seen == [("part_001.ply", True), ("part_002.ply", True)]
    assert [part["file"] for part in parts] == ["part_001.ply", "part_002.ply"]
    manifest = json.loads((tmp_path / "lot" / "manifest.json").read_text())
    assert manifest["panel"] == "panel.toml" and manifest["units"] == "mm" and manifest["lot"] == parts
    assert os.listdir(tmp_path) == ["lot"]


def test_a_lot_whose_part_cannot_be_scanned_leaves_nothing(tmp_path):
    def aim(vertices):
        raise ValueError("no sensor")

    with pytest.raises(LotPartError) as raised:
        write_lot(str(tmp_path / "lot"), lot_parts(PANEL, 2, seed=3), aim, {})
    assert raised.value.truth["part"] == 1 and str(raised.value.error) == "no sensor"
    assert os.listdir(tmp_path) == []


def test_a_lot_that_cannot_be_written_names_the_folder(tmp_path):
    with pytest.raises(CannotWrite) as raised:
        write_lot(str(tmp_path / "missing" / "lot"), lot_parts(PANEL, 1, seed=3), _aim, {})
    assert raised.value.path == str(tmp_path / "missing" / "lot") and "cannot write" in str(raised.value)
