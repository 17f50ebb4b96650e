"""Which columns of a text table are x, y, z: the header's names, --columns, and the ambiguous tables refused."""

import io
import re
from pathlib import Path

import numpy as np
import pytest

from holecli.errors import LoadError
from holecli.io import read_cloud, read_stream
from holecli.io.text import axis_of, parse_columns

REALDATA = Path("/work/shared/realdata/formats")

_POINTS = np.array([[1.5, -2.0, 3.25], [4.0, 5.0, -6.0], [7e-3, 8e3, 9.0], [0.25, 0.5, 0.75]])


def _write(path, text):
    path.write_text(text, encoding="utf-8")
    return path


def _rows(template):
    return "".join(template.format(i=i, x=x, y=y, z=z) for i, (x, y, z) in enumerate(_POINTS.tolist()))


@pytest.mark.parametrize("name, expected", [
    ("x", ("x", None)), ("Y", ("y", None)), ("//X", ("x", None)), ('"Z"', ("z", None)),
    ("x_mm", ("x", "mm")), ("X [mm]", ("x", "mm")), ("x(m)", ("x", "m")), ("z (in)", ("z", "in")),
    ("Y mm", ("y", "mm")), ("y-inch", ("y", "inch")), ("x_cm", ("x", "cm")), ("x[µm]", ("x", "µm")),
    ("pos_x", ("x", None)), ("Point X", ("x", None)), ("coord.y", ("y", None)), ("position_z_mm", ("z", "mm")),
])
def test_axis_names_of_the_grammar(name, expected):
    assert axis_of(name) == expected


@pytest.mark.parametrize("name", ["index", "xx", "x_coord", "xmm", "posx", "intensity", "x_km", "nx", "x2", ""])
def test_names_that_are_not_axes(name):
    assert axis_of(name) is None


def test_the_header_point_x_mm_y_mm_z_mm_intensity_is_read_by_its_names_and_declares_mm(tmp_path):
    # The file: taken as id, x, y before, "no hole found".
    path = _write(tmp_path / "a.csv", "point,x_mm,y_mm,z_mm,intensity\n" + _rows("{i},{x},{y},{z},100\n"))
    cloud = read_cloud(path)
    np.testing.assert_array_equal(cloud.points, _POINTS)
    assert cloud.units == "mm"
    assert (cloud.columns.indices, cloud.columns.names, cloud.columns.width) == ((1, 2, 3), ("x_mm", "y_mm", "z_mm"), 5)
    assert cloud.columns.describe() == "x_mm,y_mm,z_mm (1,2,3; of 5)"


@pytest.mark.parametrize("header, row, unit", [
    ("X [m];Y [m];Z [m];I", "{x};{y};{z};7\n", "m"), ("x(in) y(in) z(in)", "{x} {y} {z}\n", "in"),
    ("//X,Y,Z,R,G,B", "{x},{y},{z},1,2,3\n", None), ("x_mm,y,z", "{x},{y},{z}\n", None),
    ("x_cm,y_cm,z_cm", "{x},{y},{z}\n", None),  # centimetres: named, but not a unit holecli converts
])
def test_the_header_unit_is_declared_only_when_all_three_give_one_holecli_knows(tmp_path, header, row, unit):
    cloud = read_cloud(_write(tmp_path / "a.txt", header + "\n" + _rows(row)))
    np.testing.assert_array_equal(cloud.points, _POINTS)
    assert cloud.units == unit and cloud.columns.unit == unit


def test_a_header_with_x_y_z_in_different_units_is_refused(tmp_path):
    path = _write(tmp_path / "a.csv", "x_mm,y_m,z_mm\n" + _rows("{x},{y},{z}\n"))
    with pytest.raises(LoadError, match=r"the header gives x, y, z in different units \('x_mm', 'y_m', 'z_mm'\)$"):
        read_cloud(path)


def test_a_header_with_two_names_for_one_axis_is_refused(tmp_path):
    path = _write(tmp_path / "a.csv", "x,pos_x,y,z\n" + _rows("{x},{x},{y},{z}\n"))
    with pytest.raises(LoadError, match=r"ambiguous columns: the header has 2 x columns \('x', 'pos_x'\); give --columns"):
        read_cloud(path)
    np.testing.assert_array_equal(read_cloud(path, columns=("pos_x", "y", "z")).points, _POINTS)


# --- --columns ------------------------------------------------------------------------------------


def test_columns_by_name_case_ignored_and_by_0_based_index(tmp_path):
    path = _write(tmp_path / "a.csv", "point,x_mm,y_mm,z_mm,intensity\n" + _rows("{i},{z},{y},{x},100\n"))
    by_name = read_cloud(path, columns=("Z_MM", "y_mm", "x_mm"))
    np.testing.assert_array_equal(by_name.points, _POINTS)
    assert by_name.columns.indices == (3, 2, 1) and by_name.columns.given
    assert by_name.columns.unit is None  # given columns declare nothing
    np.testing.assert_array_equal(read_cloud(path, columns=(3, "2", 1)).points, _POINTS)


def test_columns_parsed_from_the_option():
    assert parse_columns(" x_mm, y_mm,z_mm ") == ("x_mm", "y_mm", "z_mm")
    assert parse_columns("1,2,3") == (1, 2, 3)
    for bad in ("1,2", "x,y,z,w", "x,,z", "x,X,z", "1,1,2"):
        with pytest.raises(ValueError):
            parse_columns(bad)


