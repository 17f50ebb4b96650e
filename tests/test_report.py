"""Tests of holecli.report: JSON, JSON Lines and CSV text of detection records."""

import csv
import io
import json

import pytest

from holecli import report
from holecli.results import SCHEMA_VERSION, Detection, Hole, Plane, Timing

# The CSV columns as the docs document them (docs/reference/output.md), in order.
DOCUMENTED_COLUMNS = (
    "file,hole,center_x,center_y,center_z,diameter,normal_x,normal_y,normal_z,rim_points,fit_rms,"
    "max_residual,roundness,bias_correction,partial,arc_deg,scan_lines,type,countersink_diameter,"
    "countersink_angle_deg,countersink_depth,countersink_diameter_at_depth,countersink_rms,counterbore_diameter,"
    "counterbore_depth,bore_diameter,bore_rms,floor_depth,axis_x,axis_y,axis_z,perpendicularity_deg,warnings,"
    "name,diameter_deviation,"
    "position_in_plane,position_along_normal,tilt_deg,countersink_diameter_deviation,countersink_angle_deviation,"
    "countersink_depth_deviation,bore_diameter_deviation,in_tolerance,failed_checks,"
    "schema_version,holecli_version,units,method,view_dir,min_diameter,min_diameter_effective,max_holes,full_only,"
    "gauge_depth,rng,settings,input_format,scan,spec_file,spec_sha256,nominal,point_spacing,gap_scale,line_pitch,period,lattice,"
    "height_noise,triangle_area_bound,candidates,undecided_checks,conformance,decision_rule,coverage_factor,notes,"
    "u_center_in_plane,u_center_along_normal,u_diameter,u_normal_deg,u_countersink_diameter,u_countersink_angle_deg,"
    "u_countersink_depth,u_countersink_diameter_at_depth,u_counterbore_diameter,u_counterbore_depth,u_bore_diameter,"
    "u_floor_depth,u_axis_deg,u_perpendicularity_deg,uncertainty_estimator,"
    "countersink_gauge_deviation"
).split(",")
# The provenance columns (issue 13): the same in every row of a record.
PROVENANCE = DOCUMENTED_COLUMNS.index("schema_version")

# Floats that lose digits when printed short.
AWKWARD = (0.1 + 0.2, 1.0 / 3.0, 2.0**-1074, 1.7976931348623157e308, -0.0, 3.0441296586146489)


def _record(holes=2, file="scans/part 7, left.ply"):
    plane = Plane(point=(3.646, 5.133, AWKWARD[0]),
                  normal=(0.18124306270407364, -0.4979612222122406, 0.848048096156426), rms=7.6e-15, inliers=7062)
    made = []
    for index in range(holes):
        made.append(Hole(index=index, center=(AWKWARD[1] + index, AWKWARD[2], AWKWARD[3]), diameter=AWKWARD[5],
                         normal=(0.0, -0.6, 0.8), rim_points=28 + index, fit_rms=0.0152, max_residual=0.0317,
                         roundness=0.0496, bias_correction=AWKWARD[4], partial=bool(index % 2), arc_deg=360.0,
                         scan_lines=None if index == 0 else 17))
    detection = Detection(holes=tuple(made), plane=plane, points=7062, method="paper", file=file,
                          dropped_points=3, timing=Timing(elapsed_ms=46.25))
    return detection.to_dict()


def test_csv_columns_are_the_documented_ones(repo_root):
    assert list(report.CSV_COLUMNS) == DOCUMENTED_COLUMNS
    page = (repo_root / "docs" / "reference" / "output.md").read_text(encoding="utf-8")
    headers = [line.strip("`") for line in page.splitlines() if line.startswith("`file,hole,")]
    assert headers == [",".join(DOCUMENTED_COLUMNS)]


def test_to_json_round_trips_at_full_precision():
    record = _record()
    text = report.to_json(record)
    assert text.endswith("}\n")
    back = json.loads(text)
    assert back == record
    hole = back["holes"][0]
    # == on floats: every bit survives, including the sign of zero.
    assert hole["center"] == [AWKWARD[1], AWKWARD[2], AWKWARD[3]]
    assert hole["diameter"] == AWKWARD[5]
    assert str(hole["bias_correction"]) == "-0.0"


def test_to_json_line_is_one_line_and_round_trips():
    record = _record()
    text = report.to_json_line(record)
    assert text.endswith("\n") and text.count("\n") == 1
    assert json.loads(text) == record


@pytest.mark.parametrize("writer", [report.to_json, report.to_json_line])
def test_json_refuses_nan_instead_of_writing_invalid_json(writer):
    record = _record()
    record["holes"][0]["diameter"] = float("nan")
    with pytest.raises(ValueError):
        writer(record)


def test_csv_rows_one_row_per_hole_in_column_order():
    record = _record(holes=2)
    rows = report.csv_rows(record)
    assert len(rows) == 2
    assert all(len(row) == len(report.CSV_COLUMNS) for row in rows)
    first, second = (dict(zip(report.CSV_COLUMNS, row)) for row in rows)
    assert first["file"] == record["file"]
    assert (first["hole"], second["hole"]) == ("0", "1")
    hole = record["holes"][0]
    assert [float(first[f"center_{axis}"]) for axis in "xyz"] == hole["center"]
    assert [float(first[f"normal_{axis}"]) for axis in "xyz"] == hole["normal"]
    assert float(first["diameter"]) == hole["diameter"]
    assert first["rim_points"] == "28"
    assert float(first["fit_rms"]) == 0.0152
    assert float(first["max_residual"]) == 0.0317
    assert float(first["roundness"]) == 0.0496
    assert first["bias_correction"] == "-0.0"
    assert float(first["arc_deg"]) == 360.0


