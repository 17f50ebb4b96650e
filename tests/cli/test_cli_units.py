"""The command line and units (issue 25, item 3): declared spec units, unit mistakes named on stderr and
in the records, the "no hole found" hint of a --min-diameter in another unit, the batch CSV's units."""

import csv
import io
import json

import pytest

from holecli.cli.exits import EXIT_NO_HOLE, EXIT_OK, EXIT_OUT_OF_TOLERANCE, EXIT_WARNING
from holecli.io import load_points, save_points
from holecli.schema import record_schema


def validate_record(record):
    """``record`` against the JSON Schema of a detect record (jsonschema when installed)."""
    jsonschema = pytest.importorskip("jsonschema")
    jsonschema.Draft202012Validator(record_schema("detect_record")).validate(record)

# table1.ply's one hole: about 2.997 mm, its center near (3.650, 5.139, 5.530) mm.
CENTER_MM = (3.6498, 5.1392, 5.5300)


@pytest.fixture(scope="module")
def scans(tmp_path_factory):
    """The Table I scan in mm (as shipped), in m and in inches: {unit: path}."""
    from pathlib import Path

    folder = tmp_path_factory.mktemp("units")
    points = load_points(Path(__file__).resolve().parents[2] / "sample_clouds" / "table1.ply")
    paths = {}
    for unit, factor in (("mm", 1.0), ("m", 1e-3), ("in", 1 / 25.4)):
        paths[unit] = folder / f"table1_{unit}.ply"
        save_points(paths[unit], points * factor)
    return paths


def _spec(tmp_path, units=None, factor=1.0, name="part.toml"):
    path = tmp_path / name
    head = f'units = "{units}"\n' if units else ""
    center = ", ".join(f"{c * factor!r}" for c in CENTER_MM)
    path.write_text(f'{head}[[hole]]\nname = "A"\ncenter = [{center}]\ndiameter = {3.0 * factor!r}\n'
                    f'tolerance = {0.02 * factor!r}\nposition_tolerance = {0.1 * factor!r}\n')
    return path


def test_a_metres_scan_against_a_3_mm_tolerance_names_the_unit_mistake(run, scans):
    """Before: "out of tolerance" (deviation -2.997) and nothing else."""
    result = run("detect", scans["m"], "--nominal-diameter", 3, "--tolerance", 0.02)
    assert result.exit_code == EXIT_OUT_OF_TOLERANCE
    assert "unit_mismatch: measured diameter 0.002997 is 1/1000 of the nominal 3" in result.stderr
    assert "the scan may be in m and the tolerances in mm" in result.stderr
    assert "1 hole with unit_mismatch" in result.stderr.splitlines()[-1]
    record = json.loads(result.stdout)
    assert [w["code"] for w in record["holes"][0]["warnings"]] == ["unit_mismatch"]
    validate_record(record)
    # the advice is the options that fix it: the tolerances are in the output unit, not the scan's
    assert "give --units m --output-units mm" in result.stderr
    # --units alone puts the tolerances in m too: the warning says so rather than "give --units" again
    result = run("detect", scans["m"], "--units", "m", "--nominal-diameter", 3, "--tolerance", 0.02)
    assert result.exit_code == EXIT_OUT_OF_TOLERANCE
    assert "the record is in m and the tolerances are taken in it" in result.stderr
    assert "--output-units mm with --units m" in result.stderr
    # --units with --output-units says it: no mistake, in tolerance
    result = run("detect", scans["m"], "--units", "m", "--output-units", "mm", "--nominal-diameter", 3,
                 "--tolerance", 0.02)
    assert result.exit_code == EXIT_OK and "unit_mismatch" not in result.stderr
    # the code is one --fail-on-warning takes
    result = run("detect", scans["m"], "--fail-on-warning", "unit_mismatch", "--nominal-diameter", 0.003,
                 "--tolerance", 0.00002)
    assert result.exit_code == EXIT_OK, result.stderr


def test_a_spec_in_inches_checks_a_scan_in_mm(run, scans, tmp_path):
    """Before: the spec could not say its unit (units = "in" refused), and in inches every hole was missing."""
    spec = _spec(tmp_path, "in", 1 / 25.4)
    result = run("detect", scans["mm"], "--units", "mm", "--spec", spec)
    assert result.exit_code == EXIT_OK, result.stderr
    record = json.loads(result.stdout)
    assert record["verdict"]["in_tolerance"] and record["verdict"]["spec_units"] == "in"
    assert record["verdict"]["spec_units_assumed"] is False and record["units"] == "mm"
    assert record["holes"][0]["conformance"]["diameter"]["upper"] == pytest.approx(0.02)
    validate_record(record)


def test_a_spec_unit_without_the_scans_is_assumed_and_said(run, scans, tmp_path):
    spec = _spec(tmp_path, "in", 1 / 25.4)
    result = run("detect", scans["in"], "--spec", spec)
    assert result.exit_code == EXIT_OK, result.stderr
    assert "spec_units_assumed: the spec is in in and the scan's unit is not known" in result.stderr
    record = json.loads(result.stdout)
    assert record["units"] == "in" and record["verdict"]["spec_units_assumed"] is True
    validate_record(record)
    assert "spec_units_assumed" not in run("detect", scans["in"], "--spec", spec, "-q").stderr


