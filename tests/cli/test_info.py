"""holecli info: what a scan holds, before measuring it."""

import json
from pathlib import Path

import numpy as np
import pytest

from holecli.io import load_points, save_points
from holecli.io.info import describe_cloud, guess_unit, point_spacing

SAMPLES = Path(__file__).resolve().parents[2] / "sample_clouds"


def test_info_of_a_ply_scan(run):
    result = run("info", SAMPLES / "table1.ply")
    assert result.exit_code == 0, result.output
    info = json.loads(result.stdout)
    points = load_points(SAMPLES / "table1.ply")
    assert info["file"].endswith("table1.ply") and info["format"] == "ply"
    assert info["points"] == {"total": 7062, "finite": 7062, "dropped": 0}
    assert info["extent"]["min"] == points.min(axis=0).tolist() and info["extent"]["max"] == points.max(axis=0).tolist()
    assert info["dimensions"] == pytest.approx((points.max(axis=0) - points.min(axis=0)).tolist())
    assert info["columns"] is None and info["fields"] == ["x", "y", "z"]
    assert info["point_spacing"] == pytest.approx(0.0908, abs=1e-4)  # the Table I grid
    assert info["units"]["declared"] is None and info["units"]["guess"] == "mm"
    assert info["units"]["guess_reason"].startswith("a guess: point spacing 0.0908 and largest dimension 9.83")


def test_info_of_a_csv_with_a_header(run, tmp_path):
    points = load_points(SAMPLES / "table1.ply")
    rows = "".join(f"{i},{x!r},{y!r},{z!r},9\n" for i, (x, y, z) in enumerate(points.tolist()))
    path = tmp_path / "scan.csv"
    path.write_text("point,x_mm,y_mm,z_mm,intensity\n" + rows + "7062,nan,1,2,9\n")
    info = json.loads(run("info", path).stdout)
    assert info["points"] == {"total": 7063, "finite": 7062, "dropped": 1}
    assert info["columns"]["names"] == ["x_mm", "y_mm", "z_mm"] and info["columns"]["indices"] == [1, 2, 3]
    assert info["fields"] == ["point", "x_mm", "y_mm", "z_mm", "intensity"]
    assert info["units"]["declared"] == "mm" and info["units"]["declared_by"] == "header"
    table = run("info", path, "--format", "table").stdout
    assert "columns     x_mm,y_mm,z_mm (1,2,3 of 5, 0-based; unit mm from the header)\n" in table
    assert "points      7063 (7062 finite, 1 dropped" in table and "unit        mm (from header)\n" in table


def test_info_of_a_scan_in_metres_guesses_metres_and_says_units_given(run, tmp_path):
    save_points(tmp_path / "m.xyz", load_points(SAMPLES / "table1.ply") / 1000.0)
    info = json.loads(run("info", tmp_path / "m.xyz").stdout)
    assert info["units"]["guess"] == "m" and info["units"]["declared"] is None
    given = json.loads(run("info", tmp_path / "m.xyz", "--units", "mm").stdout)["units"]
    assert (given["declared"], given["declared_by"], given["guess"]) == ("mm", "--units", "m")
    assert given["guess_reason"].endswith("; the declared unit is mm: is it the file's?")


def test_info_takes_columns_and_input_format(run, tmp_path):
    path = tmp_path / "scan.asc"
    path.write_text("0 9 1 2 3\n1 9 4 5 6\n2 9 7 8 10\n")
    assert run("info", path).exit_code == 3  # unsupported extension
    refused = run("info", path, "--input-format", "xyz")
    assert refused.exit_code == 3 and "ambiguous columns" in refused.stderr and refused.stderr.count("\n") == 1
    info = json.loads(run("info", path, "--input-format", "xyz", "--columns", "2,3,4").stdout)
    assert info["extent"] == {"min": [1, 2, 3], "max": [7, 8, 10]} and info["format"] == "xyz"
    assert info["columns"]["given"] is True


@pytest.mark.parametrize("content, message", [
    (None, "file not found"),
    ("x,y,z\n1,2,abc\n", "non-numeric value 'abc' in row 2"),
    ("", "empty file"),
])
def test_a_bad_file_is_the_one_line_error_of_detect(run, tmp_path, content, message):
    path = tmp_path / "bad.csv"
    if content is not None:
        path.write_text(content)
    result = run("info", path)
    assert result.exit_code == 3 and result.stdout == ""
    assert result.stderr == f"Error: {path}: {message}\n"
    assert run("detect", path).stderr == result.stderr


def test_spacing_and_the_unit_guess_rules():
    grid = np.array([[x, y, 0.0] for x in range(30) for y in range(30)]) * 0.05
    assert point_spacing(grid) == pytest.approx(0.05)
    assert point_spacing(grid[:1]) is None and point_spacing(np.zeros((5, 3))) is None
    assert guess_unit(0.05, 30.0)[0] == "mm" and guess_unit(5e-5, 0.03)[0] == "m"
    assert guess_unit(0.003, 2.0) == (None, "no guess: point spacing 0.003 and largest dimension 2 fit a scan in "
                                            "millimetres and one in metres alike")
    assert guess_unit(50.0, 1e5)[0] is None and guess_unit(None, 1.0)[0] is None


def test_describe_cloud_is_pure_over_the_cloud():
    from holecli.io import Cloud

    cloud = Cloud(np.array([[0.0, 0.0, 0.0], [1.0, 2.0, 3.0]]), 3, "p.e57", "m")
    info = describe_cloud(cloud)
    assert info["points"] == {"total": 5, "finite": 2, "dropped": 3} and info["dimensions"] == [1.0, 2.0, 3.0]
    assert info["units"]["declared"] == "m" and info["units"]["declared_by"] == "format" and info["format"] == "e57"


def test_the_docs_info_example_prints_what_the_docs_show(run, repo_root, monkeypatch):
    import re

    page = (repo_root / "docs" / "guide" / "info.md").read_text(encoding="utf-8")
    match = re.search(r"```sh\nholecli info (\S+) --format table\n```\n\n```text\n(.*?)```", page, re.DOTALL)
    assert match, "the docs' holecli info example (docs/guide/info.md) is gone"
    monkeypatch.chdir(repo_root)
    assert run("info", match.group(1), "--format", "table").stdout == match.group(2)
