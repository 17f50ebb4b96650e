"""holecli.units: the conversion of a record between length units, and the CLI's --units/--output-units."""

import json
import math
from pathlib import Path

import pytest

from holecli import units
from holecli.io import load_points, save_points

SAMPLES = Path(__file__).resolve().parents[1] / "sample_clouds"


def _compare(converted, reference, path="record"):
    """Every number of two records equal to round-off; every other value equal. The warnings' and
    notes' text quotes numbers in file units and is compared by code only."""
    if isinstance(reference, dict):
        assert set(converted) == set(reference), path
        for key in reference:
            if key in ("timing", "file"):
                continue
            if key in ("warnings", "notes"):
                assert [w["code"] for w in converted[key]] == [w["code"] for w in reference[key]], path
                continue
            _compare(converted[key], reference[key], f"{path}.{key}")
    elif isinstance(reference, list):
        assert len(converted) == len(reference), path
        for index, (a, b) in enumerate(zip(converted, reference)):
            _compare(a, b, f"{path}[{index}]")
    elif isinstance(reference, float) and not isinstance(reference, bool):
        assert math.isclose(converted, reference, rel_tol=1e-6, abs_tol=1e-9), (path, converted, reference)
    else:
        assert converted == reference, path


@pytest.fixture(scope="module")
def panel_in_mm_and_m(tmp_path_factory):
    """The sample panel (mm) and the same points in metres, both measured with --explain, the gauge
    depth and the panel's tolerance spec, as the CLI writes the records: {unit: record}."""
    from click.testing import CliRunner

    from holecli import cli

    folder = tmp_path_factory.mktemp("units")
    points = load_points(SAMPLES / "panel.ply")
    save_points(folder / "panel_m.ply", points / 1000.0)
    runner = CliRunner()
    records = {}
    for unit, scan in (("mm", SAMPLES / "panel.ply"), ("m", folder / "panel_m.ply")):
        result = runner.invoke(cli.main, ["detect", str(scan), "--explain", "--units", unit,
                                          "--output-units", "mm", "--gauge-depth", "0.5",
                                          "--spec", str(SAMPLES / "panel_tolerances.toml")])
        assert result.exit_code == 0, result.output  # every hole in tolerance
        records[unit] = json.loads(result.stdout)
        plain = runner.invoke(cli.main, ["detect", str(scan), "--explain"])
        records[f"{unit} as read"] = json.loads(plain.stdout)
    return records


def test_a_metre_scan_converted_is_the_millimetre_scan(panel_in_mm_and_m):
    mm, from_m = panel_in_mm_and_m["mm"], panel_in_mm_and_m["m"]
    assert mm["units"] == from_m["units"] == "mm"
    assert len(mm["holes"]) == 4 and mm["rejected"]
    assert any(hole["countersink"] for hole in mm["holes"])
    _compare(from_m, mm)


def test_convert_record_scales_every_length_and_nothing_else(panel_in_mm_and_m):
    read_m = panel_in_mm_and_m["m as read"]
    assert "units" not in read_m  # unspecified without --units
    converted = units.convert_record(read_m, "m", "mm")
    reference = units.label_record(panel_in_mm_and_m["mm as read"], "mm")
    _compare(converted, reference)
    assert list(converted) == list(reference)
    # the input is left as it was
    assert "units" not in read_m and read_m["plane"]["rms"] < 1e-5


def test_convert_record_round_trip_and_keys(panel_in_mm_and_m):
    record = panel_in_mm_and_m["mm"]
    there = units.convert_record(record, "mm", "in")
    assert there["units"] == "in"
    assert list(there).index("units") == list(there).index("method") + 1
    assert there["holes"][0]["diameter"] == pytest.approx(record["holes"][0]["diameter"] / 25.4)
    assert there["holes"][0]["normal"] == record["holes"][0]["normal"]
    back = units.convert_record(there, "in", "mm")
    _compare(back, record)
    with pytest.raises(ValueError, match="the record is in 'in', not 'm'"):
        units.convert_record(there, "m", "mm")


