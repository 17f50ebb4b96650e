"""Tests of holecli.simulation.cell and ``holecli simulate --cell``: a registration scene whose answer is known."""

import csv
import json

import numpy as np
import pytest

from holecli.errors import SpecError
from holecli.pipeline import detect
from holecli.simulation.cell import CellSpec, ReferenceHole, random_cell, simulate_cell
from holecli.tolerance import parse_spec


def _small(seed, **options):
    """A small, coarse cell: 3 holes on a 120 x 80 mm panel, 0.1 mm pitch (fast)."""
    options.setdefault("point_pitch", 0.1)
    return random_cell(seed, 3, width=120.0, height=80.0, target_reach=300.0, **options)


@pytest.fixture(scope="module")
def cell():
    return simulate_cell(_small(3, displaced={"R2": (0.2, 0.0)}, countersunk=True, view_tilt_deg=4.0), rng=3)


def test_detect_finds_each_reference_hole_where_the_truth_says(cell):
    for scan, truth in zip(cell.scans, cell.truth["holes"]):
        assert scan.points.ndim == 2 and scan.points.shape[1] == 3 and np.isfinite(scan.points).all()
        holes = detect(scan.points, view_dir=scan.view).holes
        hole = min(holes, key=lambda h: np.linalg.norm(np.subtract(h.center, truth["center"])))
        assert np.linalg.norm(np.subtract(hole.center, truth["center"])) < 0.010
        angle = np.degrees(np.arccos(min(1.0, abs(float(np.dot(hole.normal, truth["normal"]))))))
        assert angle < 0.05
        assert hole.diameter == pytest.approx(truth["diameter"], abs=0.01)


def test_the_transform_maps_the_nominal_holes_onto_the_true_ones_but_the_displaced(cell):
    rotation, translation = np.asarray(cell.truth["rotation"]), np.asarray(cell.truth["translation"])
    np.testing.assert_allclose(rotation @ rotation.T, np.eye(3), atol=1e-12)
    np.testing.assert_allclose(cell.transform[:3, :3], rotation)
    for nominal, truth in zip(cell.nominal, cell.truth["holes"]):
        mapped = rotation @ np.asarray(nominal.center) + translation
        np.testing.assert_allclose(truth["normal"], rotation @ np.asarray(nominal.normal), atol=1e-12)
        if nominal.name == "R2":
            assert truth["displaced"] and cell.truth["displaced"] == ["R2"]
            np.testing.assert_allclose(truth["center"], mapped + rotation @ [0.2, 0.0, 0.0], atol=1e-9)
        else:
            np.testing.assert_allclose(truth["center"], mapped, atol=1e-9)
    for target, moved in zip(cell.targets, cell.truth["targets"]):
        np.testing.assert_allclose(moved["point"], rotation @ np.asarray(target.point) + translation, atol=1e-9)


def test_random_cell_is_plausible_and_reproducible():
    spec = random_cell(7, 5)
    assert spec == random_cell(7, 5)
    assert [hole.name for hole in spec.holes] == ["R1", "R2", "R3", "R4", "R5"]
    assert all(4.0 <= hole.diameter <= 8.0 for hole in spec.holes)
    centers = np.array([hole.center for hole in spec.holes])
    assert np.abs(centers[:, 0]).max() < 150.0 and np.abs(centers[:, 1]).max() < 100.0
    reach = np.linalg.norm(np.array([t.point[:2] for t in spec.targets]) - centers.mean(axis=0), axis=1)
    assert reach.max() <= 300.0
    assert np.linalg.norm(spec.translation) > 100.0
    angle = np.degrees(np.arccos((np.trace(np.asarray(spec.rotation)) - 1) / 2))
    assert 0.0 < angle < 10.0


@pytest.mark.parametrize("change, message", [
    ({"displaced": {"R9": (0.2, 0.0)}}, "'R9' is not a reference hole"),
    ({"rotation": ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, -1.0))}, "proper 3x3 rotation"),
    ({"holes": (ReferenceHole("A", (0.0, 0.0), 4.0), ReferenceHole("A", (50.0, 0.0), 4.0))}, "unique"),
    ({"range_noise": -1.0}, "range_noise must be >= 0"),
])
def test_an_invalid_cell_is_refused_with_its_reason(change, message):
    base = {"holes": (ReferenceHole("R1", (0.0, 0.0), 5.0),)}
    with pytest.raises(SpecError, match=message):
        simulate_cell(CellSpec(**{**base, **change}))


def test_simulate_cell_writes_the_scene(run, tmp_path):
    folder = tmp_path / "cell"
    args = ("simulate", "--cell", folder, "--holes", "3", "--displace", "R1=0.2,-0.1", "--spacing", "0.15",
            "--seed", "5")
    result = run(*args)
    assert result.exit_code == 0, result.stderr
    assert sorted(p.name for p in folder.iterdir()) == ["R1.ply", "R2.ply", "R3.ply", "cell.truth.json",
                                                         "part.toml", "targets.csv"]
    spec = parse_spec((folder / "part.toml").read_text())
    truth = json.loads((folder / "cell.truth.json").read_text())
    assert [hole.name for hole in spec.holes] == ["R1", "R2", "R3"] == [h["name"] for h in truth["holes"]]
    assert truth["displaced"] == ["R1"] and truth["holes"][0]["offset"] == [0.2, -0.1]
    assert truth["profiler"]["range_noise"] == 0.005 and truth["seed"] == 5
    assert np.asarray(truth["transform"]).shape == (4, 4)
    with open(folder / "targets.csv", newline="") as handle:
        rows = list(csv.reader(handle))
    assert rows[0] == ["name", "x", "y", "z", "nx", "ny", "nz"] and len(rows) == 6
    assert b"property float x" in (folder / "R2.ply").read_bytes()[:300]
    # the same seed writes the same files
    again = tmp_path / "again"
    assert run(*args[:2], again, *args[3:]).exit_code == 0
    for path in folder.iterdir():
        assert (again / path.name).read_bytes() == path.read_bytes(), path.name


@pytest.mark.parametrize("args, message", [
    (["--displace", "R7=0.2,0"], "no reference hole 'R7'"),
    (["--displace", "R1=0.2"], "NAME=DX,DY"),
    (["--hole", "0,0,3"], "--hole cannot be used with --cell"),
])
def test_simulate_cell_refuses_bad_options(run, tmp_path, args, message):
    result = run("simulate", "--cell", tmp_path / "cell", *args)
    assert result.exit_code == 2
    assert message in result.stderr
    assert not (tmp_path / "cell").exists()


def test_cell_options_need_cell_and_output_is_still_required(run, tmp_path):
    result = run("simulate", tmp_path / "scan.ply", "--displace", "R1=0,0")
    assert result.exit_code == 2 and "--displace need --cell" in result.stderr
    result = run("simulate")
    assert result.exit_code == 2 and "OUTPUT" in result.stderr
    result = run("simulate", tmp_path / "scan.ply", "--cell", tmp_path / "cell")
    assert result.exit_code == 2 and "give no OUTPUT" in result.stderr