def test_a_spec_far_from_the_scan_by_a_factor_of_units_says_which(run, scans, tmp_path):
    """A scan in m, a spec in mm (no units): every hole missing; the hint names the factor and the units."""
    result = run("detect", scans["m"], "--spec", _spec(tmp_path))
    assert result.exit_code == EXIT_OUT_OF_TOLERANCE
    assert "missing: A" in result.stderr
    assert ("every spec hole matches a measured one with the scan's coordinates times 1000: the scan may be in m "
            "and the spec in mm; give --units m") in result.stderr
    # and the advice works: the spec declares mm, the scan is said to be in m
    result = run("detect", scans["m"], "--units", "m", "--spec", _spec(tmp_path, "mm", name="mm.toml"))
    assert result.exit_code == EXIT_OK, result.stderr


def test_no_hole_found_with_a_min_diameter_larger_than_the_scan(run, scans):
    """Before: "--min-diameter 2" on a metres scan said "no hole found" and nothing of units."""
    result = run("detect", scans["m"], "--min-diameter", 2)
    assert result.exit_code == EXIT_NO_HOLE
    line = result.stderr.strip().splitlines()[-1]
    assert line.startswith("holecli: no hole found") and "--min-diameter 2 is larger than the whole scan" in line
    assert "is it in the scan's unit?" in line
    # a min-diameter that fits the scan but finds nothing: no such hint
    result = run("detect", scans["mm"], "--min-diameter", 3.5)
    assert result.exit_code == EXIT_NO_HOLE and "larger than the whole scan" not in result.stderr


def test_batch_says_unit_mistakes_and_fills_the_units_column(run, scans, tmp_path):
    spec = _spec(tmp_path, "mm")
    result = run("batch", scans["mm"], scans["in"], "--spec", spec, "--format", "csv")
    rows = {row["file"]: row for row in csv.DictReader(io.StringIO(result.stdout))}
    # each row says the unit of its values: the spec's, taken for the scan's (mm); the inch scan, far
    # from the spec, is said as such
    assert {row["units"] for row in rows.values()} == {"mm"}
    assert f"{scans['mm']}: spec_units_assumed" in result.stderr
    # the command-line nominal on a scan in m: the mistake on stderr, in the CSV's warnings
    result = run("batch", scans["m"], "--nominal-diameter", 3, "--tolerance", 0.02, "--format", "csv")
    (row,) = csv.DictReader(io.StringIO(result.stdout))
    assert row["warnings"] == "unit_mismatch"
    assert "hole 0: unit_mismatch: measured diameter 0.002997 is 1/1000" in result.stderr
    assert "unit_mismatch 1" in result.stderr  # the summary's count of doubtful holes
    assert "unit_mismatch" not in run("batch", scans["m"], "-q", "--nominal-diameter", 3, "--tolerance", 0.02).stderr
    result = run("batch", scans["m"], "--fail-on-warning", "unit_mismatch", "--nominal-diameter", 3,
                 "--tolerance", 0.02)
    assert result.exit_code in (EXIT_OUT_OF_TOLERANCE, EXIT_WARNING)


def test_batch_warns_when_units_overrides_e57_metres_in_a_mixed_batch(run, scans, repo_root):
    e57 = repo_root / "tests" / "data" / "e57" / "pye57_testWithNormals.e57"
    result = run("batch", scans["mm"], e57, "--units", "mm", "--format", "csv")
    assert "e57_units_overridden: --units mm is taken for the 1 E57 file too" in result.stderr
    for args in ((scans["mm"], e57), (scans["mm"], "--units", "mm"), (scans["mm"], e57, "--units", "m")):
        assert "e57_units_overridden" not in run("batch", *args, "--format", "csv").stderr


def test_register_takes_a_spec_that_declares_its_unit(run, tmp_path):
    """A spec with units = "mm" was refused by every command (unknown top-level key 'units')."""
    from holecli.simulation import synth

    holes = ((0.0, 0.0), (20.0, 0.0), (0.0, 12.0))
    scene = synth.SceneSpec(holes=tuple(synth.HoleSpec(center=c, diameter=3.0) for c in holes),
                            extent=(-4.0, 24.0, -4.0, 16.0), spacing=0.12)
    scan = tmp_path / "three.ply"
    save_points(scan, synth.make_scan(scene, 0).points)
    text = "".join(f'[[hole]]\nname = "H{k}"\ncenter = [{x}, {y}, 0.0]\nnormal = [0, 0, 1]\n'
                   'diameter = 3.0\ntolerance = 0.05\n' for k, (x, y) in enumerate(holes))
    plain, declared = tmp_path / "plain.toml", tmp_path / "declared.toml"
    plain.write_text(text)
    declared.write_text('units = "mm"\n' + text)
    first, second = run("register", scan, "--spec", plain), run("register", scan, "--spec", declared)
    assert second.exit_code == first.exit_code == EXIT_OK, second.stderr
    assert json.loads(second.stdout)["transform"] == json.loads(first.stdout)["transform"]
    # targets in inches (# units = in) against the spec's mm: converted, the same corrected targets as in mm
    in_mm, in_inches = tmp_path / "targets_mm.csv", tmp_path / "targets_in.csv"
    in_mm.write_text("name,x,y,z,nx,ny,nz\nT1,10.16,5.08,0,0,0,1\n")
    in_inches.write_text("# units = in\nname,x,y,z,nx,ny,nz\nT1,0.4,0.2,0,0,0,1\n")
    corrected = {}
    for path in (in_mm, in_inches):
        corrected[path] = tmp_path / f"corrected_{path.stem}.csv"
        result = run("register", scan, "--spec", declared, "--targets", path, "--targets-output", corrected[path])
        assert result.exit_code == EXIT_OK, result.stderr
    rows = [next(csv.DictReader(io.StringIO(corrected[path].read_text()))) for path in (in_mm, in_inches)]
    for key in ("x", "y", "z"):
        assert float(rows[1][key]) == pytest.approx(float(rows[0][key]), abs=1e-9)
