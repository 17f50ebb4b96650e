"""The service behind every front end (holecli.serve.service): a request checked, measured in a warm
worker, stored, answered; the record is the one ``holecli detect`` writes."""

import asyncio
import json
import shutil
from pathlib import Path

import pytest

from holecli import cli, measure_scan
from holecli.serve.service import MeasureRequest, Service, ServiceError, checked_meta, detection_keywords
from holecli.store import open_store

SAMPLES = Path(__file__).resolve().parents[2] / "sample_clouds"


@pytest.fixture(scope="module")
def cell(tmp_path_factory):
    """A drilling cell's files: ``holecli simulate --cell`` scans in the allowed folder ``scans``, its
    part.toml as the spec ``part`` and register's result of R1, R3, R4 as the registration ``frame``
    in the spec folder ``specs``, and the Table I scan and the panel with its tolerances."""
    from click.testing import CliRunner

    folder = tmp_path_factory.mktemp("service")
    runner = CliRunner()
    made = runner.invoke(cli.main, ["simulate", "cell", str(folder / "scans"), "--seed", "1"])
    assert made.exit_code == 0, made.stderr
    (folder / "specs").mkdir()
    shutil.copy(folder / "scans" / "part.toml", folder / "specs" / "part.toml")
    shutil.copy(SAMPLES / "panel_tolerances.toml", folder / "specs" / "panel.toml")
    registered = runner.invoke(cli.main, ["register", *(str(folder / "scans" / f"R{i}.ply") for i in (1, 3, 4)),
                                          "--spec", str(folder / "specs" / "part.toml"),
                                          "-o", str(folder / "specs" / "frame.json")])
    assert registered.exit_code == 0, registered.stderr
    for name in ("table1.ply", "panel.ply", "no_hole.csv"):
        shutil.copy(SAMPLES / name, folder / "scans" / name)
    return folder


@pytest.fixture(scope="module")
def service(cell):
    store = open_store(cell / "results.sqlite")
    running = Service(store, workers=1, allow_dirs=[str(cell / "scans")], spec_dir=str(cell / "specs"),
                      request_timeout=60)
    running.warm()
    yield running
    running.close()


def measure(service, **request):
    return asyncio.run(service.measure(MeasureRequest(**request)))


def refused(service, **request):
    with pytest.raises(ServiceError) as error:
        measure(service, **request)
    return error.value


def test_a_path_is_measured_into_the_detect_record_and_stored(service, cell):
    answer = measure(service, path="table1.ply", meta={"part": "P-7", "serial": "S1"})
    expected = measure_scan(cell / "scans" / "table1.ply").record
    assert [hole["diameter"] for hole in answer["holes"]] == [hole["diameter"] for hole in expected["holes"]]
    assert answer["file"] == "table1.ply" and answer["stored"] is True
    assert answer["meta"] == {"part": "P-7", "serial": "S1", "cell": None, "operator": None}
    assert len(answer["id"]) == 32 and answer["received"].endswith("Z") and answer["processing_ms"] > 0
    jsonschema = pytest.importorskip("jsonschema")
    from holecli.schema import record_schema

    jsonschema.Draft202012Validator(record_schema("served_record")).validate(answer)
    stored = asyncio.run(service.result(answer["id"]))
    assert json.loads(json.dumps(stored)) == json.loads(json.dumps(answer))
    found = asyncio.run(service.results(part="P-7", serial="S1"))
    assert [summary["id"] for summary in found] == [answer["id"]]


def test_an_upload_is_measured_as_the_file_would_be(service, cell):
    data = (cell / "scans" / "table1.ply").read_bytes()
    answer = measure(service, upload=data, format="ply")
    by_path = measure(service, path="table1.ply")
    assert answer["file"] == "upload.ply" and "path" not in answer
    assert answer["holes"][0]["diameter"] == by_path["holes"][0]["diameter"]
    assert list(Path(service._uploads).iterdir()) == []  # the upload's copy is gone


def test_a_named_spec_checks_the_holes(service):
    answer = measure(service, path="panel.ply", spec="panel")
    assert answer["verdict"]["in_tolerance"] is True and answer["verdict"]["checked"] == 4
    summary = asyncio.run(service.results(verdict="pass"))[0]
    assert summary["id"] == answer["id"]


def test_a_named_registration_maps_the_spec_into_the_scans_frame(service):
    # R2 took no part in the registration; its stem ties it to the spec's hole R2 (as holecli detect does)
    answer = measure(service, path="R2.ply", spec="part", registration="frame")
    hole = answer["holes"][0]
    assert hole["name"] == "R2" and hole["conformance"]["position"]["decision"] == "pass"
    assert answer["options"]["tolerances"]["registration"]["file"].endswith("frame.json")
    unmapped = measure(service, path="R2.ply", spec="part")
    assert "position" not in unmapped["holes"][0]["conformance"]


