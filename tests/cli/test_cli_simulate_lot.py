"""holecli simulate --lot: a folder of N simulated parts with chosen defects and a manifest, written all
or none; and, end to end, that batch with the sample spec passes the clean parts and rejects exactly the
defective ones (issue 25, items 10 and 3 of the lot helper)."""

import json

import pytest

from holecli import cli
from tests.conftest import REPO_ROOT

PANEL = REPO_ROOT / "sample_clouds" / "panel.toml"
SPEC = REPO_ROOT / "sample_clouds" / "panel_tolerances.toml"
SCAN = ("--spacing", "0.2", "--range-noise", "0.002")  # as sample_clouds/panel.ply was made
DEFECTS = ("2/C1=diameter:+0.1", "3/L1=missing", "4/T1=position:0.3", "5/C1=countersink:0.1")


@pytest.fixture(scope="module")
def lot(tmp_path_factory):
    from click.testing import CliRunner

    folder = tmp_path_factory.mktemp("lot") / "lot"
    args = ["simulate", "--lot", folder, "--parts", "6", "--panel", PANEL, *SCAN, "--seed", "3"]
    for defect in DEFECTS:
        args += ["--defect", defect]
    result = CliRunner().invoke(cli.main, [str(arg) for arg in args])
    assert result.exit_code == 0, result.output
    return folder, result


def test_the_lot_holds_its_scans_truths_and_manifest(lot):
    folder, result = lot
    names = sorted(path.name for path in folder.iterdir())
    assert names == ["manifest.json", *(f"part_00{i}.{ext}" for i in range(1, 7) for ext in ("ply", "truth.json"))]
    manifest = json.loads((folder / "manifest.json").read_text())
    assert manifest["parts"] == 6 and manifest["defects"] == list(DEFECTS)
    assert manifest["defective"] == ["part_002.ply", "part_003.ply", "part_004.ply", "part_005.ply"]
    assert [part["file"] for part in manifest["lot"]] == [f"part_00{i}.ply" for i in range(1, 7)]
    assert [d["defect"] for d in manifest["lot"][2]["defects"]] == ["3/L1=missing"]
    truth = json.loads((folder / "part_003.truth.json").read_text())
    assert "L1" not in {hole["name"] for hole in truth["holes"]} and truth["part"] == 3
    assert f"wrote 6 scans of {PANEL} (4 with defects) and manifest.json to {folder}" in result.stderr


def test_batch_with_the_sample_spec_rejects_exactly_the_defective_parts(lot, run):
    folder, _ = lot
    result = run("batch", folder, "--spec", SPEC)
    assert result.exit_code == cli.EXIT_OUT_OF_TOLERANCE, result.stderr
    records = {json.loads(line)["file"].rsplit("/", 1)[-1]: json.loads(line) for line in result.stdout.splitlines()}
    manifest = json.loads((folder / "manifest.json").read_text())
    rejected = sorted(name for name, record in records.items() if not record["verdict"]["in_tolerance"])
    assert rejected == manifest["defective"]
    failed = {name: {hole["name"]: hole["failed_checks"] for hole in record["holes"] if hole["failed_checks"]}
              for name, record in records.items()}
    assert failed["part_002.ply"] == {"C1": ["diameter", "countersink_diameter"]}
    assert records["part_003.ply"]["verdict"]["missing"] == ["L1"]
    assert failed["part_004.ply"] == {"T1": ["position"]}
    assert set(failed["part_005.ply"]["C1"]) >= {"diameter", "countersink_diameter", "countersink_depth"}
    assert "parts rejected: 4 of 6; holes out of tolerance: 3, nominal holes missing: 1" in result.stderr


def test_a_folder_that_is_not_empty_is_refused_and_left_as_it_was(run, tmp_path):
    (tmp_path / "lot").mkdir()
    (tmp_path / "lot" / "keep.txt").write_text("mine")
    result = run("simulate", "--lot", tmp_path / "lot", "--parts", "2", "--panel", PANEL)
    assert result.exit_code == cli.EXIT_USAGE
    assert result.stderr.startswith(f"Error: {tmp_path / 'lot'}: exists and is not an empty folder")
    assert [path.name for path in (tmp_path / "lot").iterdir()] == ["keep.txt"]


def test_a_part_that_cannot_be_made_leaves_nothing(run, tmp_path):
    # part 2's T1 drilled 30 mm off: beyond the sheet's border, after part 1 was written
    result = run("simulate", "--lot", tmp_path / "lot", "--parts", "2", "--panel", PANEL, *SCAN,
                 "--defect", "2/T1=position:30")
    assert result.exit_code == cli.EXIT_INPUT
    assert result.stderr.startswith(f"Error: {PANEL}: part 2 (2/T1=position:30): ")
    assert list(tmp_path.iterdir()) == []  # neither the lot nor its staging folder


@pytest.mark.parametrize("args, code, message", [
    (("--defect", "C1=bigger:1"), cli.EXIT_USAGE, "unknown defect 'bigger'"),
    (("--defect", "X9=missing"), cli.EXIT_INPUT, "the panel has no hole named 'X9'"),
    (("--defect", "C1=countersink:0.1", "--defect", "T1=countersink:0.1"), cli.EXIT_INPUT,
     "T1 is through, not countersunk"),
])
def test_bad_defects_are_refused_before_anything_is_written(run, tmp_path, args, code, message):
    result = run("simulate", "--lot", tmp_path / "lot", "--parts", "2", "--panel", PANEL, *args)
    assert result.exit_code == code, result.stderr
    assert message in result.stderr
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("args, message", [
    (("--parts", "3"), "--parts need --lot"),
    (("--lot", "x", "--parts", "3"), "--lot needs --panel (the drawing) and --parts (how many)"),
    (("--lot", "x", "--panel", str(PANEL)), "--lot needs --panel (the drawing) and --parts (how many)"),
    (("out.ply", "--lot", "x", "--parts", "3", "--panel", str(PANEL)), "--lot cannot be used with OUTPUT"),
    (("--lot", "x", "--parts", "3", "--panel", str(PANEL), "--cell", "c"), "--lot cannot be used with --cell"),
])
def test_lot_option_combinations(run, tmp_path, monkeypatch, args, message):
    monkeypatch.chdir(tmp_path)
    result = run("simulate", *args)
    assert result.exit_code == cli.EXIT_USAGE
    assert message in result.stderr
    assert list(tmp_path.iterdir()) == []