def test_angles_counts_and_directions_never_convert():
    record = {
        "file": "x.ply", "points": 100, "dropped_points": 2, "method": "robust",
        "plane": {"point": [1.0, 2.0, 3.0], "normal": [0.0, 0.0, 1.0], "rms": 0.5, "inliers": 90},
        "holes": [{
            "index": 0, "center": [1.0, 1.0, 0.0], "diameter": 3.0, "normal": [0.0, 0.0, 1.0], "rim_points": 60,
            "fit_rms": 0.01, "max_residual": 0.02, "roundness": 0.03, "bias_correction": 0.04, "partial": False,
            "arc_deg": 360.0, "scan_lines": 7, "type": "countersunk",
            "countersink": {"diameter": 7.0, "angle_deg": 100.0, "depth": 1.26, "depth_from": "bore",
                            "diameter_at_depth": 6.0, "gauge_depth": 0.5, "rms": 0.001, "points": 600, "arc_deg": 350.0},
            "counterbore": None,
            "bore": {"diameter": 4.0, "rms": 0.002, "points": 40, "depth_range": [0.1, 2.0], "arc_deg": 180.0,
                     "floor_depth": None, "floor_rms": None},
            "axis": [0.0, 0.0, 1.0], "perpendicularity_deg": 0.1, "warnings": [],
            "name": "C1", "diameter_deviation": 0.01, "position_deviation": {"in_plane": 0.02, "along_normal": -0.03},
            "tilt_deg": 0.2, "countersink_diameter_deviation": 0.04, "countersink_angle_deviation": 0.5,
            "countersink_depth_deviation": -0.05, "bore_diameter_deviation": 0.06, "in_tolerance": True,
            "failed_checks": [],
        }],
        "verdict": {"checked": 1, "out_of_tolerance": 0, "missing": [], "in_tolerance": True},
        "options": {"method": "robust", "view_dir": None, "min_diameter": 1.0, "min_diameter_effective": 1.0,
                    "max_holes": None, "full_only": False, "gauge_depth": 0.5, "rng": 0, "settings": {},
                    "tolerances": None},
        "scales": {"point_spacing": 0.1, "gap_scale": 0.08, "line_pitch": None, "period": 0.1, "lattice": True,
                   "height_noise": 0.002, "min_diameter": 1.0, "triangle_area_bound": 0.5},
        "candidates": 3,
        "timing": {"elapsed_ms": 12.5},
        "rejected": [
            {"check": "not_round", "reason": "r", "center": [0.0, 1.0, 2.0], "diameter": 5.0, "value": 0.5,
             "limit": 0.2, "shape": {"length": 6.0, "width": 2.0, "direction": [1.0, 0.0, 0.0]}},
            {"check": "partial_rim_arc", "reason": "r", "center": [0.0, 1.0, 2.0], "diameter": 5.0, "value": 90.0,
             "limit": 120.0, "shape": None},
            {"check": "too_few_rim_points", "reason": "r", "center": [0.0, 1.0, 2.0], "diameter": 5.0, "value": 4,
             "limit": 6, "shape": None},
        ],
    }
    out = units.convert_record(record, "mm", "m")
    hole = out["holes"][0]
    assert out["plane"]["point"] == [0.001, 0.002, 0.003] and out["plane"]["rms"] == 0.0005
    assert out["plane"]["normal"] == [0.0, 0.0, 1.0] and out["plane"]["inliers"] == 90
    assert hole["center"] == [0.001, 0.001, 0.0] and hole["diameter"] == 0.003
    assert hole["countersink"]["angle_deg"] == 100.0 and hole["countersink"]["gauge_depth"] == 0.0005
    assert hole["countersink"]["points"] == 600 and hole["bore"]["depth_range"] == [0.0001, 0.002]
    assert hole["position_deviation"] == {"in_plane": 0.00002, "along_normal": -0.00003}
    assert hole["countersink_angle_deviation"] == 0.5 and hole["tilt_deg"] == 0.2
    assert hole["perpendicularity_deg"] == 0.1 and hole["arc_deg"] == 360.0 and hole["scan_lines"] == 7
    assert hole["bore_diameter_deviation"] == pytest.approx(0.00006)
    assert out["timing"] == {"elapsed_ms": 12.5} and out["points"] == 100 and out["verdict"] == record["verdict"]
    assert out["options"]["min_diameter"] == 0.001 and out["options"]["gauge_depth"] == 0.0005
    assert out["options"]["min_diameter_effective"] == 0.001 and out["options"]["rng"] == 0
    assert out["scales"]["point_spacing"] == 0.0001 and out["scales"]["line_pitch"] is None
    assert out["scales"]["lattice"] is True and out["candidates"] == 3
    assert out["scales"]["triangle_area_bound"] == pytest.approx(0.5e-6)
    not_round, arc, few = out["rejected"]
    assert not_round["value"] == 0.0005 and not_round["shape"]["length"] == 0.006
    assert not_round["shape"]["direction"] == [1.0, 0.0, 0.0]
    assert (arc["value"], arc["limit"], few["value"], few["limit"]) == (90.0, 120.0, 4, 6)
    assert arc["diameter"] == 0.005
    assert record["holes"][0]["diameter"] == 3.0  # pure


