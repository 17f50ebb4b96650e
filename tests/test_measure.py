"""measure_scan: the one road from a scan to its record, which detect, batch, plot and register take."""

import json

import pytest

from holecli import MeasureError, Measurement, measure_scan
from holecli.batch import measure_record
from holecli.tolerance import nominal_spec
from holecli.units import UnitChoice

SPEC = nominal_spec(diameter=3.0, tolerance="+0.036/-0")


def _without_timing(record):
    return {key: value for key, value in record.items() if key not in ("timing", "path")}


def test_the_record_is_the_one_detect_prints(table1_files, run):
    path = str(table1_files[".ply"])
    result = run("detect", path, "--method", "paper", "--nominal-diameter", "3", "--tolerance", "+0.036/-0")
    measurement = measure_scan(path, method="paper", spec=SPEC)
    assert isinstance(measurement, Measurement)
    assert _without_timing(measurement.record) == _without_timing(json.loads(result.stdout))


def test_the_record_is_the_one_batch_writes(table1_files):
    path = str(table1_files[".csv"])
    units = UnitChoice(file="mm", output="m")
    record = measure_scan(path, method="paper", units=units, spec=nominal_spec(diameter=0.003, tolerance=0.0001),
                          resolve_path=True).record
    batch_record = measure_record(path, {"method": "paper"}, nominal_spec(diameter=0.003, tolerance=0.0001),
                                  units=units)
    assert record["units"] == "m" and "verdict" in record
    assert _without_timing(record) == _without_timing(batch_record)
    assert list(record) == list(batch_record)  # the same keys in the same order ("path" before the verdict)


def test_a_checked_measurement_keeps_the_spec_it_was_checked_against(table1_files):
    measurement = measure_scan(str(table1_files[".ply"]), method="paper", spec=SPEC)
    assert measurement.spec is SPEC
    assert measure_scan(str(table1_files[".ply"]), method="paper").spec is None


@pytest.mark.parametrize("case, stage, message", [
    ("missing", "read", "file not found"),
    ("output unit without the file's", "units", ""),
])
def test_a_scan_that_cannot_be_measured_says_where(table1_files, tmp_path, case, stage, message):
    if case == "missing":
        path, options = str(tmp_path / "missing.ply"), {}
    else:
        path, options = str(table1_files[".ply"]), {"units": UnitChoice(output="m")}
    with pytest.raises(MeasureError) as raised:
        measure_scan(path, method="paper", **options)
    assert raised.value.stage == stage
    assert str(raised.value).startswith(path) and message in str(raised.value)
    assert raised.value.__cause__ is not None


def test_the_points_are_kept_only_when_a_picture_is_asked_for(table1_files):
    path = str(table1_files[".ply"])
    assert measure_scan(path, method="paper").points is None
    with pytest.raises(ValueError, match="plot=True"):
        measure_scan(path, method="paper").png()
    kept = measure_scan(path, method="paper", plot=True)
    assert kept.points.shape == (kept.detection.points, 3)
    assert _without_timing(kept.record) == _without_timing(measure_scan(path, method="paper").record)


def test_a_cloud_read_otherwise_is_measured_the_same(table1_files):
    from holecli.io import read_cloud

    path = str(table1_files[".ply"])
    read = measure_scan(path, read=lambda: read_cloud(path), method="paper")
    assert _without_timing(read.record) == _without_timing(measure_scan(path, method="paper").record)
