"""Issue 25, output for people and spreadsheets: the table fitted to the terminal with U, the CSV's u_*
columns and --fields, on the sample panel checked against its tolerances."""

import csv
import io
import json
import os

import pytest

from holecli import cli
from holecli.cli.render import conformance_text

SAMPLES = os.path.join(os.path.dirname(__file__), "..", "..", "sample_clouds")
PANEL = os.path.join(SAMPLES, "panel.ply")
TABLE1 = os.path.join(SAMPLES, "table1.ply")
# a spec the sample panel fails (the sample spec before issue 25): failed and undecided checks to show
FAILING = os.path.join(os.path.dirname(__file__), "..", "data", "panel_tolerances_failing.toml")
CHECKED = ["--spec", FAILING, "--decision-rule", "guarded"]


@pytest.fixture(scope="module")
def panel_record():
    from click.testing import CliRunner

    result = CliRunner().invoke(cli.main, ["detect", PANEL, *CHECKED])
    assert result.exit_code == cli.EXIT_OUT_OF_TOLERANCE, result.stderr
    return json.loads(result.stdout)


def _table(run, monkeypatch, width, *args):
    monkeypatch.setenv("COLUMNS", str(width))
    result = run("detect", *args, "--format", "table")
    return result, result.stdout.splitlines()


@pytest.mark.parametrize("width", [80, 140])
def test_the_table_fits_the_terminal_and_never_breaks_a_verdict_word(run, monkeypatch, panel_record, width):
    result, lines = _table(run, monkeypatch, width, PANEL, *CHECKED)
    assert result.exit_code == cli.EXIT_OUT_OF_TOLERANCE
    assert max(len(line) for line in lines) <= width
    words = set(result.stdout.replace("│", " ").split())
    for hole in panel_record["holes"]:
        assert f"{hole['name']}:" in words
        for check, entry in hole["conformance"].items():
            # every word of the check's line whole, whatever wraps between them
            assert set(conformance_text(check, entry).split()) <= words, check
    assert {"OUT:", "UNDECIDED:", "in", "countersink_diameter", "bore_diameter"} <= words


def test_narrow_terminal_gets_a_block_per_hole_and_wide_one_row_per_hole(run, monkeypatch):
    _, narrow = _table(run, monkeypatch, 80, PANEL, *CHECKED)
    assert any(line.strip().startswith("hole 1 (C1)") for line in narrow)
    assert sum(line.startswith("│ check ") for line in narrow) >= 10
    _, wide = _table(run, monkeypatch, 140, PANEL, *CHECKED)
    header = next(line for line in wide if "center x" in line)
    assert "U ctr" in header and "U dia" in header and "tolerance" in header
    assert not any(line.strip().startswith("hole 1 (C1)") for line in wide)


def test_the_table_gives_u_beside_center_diameter_and_countersink(run, monkeypatch, panel_record):
    _, lines = _table(run, monkeypatch, 140, PANEL, *CHECKED)
    hole = panel_record["holes"][1]  # C1, countersunk
    u = hole["uncertainty"]
    row = next(line for line in lines if line.startswith("│    1 │"))
    cells = [cell.strip() for cell in row.split("│")]
    assert cells[5] == f"{2 * u['center_in_plane']:.2g}" and cells[7] == f"{2 * u['diameter']:.2g}"
    assert "U = 2u" in "\n".join(lines)
    below = "\n".join(lines[next(i for i, line in enumerate(lines) if "below the edge" in line):])
    assert f"U {2 * u['countersink']['diameter']:.2g}" in below.replace("│", " ")
    _, narrow = _table(run, monkeypatch, 80, PANEL, *CHECKED)
    text = "\n".join(narrow)
    assert f"{hole['diameter']:.4f}  U {2 * u['diameter']:.2g}" in text
    assert f"{hole['countersink']['diameter']:.4f}  U {2 * u['countersink']['diameter']:.2g}" in text