def test_detection_options_reach_the_pipeline(service):
    answer = measure(service, path="panel.ply", options={"max_holes": 1, "explain": True})
    assert len(answer["holes"]) == 1 and "rejected" in answer
    assert measure(service, path="table1.ply", options={"output_units": "m", "units": "mm"})["units"] == "m"


@pytest.mark.parametrize("request_, status", [
    ({"path": "missing.ply"}, 404),
    ({"path": "../x.ply"}, 400),
    ({"path": "/etc/hostname"}, 403),
    ({"path": "table1.ply", "spec": "nope"}, 404),
    ({"path": "table1.ply", "spec": "../part"}, 400),
    ({"path": "table1.ply", "options": {"fast": True}}, 400),
    ({"path": "table1.ply", "meta": {"part": "x" * 201}}, 400),
    ({}, 400),
    ({"path": "table1.ply", "upload": b"ply"}, 400),
    ({"upload": b"not a cloud", "format": "ply"}, 422),
    ({"upload": b"x,y,z\n", "format": "obj"}, 400),
])
def test_refusals_have_their_status(service, request_, status):
    assert refused(service, **request_).status == status


def test_a_scan_that_cannot_be_read_is_422_naming_it(service):
    error = refused(service, upload=b"ply\nformat ascii 1.0\nelement vertex 3\nend_header\n1 2\n", format="ply")
    assert error.status == 422 and error.code == "unmeasurable" and error.message.startswith("upload.ply")


def test_an_upload_larger_than_the_cap_is_413(service):
    cap, service.max_upload_bytes = service.max_upload_bytes, 10
    try:
        assert refused(service, upload=b"x" * 11, format="ply").status == 413
    finally:
        service.max_upload_bytes = cap


def test_subscribers_hear_of_each_stored_measurement(service):
    heard = []
    service.subscribe(lambda answer: heard.append((answer["id"], service.store.get(answer["id"]) is not None)))
    answer = measure(service, path="table1.ply")
    assert heard[-1] == (answer["id"], True)  # stored before anyone hears of it
    assert service.last["id"] == answer["id"]


def test_an_unknown_result_is_404_and_a_malformed_id_400(service):
    with pytest.raises(ServiceError) as error:
        asyncio.run(service.result("0" * 32))
    assert error.value.status == 404
    with pytest.raises(ServiceError) as error:
        asyncio.run(service.result("../etc"))
    assert error.value.status == 400


def test_the_metrics_count_answers_and_errors(service):
    before = service.metrics.text().decode()
    refused(service, path="missing.ply", channel="tcp")
    after = service.metrics.text().decode()
    assert 'holecli_errors_total{channel="tcp",status="404"} 1.0' in after
    assert 'holecli_errors_total{channel="tcp",status="404"}' not in before


@pytest.mark.parametrize("options, message", [
    ({"method": "fast"}, "options.method"), ({"min_diameter": -1}, "options.min_diameter"),
    ({"min_diameter": True}, "options.min_diameter"), ({"max_holes": 0}, "options.max_holes"),
    ({"max_holes": 1.5}, "options.max_holes"), ({"view_dir": [0, 0]}, "options.view_dir"),
    ({"view_dir": [0, 0, 0]}, "options.view_dir"), ({"columns": ["x", "y"]}, "options.columns"),
    ({"units": "cm"}, "options.units"), ({"full_only": "yes"}, "options.full_only"),
    ({"method": "paper", "max_holes": 2}, "cannot be used with method paper"),
    ({"min_diameter": float("nan")}, "options.min_diameter"), ({"scan": -1}, "options.scan"),
])
def test_detection_options_are_checked(options, message):
    with pytest.raises(ServiceError) as error:
        detection_keywords(options)
    assert error.value.status == 400 and message in error.value.message


def test_detection_options_become_keywords():
    keywords = detection_keywords({"method": "robust", "min_diameter": 2, "view_dir": [0, 0, 1], "max_holes": None,
                                   "units": "mm", "output_units": "m", "columns": ["x", 1, "z"]})
    assert keywords["min_diameter"] == 2.0 and keywords["view_dir"] == (0.0, 0.0, 1.0)
    assert "max_holes" not in keywords and keywords["columns"] == ("x", 1, "z")
    assert (keywords["units"].file, keywords["units"].output) == ("mm", "m")


@pytest.mark.parametrize("meta", [[], {"bad key": "x"}, {"part": 7}, {"part": "a\nb"}, {f"k{i}": "v" for i in range(21)}])
def test_meta_is_words_to_lines(meta):
    with pytest.raises(ServiceError) as error:
        checked_meta(meta)
    assert error.value.status == 400


def test_meta_keeps_other_words_and_drops_nulls():
    assert checked_meta({"part": "P", "serial": None, "fixture": "F2"}) == {"part": "P", "serial": None, "cell": None,
                                                                             "operator": None, "fixture": "F2"}