def test_csv_gives_the_codes_of_the_warnings_and_of_the_notes_apart():
    from dataclasses import replace

    from holecli.results import HoleNote, HoleWarning

    detection = Detection(holes=(), plane=Plane(point=(0.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0), rms=0.0, inliers=9),
                          points=9, method="robust")
    hole = Hole(index=0, center=(0.0, 0.0, 0.0), diameter=3.0, normal=(0.0, 0.0, 1.0), rim_points=40, fit_rms=0.01,
                warnings=(HoleWarning("rim_gap", "a gap"),),
                notes=(HoleNote("bore_not_seen", "no wall"), HoleNote("axis_not_measured", "no axis")))
    record = replace(detection, holes=(hole,)).to_dict()
    assert [entry["code"] for entry in record["holes"][0]["notes"]] == ["bore_not_seen", "axis_not_measured"]
    row = dict(zip(report.CSV_COLUMNS, report.csv_rows(record)[0]))
    assert (row["warnings"], row["notes"]) == ("rim_gap", "bore_not_seen;axis_not_measured")
    clean = replace(detection, holes=(replace(hole, warnings=()),)).to_dict()
    row = dict(zip(report.CSV_COLUMNS, report.csv_rows(clean)[0]))
    assert (row["warnings"], row["notes"]) == ("", "bore_not_seen;axis_not_measured")


def test_csv_booleans_and_none():
    first, second = (dict(zip(report.CSV_COLUMNS, row)) for row in report.csv_rows(_record(holes=2)))
    assert (first["partial"], second["partial"]) == ("false", "true")
    assert first["scan_lines"] == ""
    assert second["scan_lines"] == "17"


def _provenance_cells(record):
    return report.csv_rows(record)[0][PROVENANCE:]


def test_csv_record_without_holes_is_one_row_with_only_the_file_and_its_provenance():
    record = _record(holes=0)
    rows = report.csv_rows(record)
    assert rows == [["scans/part 7, left.ply"] + [""] * (PROVENANCE - 1) + _provenance_cells(record)]
    assert dict(zip(DOCUMENTED_COLUMNS[PROVENANCE:], rows[0][PROVENANCE:]))["schema_version"] == SCHEMA_VERSION


def test_csv_record_without_file_or_holes():
    record = _record(holes=0, file=None)
    assert report.csv_rows(record) == [[""] * PROVENANCE + _provenance_cells(record)]
    # a record without any provenance (an error record of an older batch) leaves those cells empty too
    assert report.csv_rows({"holes": []}) == [[""] * len(report.CSV_COLUMNS)]


def test_csv_provenance_columns_are_the_records_options_and_scales():
    from holecli.results import Options, Scales
    from holecli.tolerance import check, nominal_spec

    detection = Detection(holes=(), plane=Plane(point=(0.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0), rms=0.0, inliers=9),
                          points=9, method="robust", file="a.ply", candidates=4,
                          options=Options(view_dir=(0.0, 0.5, 1.0), max_holes=3, full_only=True, gauge_depth=0.5,
                                          settings=(("alpha_gaps", 3.0), ("bias_offsets", (0.25, 0.5)))),
                          scales=Scales(point_spacing=0.1, gap_scale=0.07, line_pitch=None, period=0.1, lattice=True,
                                        height_noise=0.001, min_diameter=0.42))
    record = check(detection.to_dict(), nominal_spec(diameter=3.0, tolerance="+0.036/-0"))
    cells = dict(zip(DOCUMENTED_COLUMNS, report.csv_rows(record)[0]))
    assert cells["method"] == "robust"
    assert cells["view_dir"] == "0.0;0.5;1.0"
    assert (cells["min_diameter"], cells["min_diameter_effective"]) == ("", "0.42")
    assert (cells["max_holes"], cells["full_only"], cells["gauge_depth"], cells["rng"]) == ("3", "true", "0.5", "0")
    assert json.loads(cells["settings"]) == {"alpha_gaps": 3.0, "bias_offsets": [0.25, 0.5]}
    assert (cells["spec_file"], cells["spec_sha256"]) == ("", "")
    assert json.loads(cells["nominal"])["band"] == {"lower": 0.0, "upper": 0.036}
    assert (cells["point_spacing"], cells["gap_scale"], cells["line_pitch"], cells["period"]) == (
        "0.1", "0.07", "", "0.1")
    assert (cells["lattice"], cells["triangle_area_bound"], cells["candidates"]) == ("true", "", "4")


def test_write_csv_header_and_rows_parse_back():
    buffer = io.StringIO()
    report.write_csv([_record(holes=2), _record(holes=0, file="b.csv")], buffer)
    text = buffer.getvalue()
    assert text.splitlines()[0] == ",".join(DOCUMENTED_COLUMNS)
    assert "\r" not in text
    rows = list(csv.reader(io.StringIO(text)))
    assert rows[0] == DOCUMENTED_COLUMNS
    assert len(rows) == 4
    # The file name holds a comma: quoted by the writer, whole again when read back.
    assert rows[1][0] == rows[2][0] == "scans/part 7, left.ply"
    assert rows[3][:PROVENANCE] == ["b.csv"] + [""] * (PROVENANCE - 1)
    assert float(rows[1][DOCUMENTED_COLUMNS.index("center_x")]) == AWKWARD[1]


def test_write_csv_without_header():
    buffer = io.StringIO()
    report.write_csv([_record(holes=1)], buffer, header=False)
    rows = list(csv.reader(io.StringIO(buffer.getvalue())))
    assert len(rows) == 1
    assert rows[0][1] == "0"


def test_write_csv_of_no_records_is_the_header_only():
    buffer = io.StringIO()
    report.write_csv([], buffer)
    assert buffer.getvalue() == ",".join(DOCUMENTED_COLUMNS) + "\n"