def test_convert_record_converts_the_conformance_of_length_checks_only():
    from holecli.tolerance import check, nominal_spec

    uncertainty = {"center_in_plane": 0.01, "diameter": 0.002, "normal_deg": 0.1,
                   "countersink": {"diameter": None, "angle_deg": 0.2, "depth": None, "diameter_at_depth": None},
                   "perpendicularity_deg": 0.05}
    hole = {"index": 0, "center": [0.03, 0.0, 0.0], "diameter": 3.01, "normal": [0.0, 0.0, 1.0],
            "countersink": {"angle_deg": 100.4}, "perpendicularity_deg": 0.3, "uncertainty": uncertainty}
    record = {"file": "a.ply", "method": "robust", "holes": [hole]}
    spec = nominal_spec(diameter=3.0, tolerance="+0.036/-0", center=(0.0, 0.0, 0.0), position_tolerance=0.1,
                        normal=(0.0, 0.0, 1.0), max_tilt=1.0, countersink_angle=100.0, countersink_angle_tolerance=1.0,
                        max_perpendicularity=0.5)
    checked = check(record, spec)
    out = units.convert_record(checked, "mm", "m")["holes"][0]["conformance"]
    before = checked["holes"][0]["conformance"]
    for name in ("diameter", "position"):  # lengths: by 1/1000
        for key in ("value", "upper", "expanded_uncertainty"):
            assert out[name][key] == pytest.approx(before[name][key] / 1000, rel=1e-12), (name, key)
    assert out["diameter"]["lower"] == 0.0 and out["position"]["lower"] is None
    for name in ("tilt", "countersink_angle", "perpendicularity"):  # degrees: as they were
        assert out[name] == before[name], name
    assert out["countersink_angle"]["expanded_uncertainty"] == pytest.approx(0.4)
    assert {entry["decision"] for entry in out.values()} == {"pass"}


def test_scale_factor_and_unknown_units():
    assert units.scale_factor("in", "m") == pytest.approx(0.0254)
    with pytest.raises(ValueError, match="unknown unit 'ft'"):
        units.scale_factor("ft", "mm")


def test_unit_choice():
    choice = units.UnitChoice("m", "mm")
    assert choice.to_file_units(2.0) == 0.002 and choice.to_file_units(None) is None
    assert units.UnitChoice("m").to_file_units(2.0) == 2.0
    record = {"file": "a", "method": "robust", "plane": {"point": [1.0, 0.0, 0.0], "rms": 0.0}, "holes": []}
    assert units.UnitChoice().express(record) is record
    assert units.UnitChoice().express(record, declared="m")["units"] == "m"
    assert units.UnitChoice("mm").express(record, declared="m")["units"] == "mm"  # --units wins
    assert units.UnitChoice(None, "mm").express(record, declared="m")["plane"]["point"] == [1000.0, 0.0, 0.0]
    with pytest.raises(ValueError, match="give --units"):
        units.UnitChoice(None, "mm").express(record)


