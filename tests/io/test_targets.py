"""Tests of holecli.io.targets: the strict targets CSV and the corrected targets' text."""

import csv
import io

import numpy as np
import pytest

from holecli.errors import LoadError
from holecli.io.targets import TARGET_COLUMNS, format_targets, parse_targets, read_targets

GOOD = "name,x,y,z,nx,ny,nz\nT1,1,2,3,0,0,2\n\nT2,-1.5,0,1e-3,0,1,1\n"


def test_reads_the_targets(tmp_path):
    path = tmp_path / "targets.csv"
    path.write_text(GOOD)
    targets = read_targets(path)
    assert targets.names == ("T1", "T2")
    assert np.allclose(targets.points, [[1, 2, 3], [-1.5, 0, 1e-3]])
    assert np.allclose(targets.normals, [[0, 0, 1], [0, 2 ** -0.5, 2 ** -0.5]])


@pytest.mark.parametrize("text, match", [
    ("", "empty"),
    ("name,x,y,z\nT1,1,2,3\n", "line 1: expected the header"),
    ("name,x,y,z,nx,ny,nz\n", "no target"),
    ("name,x,y,z,nx,ny,nz\nT1,1,2,3,0,0,1\nT2,1,2\n", "line 3: expected 7 fields"),
    ("name,x,y,z,nx,ny,nz\nT1,1,nan,3,0,0,1\n", "line 2: y 'nan'"),
    ("name,x,y,z,nx,ny,nz\nT1,1,2,3,0,0,0\n", "line 2: the normal of 'T1' is zero"),
    ("name,x,y,z,nx,ny,nz\nT1,1,2,3,0,0,1\nT1,1,2,3,0,0,1\n", "line 3: the name 'T1' is used twice"),
    ("name,x,y,z,nx,ny,nz\n,1,2,3,0,0,1\n", "line 2: empty name"),
])
def test_bad_files_name_the_line(text, match):
    with pytest.raises(LoadError, match=match):
        parse_targets(text, source="t.csv")


def test_missing_file(tmp_path):
    with pytest.raises(LoadError, match="cannot read"):
        read_targets(tmp_path / "nope.csv")


def test_format_round_trips_full_precision():
    row = {"name": "T1", "x": 0.1 + 0.2, "y": 1.0, "z": -2.0, "nx": 0.0, "ny": 0.0, "nz": 1.0,
           "u_x": 1e-4, "u_y": float("inf"), "u_z": float("nan"), "u_normal_deg": 0.01}
    rows = list(csv.DictReader(io.StringIO(format_targets([row]))))
    assert tuple(rows[0]) == TARGET_COLUMNS
    assert float(rows[0]["x"]) == 0.1 + 0.2
    assert rows[0]["u_y"] == "inf" and rows[0]["u_z"] == "nan"


@pytest.mark.parametrize("line, units", [("# units = in", "in"), ('# units = "mm"', "mm"), ("#units=m", "m"),
                                         ("\n# units = 'in'", "in")])
def test_a_targets_file_may_declare_its_unit(line, units):
    targets = parse_targets(f"{line}\nname,x,y,z,nx,ny,nz\nT1,1,2,3,0,0,1\n")
    assert targets.units == units and targets.points.tolist() == [[1.0, 2.0, 3.0]]
    assert parse_targets("name,x,y,z,nx,ny,nz\nT1,1,2,3,0,0,1\n").units is None


def test_a_targets_file_refuses_an_unknown_unit_with_its_line():
    with pytest.raises(LoadError, match=r"t.csv: line 1: units must be one of mm, m, in, got 'cm'"):
        parse_targets("# units = cm\nname,x,y,z,nx,ny,nz\nT1,1,2,3,0,0,1\n", "t.csv")
    # the units line comes first, or it is no units line: the header is expected
    with pytest.raises(LoadError, match=r"line 2: expected 7 fields"):
        parse_targets("name,x,y,z,nx,ny,nz\n# units = mm\nT1,1,2,3,0,0,1\n", "t.csv")