def test_register_table_fits_the_terminal(run, monkeypatch, tmp_path):
    from tests.cli.test_cli_register import _scan, _spec_text
    from holecli.io import save_points

    for name in ("A1", "A2", "A3"):
        save_points(tmp_path / f"{name}.ply", _scan(name))
    (tmp_path / "part.toml").write_text(_spec_text(["A1", "A2", "A3"]))
    for width in (80, 140):
        monkeypatch.setenv("COLUMNS", str(width))
        result = run("register", *(tmp_path / f"{n}.ply" for n in ("A1", "A2", "A3")), "--spec",
                     tmp_path / "part.toml", "--format", "table")
        assert result.exit_code == cli.EXIT_OK, result.stderr
        lines = result.stdout.splitlines()
        assert max(len(line) for line in lines) <= width
        assert "quaternion w,x,y,z" in result.stdout and "residuals after the fit" in result.stdout


# --- the CSV ----------------------------------------------------------------------------------------


def test_the_csv_has_the_standard_uncertainties(run):
    record = json.loads(run("detect", TABLE1).stdout)
    (row,) = csv.DictReader(io.StringIO(run("detect", TABLE1, "--format", "csv").stdout))
    u = record["holes"][0]["uncertainty"]
    assert float(row["u_diameter"]) == u["diameter"] and float(row["u_center_in_plane"]) == u["center_in_plane"]
    assert float(row["u_center_along_normal"]) == u["center_along_normal"]
    assert float(row["u_normal_deg"]) == u["normal_deg"] and row["uncertainty_estimator"] == u["estimator"]
    assert row["u_countersink_diameter"] == "" and row["u_bore_diameter"] == ""


def test_fields_chooses_the_csv_columns_in_their_order(run):
    result = run("detect", TABLE1, "--format", "csv", "--fields", "diameter, u_diameter,file,hole")
    assert result.exit_code == cli.EXIT_OK, result.stderr
    lines = result.stdout.splitlines()
    assert lines[0] == "diameter,u_diameter,file,hole" and len(lines) == 2
    assert lines[1].split(",")[2:] == [TABLE1, "0"]


def test_an_unknown_field_is_one_error_line_listing_the_valid_ones(run):
    result = run("detect", TABLE1, "--format", "csv", "--fields", "file,diameter_u")
    assert result.exit_code == cli.EXIT_USAGE and result.stdout == ""
    (error,) = [line for line in result.stderr.splitlines() if line.startswith("Error")]
    assert "unknown field 'diameter_u'" in error and "valid fields: file,hole,center_x," in error
    assert "u_diameter" in error


def test_fields_needs_csv(run):
    result = run("detect", TABLE1, "--fields", "file")
    assert result.exit_code == cli.EXIT_USAGE and "--fields chooses the columns of --format csv" in result.stderr


def test_batch_fields_writes_those_columns_and_refuses_resume(run, tmp_path):
    out = tmp_path / "shift.csv"
    result = run("batch", TABLE1, os.path.join(SAMPLES, "no_hole.csv"), "--format", "csv", "-q",
                 "--fields", "file,hole,diameter,u_diameter,error", "-o", out)
    assert result.exit_code == cli.EXIT_NO_HOLE, result.stderr
    rows = list(csv.reader(io.StringIO(out.read_text())))
    assert rows[0] == ["file", "hole", "diameter", "u_diameter", "error"]
    assert all(len(row) == 5 for row in rows) and len(rows) == 3
    result = run("batch", TABLE1, "--format", "csv", "--fields", "file", "-o", out, "--resume")
    assert result.exit_code == cli.EXIT_USAGE and "--resume needs the whole CSV" in result.stderr
    assert run("batch", TABLE1, "--fields", "path", "-o", tmp_path / "x.jsonl").exit_code == cli.EXIT_USAGE


def test_batch_resume_names_a_csv_written_before_the_u_columns(run, tmp_path):
    from holecli.report import BATCH_CSV_COLUMNS

    output = tmp_path / "out.csv"
    assert run("batch", TABLE1, "--format", "csv", "-o", output, "-q").exit_code == cli.EXIT_OK
    rows = list(csv.reader(io.StringIO(output.read_text())))
    first_u = BATCH_CSV_COLUMNS.index("u_center_in_plane")
    output.write_text("".join(",".join(row[:first_u] + row[-2:]) + "\n" for row in rows))
    resumed = run("batch", TABLE1, "--format", "csv", "-o", output, "--resume")
    assert resumed.exit_code == cli.EXIT_INPUT
    assert "written before the u_* columns of the uncertainties" in resumed.stderr