def test_a_column_name_the_header_lacks_is_one_error_listing_the_columns(tmp_path):
    path = _write(tmp_path / "a.csv", "point,x_mm,y_mm,z_mm,intensity\n" + _rows("{i},{x},{y},{z},100\n"))
    with pytest.raises(LoadError, match=r"--columns names 'x', which the header does not have \(columns 0 'point', "
                                        r"1 'x_mm', 2 'y_mm', 3 'z_mm', 4 'intensity'\)$"):
        read_cloud(path, columns=("x", "y", "z"))
    with pytest.raises(LoadError, match=r"--columns 5 is past the last column \(0-based: columns 0 'point', .*\)$"):
        read_cloud(path, columns=(1, 2, 5))


def test_column_names_on_a_table_without_a_header_are_refused(tmp_path):
    path = _write(tmp_path / "a.xyz", _rows("{x} {y} {z}\n"))
    with pytest.raises(LoadError, match=r"--columns names 'x' but the table has no header row \(3 columns: give "
                                        r"0-based indices, e\.g\. --columns 0,1,2\)$"):
        read_cloud(path, columns=("x", "y", "z"))


def test_columns_on_another_format_are_refused(tmp_path):
    from holecli.io import save_points

    save_points(tmp_path / "a.ply", _POINTS)
    with pytest.raises(LoadError, match=r"--columns is for text tables \(\.csv, \.txt, \.xyz\), not \.ply files$"):
        read_cloud(tmp_path / "a.ply", columns=(0, 1, 2))


def test_columns_of_a_stream(tmp_path):
    text = ("id;a;b;c\n" + _rows("{i};{x};{y};{z}\n")).encode()
    cloud = read_stream(io.BytesIO(text), "csv", columns=("a", "b", "c"))
    np.testing.assert_array_equal(cloud.points, _POINTS)
    assert cloud.columns.names == ("a", "b", "c")


# --- ambiguous tables ----------------------------------------------------------------------------


def test_a_point_number_first_without_a_header_is_refused_then_read_with_columns(tmp_path):
    path = _write(tmp_path / "a.xyz", _rows("{i} {x} {y} {z}\n"))
    with pytest.raises(LoadError, match=r"ambiguous columns: no header, 4 columns and the first is whole numbers going "
                                        r"up by 1 \(0, 1, 2, \.\.\.\): a point number before x, y, z, or x itself\? "
                                        r"\(row 1: .*; give --columns 1,2,3 or --columns 0,1,2, 0-based\)$"):
        read_cloud(path)
    cloud = read_cloud(path, columns=(1, 2, 3))
    np.testing.assert_array_equal(cloud.points, _POINTS)
    assert cloud.columns.describe() == "1,2,3 (no header, given; of 4)"


@pytest.mark.parametrize("first", [["3", "7", "12", "13"], ["0.0", "1.0", "2.0", "3.0"], ["5", "4", "3", "2"]],
                         ids=["not-by-1", "decimals", "down"])
def test_a_first_column_that_is_not_a_point_number_is_x(tmp_path, first):
    rows = "".join(f"{first[i]} {y} {z} 9\n" for i, (_, y, z) in enumerate(_POINTS.tolist()))
    cloud = read_cloud(_write(tmp_path / "a.xyz", rows))
    np.testing.assert_array_equal(cloud.points[:, 0], [float(value) for value in first])


def test_three_columns_counting_up_are_x_y_z(tmp_path):
    # Only x, y, z: nothing else the first column could be.
    rows = "".join(f"{i} {y} {z}\n" for i, (_, y, z) in enumerate(_POINTS.tolist()))
    assert read_cloud(_write(tmp_path / "a.xyz", rows)).points[:, 0].tolist() == [0, 1, 2, 3]


@pytest.mark.parametrize("extra", ["0.0 0.0 1.0", "117 73 49", "117 73 49 255", "0.5 117 73 49 0 0 1"],
                         ids=["normals", "rgb", "rgba", "intensity-rgb-normals"])
def test_x_y_z_first_then_well_known_extra_columns_without_a_header(tmp_path, extra):
    cloud = read_cloud(_write(tmp_path / "a.xyz", _rows("{x} {y} {z} " + extra + "\n")))
    np.testing.assert_array_equal(cloud.points, _POINTS)
    assert cloud.columns.indices == (0, 1, 2) and cloud.columns.names is None


def test_a_header_naming_no_axis_over_three_numeric_columns_is_read(tmp_path):
    cloud = read_cloud(_write(tmp_path / "a.csv", "label,east,north,up\n" + _rows("p{i},{x},{y},{z}\n")))
    np.testing.assert_array_equal(cloud.points, _POINTS)
    assert cloud.columns.names == ("east", "north", "up")


@pytest.mark.skipif(not REALDATA.is_dir(), reason="the shared real files are not on this machine")
@pytest.mark.parametrize("name, width", [("trimesh_points_agisoft.xyz", 6), ("trimesh_points_cloudcompare.xyz", 7)])
def test_real_exports_with_colour_columns_are_read_as_before(name, width):
    cloud = read_cloud(REALDATA / name)
    assert cloud.columns.indices == (0, 1, 2) and cloud.columns.width == width
    assert cloud.points[0].tolist() == [665187.522077, 5648349.895035, 241.767693]
