"""The command line on text tables: the columns read by their header names, --columns, refusals, -v."""

import json
import sys
from pathlib import Path

import jsonschema
import pytest

from holecli.io import load_points
from holecli.schema import record_schema

SAMPLES = Path(__file__).resolve().parents[2] / "sample_clouds"


@pytest.fixture(scope="module")
def table1_points():
    return load_points(SAMPLES / "table1.ply").tolist()


@pytest.fixture
def named_csv(tmp_path, table1_points):
    """The Table I scan as the issue's CSV: a point number, x, y, z in mm, an intensity."""
    rows = "".join(f"{i},{x!r},{y!r},{z!r},{100 + i % 7}\n" for i, (x, y, z) in enumerate(table1_points))
    path = tmp_path / "table1.csv"
    path.write_text("point,x_mm,y_mm,z_mm,intensity\n" + rows)
    return path


@pytest.fixture
def numbered_xyz(tmp_path, table1_points):
    """The Table I scan without a header, a point number first."""
    path = tmp_path / "table1.xyz"
    path.write_text("".join(f"{i} {x!r} {y!r} {z!r}\n" for i, (x, y, z) in enumerate(table1_points)))
    return path


def test_the_csv_with_x_mm_y_mm_z_mm_after_a_point_number_finds_the_hole(run, named_csv):
    result = run("detect", named_csv)
    assert result.exit_code == 0, result.output
    record = json.loads(result.stdout)
    assert len(record["holes"]) == 1 and record["holes"][0]["diameter"] == pytest.approx(3.0, abs=0.01)
    assert record["units"] == "mm"  # the header's unit
    assert record["input_columns"] == {"indices": [1, 2, 3], "names": ["x_mm", "y_mm", "z_mm"],
                                       "header": ["point", "x_mm", "y_mm", "z_mm", "intensity"], "width": 5,
                                       "unit": "mm", "given": False}
    assert record["options"]["columns"] is None
    jsonschema.Draft202012Validator(record_schema("detect_record")).validate(record)


def test_verbose_says_which_columns_were_read(run, named_csv):
    result = run("detect", named_csv, "-v")
    assert ("holecli:   columns read as x, y, z: x_mm,y_mm,z_mm (1,2,3 of 5, 0-based; unit mm from the header)\n"
            in result.stderr)


def test_a_point_number_first_is_refused_in_one_line_then_read_with_columns(run, numbered_xyz):
    result = run("detect", numbered_xyz)
    assert result.exit_code == 3 and result.stdout == ""
    assert result.stderr.startswith(f"Error: {numbered_xyz}: ambiguous columns: no header, 4 columns and the first is "
                                    f"whole numbers going up by 1")
    assert result.stderr.count("\n") == 1 and "--columns 1,2,3" in result.stderr
    result = run("detect", numbered_xyz, "--columns", "1,2,3", "-v")
    assert result.exit_code == 0, result.output
    record = json.loads(result.stdout)
    assert record["holes"][0]["diameter"] == pytest.approx(3.0, abs=0.01) and "units" not in record
    assert record["options"]["columns"] == [1, 2, 3] and record["input_columns"]["given"] is True
    assert "columns read as x, y, z: columns 1,2,3 of 4, 0-based; given by --columns; no header\n" in result.stderr
    jsonschema.Draft202012Validator(record_schema("detect_record")).validate(record)


def test_a_bad_column_name_is_one_error_line_listing_the_columns(run, named_csv):
    result = run("detect", named_csv, "--columns", "x,y,z")
    assert result.exit_code == 3 and result.stdout == ""
    assert result.stderr == (f"Error: {named_csv}: --columns names 'x', which the header does not have (columns "
                             f"0 'point', 1 'x_mm', 2 'y_mm', 3 'z_mm', 4 'intensity')\n")


def test_columns_that_are_not_three_are_a_usage_error(run, named_csv):
    result = run("detect", named_csv, "--columns", "x_mm,y_mm")
    assert result.exit_code == 2 and "Invalid value for '--columns'" in result.stderr


def test_columns_on_a_ply_scan_are_refused(run):
    result = run("detect", SAMPLES / "table1.ply", "--columns", "0,1,2")
    assert result.exit_code == 3
    assert result.stderr.endswith("table1.ply: --columns is for text tables (.csv, .txt, .xyz), not .ply files\n")


def test_batch_and_stdin_take_columns(run, numbered_xyz, tmp_path):
    output = tmp_path / "out.jsonl"
    result = run("batch", numbered_xyz, "--columns", "1,2,3", "-o", output, "-q")
    assert result.exit_code == 0, result.output
    record = json.loads(output.read_text())
    assert record["input_columns"]["indices"] == [1, 2, 3] and len(record["holes"]) == 1
    from click.testing import CliRunner

    from holecli import cli

    piped = CliRunner().invoke(cli.main, ["detect", "-", "--input-format", "xyz", "--columns", "1,2,3"],
                               input=numbered_xyz.read_bytes())
    assert piped.exit_code == 0, piped.output
    assert json.loads(piped.stdout)["input_columns"]["indices"] == [1, 2, 3]


@pytest.mark.parametrize("command", ["detect", "batch", "plot", "register", "info"])
def test_every_command_that_reads_scans_has_columns(run, command):
    assert "--columns" in run(command, "--help").stdout