# --- the command line ------------------------------------------------------------------------------


def test_cli_tolerances_and_length_options_are_in_the_output_unit(run, tmp_path):
    points = load_points(SAMPLES / "table1.ply") / 1000.0
    scan = tmp_path / "table1_m.ply"
    save_points(scan, points)
    result = run("detect", scan, "--units", "m", "--output-units", "mm", "--nominal-diameter", "3",
                 "--tolerance", "0.01", "--min-diameter", "2")
    assert result.exit_code == 0, result.output
    record = json.loads(result.stdout)
    hole = record["holes"][0]
    assert record["units"] == "mm" and hole["diameter"] == pytest.approx(3.0, abs=0.01)
    assert hole["in_tolerance"] is True and abs(hole["diameter_deviation"]) < 0.01
    # --min-diameter 4 (mm) leaves the 3 mm hole out: it is converted into the file's metres
    result = run("detect", scan, "--units", "m", "--output-units", "mm", "--min-diameter", "4")
    assert result.exit_code == 4 and json.loads(result.stdout)["holes"] == []
    # without --output-units the record is in the file's unit and says so
    record = json.loads(run("detect", scan, "--units", "m").stdout)
    assert record["units"] == "m" and record["holes"][0]["diameter"] == pytest.approx(0.003, abs=1e-5)
    # without either, as before: no "units"
    assert "units" not in json.loads(run("detect", scan).stdout)


def test_cli_output_units_need_the_file_unit(run, table1_files):
    result = run("detect", table1_files[".ply"], "--output-units", "mm")
    assert result.exit_code == 2
    assert "--output-units needs --units" in result.stderr


def test_cli_table_shows_the_unit_and_its_digits(run, tmp_path):
    scan = tmp_path / "table1_m.ply"
    save_points(scan, load_points(SAMPLES / "table1.ply") / 1000.0)
    def table(*options):
        return " ".join(run("detect", scan, *options, "--format", "table").stdout.split())  # the title may wrap

    text = table("--units", "m")
    assert "lengths in m" in text and "0.0029969" in text  # 7 decimals: a tenth of a micrometre
    text = table("--units", "m", "--output-units", "mm")
    assert "lengths in mm" in text and "2.9969 " in text
    text = table("--units", "m", "--output-units", "in")
    assert "lengths in in" in text and f"{2.99689 / 25.4:.5f}" in text


def test_cli_batch_units(run, tmp_path):
    save_points(tmp_path / "a.ply", load_points(SAMPLES / "table1.ply") / 1000.0)
    result = run("batch", tmp_path, "--units", "m", "--output-units", "mm", "-j", "1")
    assert result.exit_code == 0, result.output
    record = json.loads(result.stdout)
    assert record["units"] == "mm" and record["holes"][0]["diameter"] == pytest.approx(3.0, abs=0.01)
    result = run("batch", tmp_path, "--output-units", "mm", "-j", "1")
    assert result.exit_code == 2 and "--output-units needs --units" in result.stderr
    assert result.stdout == ""



def test_an_unknown_unit_is_a_usage_error(run, table1_files):
    result = run("detect", table1_files[".ply"], "--units", "ft")
    assert result.exit_code == 2 and "'ft' is not one of 'mm', 'm', 'in'" in result.stderr


def test_cli_csv_rows_say_their_unit(run, table1_files):
    import csv
    import io

    result = run("detect", table1_files[".ply"], "--units", "mm", "--output-units", "m", "--format", "csv")
    (row,) = csv.DictReader(io.StringIO(result.stdout))
    assert row["units"] == "m" and abs(float(row["diameter"]) - 0.003) < 2e-5
    assert abs(float(row["point_spacing"]) - 0.0908e-3) < 1e-9
    (plain,) = csv.DictReader(io.StringIO(run("detect", table1_files[".ply"], "--format", "csv").stdout))
    assert plain["units"] == ""
