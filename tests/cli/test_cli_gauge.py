"""The countersink gauge as a checked characteristic (issue 25, item 8): --countersink-gauge-diameter and
--countersink-gauge-tolerance, the spec keys of those names, with --gauge-depth; table, JSON, batch."""

import json
import math

import pytest

from holecli import cli
from tests.conftest import REPO_ROOT

PANEL = REPO_ROOT / "sample_clouds" / "panel.ply"
# C1 of sample_clouds/panel.toml: a 100 degree countersink of 7 mm at the surface; 0.5 below it the
# cone's diameter is 7 - 2 * 0.5 * tan(50 degrees).
GAUGE_DEPTH = 0.5
AT_DEPTH = 7.0 - 2 * GAUGE_DEPTH * math.tan(math.radians(50.0))


def _spec(tmp_path, nominal, tolerance):
    path = tmp_path / "gauge.toml"
    path.write_text(f'[[hole]]\nname = "C1"\ncenter = [-6.0, 8.0, 0.0]\ndiameter = 7.0\ntolerance = 0.05\n'
                    f'countersink_gauge_diameter = {nominal}\ncountersink_gauge_tolerance = "{tolerance}"\n')
    return path


def _c1(record):
    [hole] = [hole for hole in record["holes"] if hole.get("name") == "C1"]
    return hole


@pytest.mark.parametrize("nominal, expected_exit, decision", [
    (round(AT_DEPTH, 3), cli.EXIT_OK, "pass"),  # the drawn gauge reading
    (round(AT_DEPTH, 3) + 0.05, cli.EXIT_OUT_OF_TOLERANCE, "fail"),  # the countersink 0.05 too small
])
def test_spec_gauge_check_in_the_record_and_the_schema(run, tmp_path, nominal, expected_exit, decision):
    jsonschema = pytest.importorskip("jsonschema")
    from holecli.schema import record_schema

    result = run("detect", PANEL, "--gauge-depth", GAUGE_DEPTH, "--spec", _spec(tmp_path, nominal, "+/-0.01"))
    assert result.exit_code == expected_exit, result.stderr
    record = json.loads(result.stdout)
    hole = _c1(record)
    assert hole["countersink"]["diameter_at_depth"] == pytest.approx(AT_DEPTH, abs=0.005)
    entry = hole["conformance"]["countersink_gauge"]
    assert entry["decision"] == decision and (entry["lower"], entry["upper"]) == (-0.01, 0.01)
    assert hole["countersink_gauge_deviation"] == pytest.approx(hole["countersink"]["diameter_at_depth"] - nominal)
    assert entry["expanded_uncertainty"] is not None and entry["expanded_uncertainty"] < 0.01
    assert record["options"]["gauge_depth"] == GAUGE_DEPTH
    jsonschema.Draft202012Validator(record_schema("detect_record")).validate(record)


def test_the_table_shows_the_gauge_reading_and_its_decision(run, tmp_path):
    result = run("detect", PANEL, "--gauge-depth", GAUGE_DEPTH, "--spec", _spec(tmp_path, 5.75, "+/-0.01"),
                 "--format", "table")
    assert result.exit_code == cli.EXIT_OUT_OF_TOLERANCE
    assert "countersink gauge (diameter at the gauge depth)" in result.stdout
    [row] = [line for line in result.stdout.splitlines() if "│ C1 " in line]
    cells = [cell.strip() for cell in row.strip("│").split("│")]
    assert cells[1:3] == ["C1", "0.5000"] and float(cells[3]) == pytest.approx(AT_DEPTH, abs=0.001)
    assert cells[4] == "5.7500" and cells[-1] == "fail"
    assert "countersink_gauge" in result.stdout.split("countersink gauge (diameter")[0]  # the tolerance cell


def test_the_options_check_the_gauge_reading(run):
    result = run("detect", PANEL, "--gauge-depth", GAUGE_DEPTH, "--nominal-center", "-6,8,0",
                 "--countersink-gauge-diameter", f"{AT_DEPTH:.3f}", "--countersink-gauge-tolerance", "0.01")
    assert result.exit_code == cli.EXIT_OK, result.stderr
    record = json.loads(result.stdout)
    [hole] = [hole for hole in record["holes"] if hole["in_tolerance"] is not None]
    assert list(hole["conformance"]) == ["countersink_gauge"]
    assert record["options"]["tolerances"]["nominal"]["countersink_gauge_band"] == {"lower": -0.01, "upper": 0.01}


@pytest.mark.parametrize("command", ["detect", "batch"])
def test_a_gauge_check_without_a_gauge_depth_is_refused(run, tmp_path, command):
    result = run(command, PANEL, "--spec", _spec(tmp_path, 5.8, "0.01"), "-o", tmp_path / "out.json")
    assert result.exit_code == cli.EXIT_USAGE
    assert result.stderr == (f"Error: {tmp_path / 'gauge.toml'}: hole 'C1' has countersink_gauge_diameter: give "
                             f"--gauge-depth (the depth below the surface at which the gauge reads the countersink's "
                             f"diameter)\n")
    assert not (tmp_path / "out.json").exists()
    result = run(command, PANEL, "--countersink-gauge-diameter", "5.8", "--countersink-gauge-tolerance", "0.01")
    assert result.exit_code == cli.EXIT_USAGE
    assert "Error: --countersink-gauge-diameter needs --gauge-depth" in result.stderr
    result = run(command, PANEL, "--countersink-gauge-diameter", "5.8", "--gauge-depth", "0.5")
    assert result.exit_code == cli.EXIT_USAGE
    assert "--countersink-gauge-diameter needs --countersink-gauge-tolerance" in result.stderr


def test_batch_checks_the_gauge_reading(run, tmp_path):
    result = run("batch", PANEL, "--gauge-depth", GAUGE_DEPTH, "--spec", _spec(tmp_path, 5.75, "0.01"))
    assert result.exit_code == cli.EXIT_OUT_OF_TOLERANCE
    hole = _c1(json.loads(result.stdout))
    assert hole["failed_checks"] == ["countersink_gauge"]


def test_the_csv_has_the_gauge_deviation(run, tmp_path):
    import csv
    import io

    result = run("detect", PANEL, "--gauge-depth", GAUGE_DEPTH, "--spec", _spec(tmp_path, 5.75, "0.01"),
                 "--format", "csv", "--fields", "hole,name,countersink_diameter_at_depth,countersink_gauge_deviation")
    rows = {row["name"]: row for row in csv.DictReader(io.StringIO(result.stdout))}
    deviation = float(rows["C1"]["countersink_gauge_deviation"])
    assert deviation == pytest.approx(float(rows["C1"]["countersink_diameter_at_depth"]) - 5.75)
    assert rows[""]["countersink_gauge_deviation"] == ""  # the holes the one-hole spec does not name
