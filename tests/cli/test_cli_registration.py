"""``detect`` and ``batch`` with ``--registration`` (register's result maps the spec into the scans' frame)
and ``--name`` (a scan tied to a spec hole), on the docs' drilling cell (docs/guide/register.md) (issue 25, item 7)."""

import json
import shutil

import pytest

from holecli import cli


@pytest.fixture(scope="module")
def cell(tmp_path_factory):
    """``holecli simulate --cell`` (four reference holes R1..R4 in the robot's frame, part.toml in the
    part's) and ``registration.json`` of R1, R3, R4."""
    from click.testing import CliRunner

    folder = tmp_path_factory.mktemp("cell")
    runner = CliRunner()
    made = runner.invoke(cli.main, ["simulate", "--cell", str(folder / "cell"), "--seed", "1"])
    assert made.exit_code == 0, made.stderr
    registered = runner.invoke(cli.main, ["register", *(str(folder / "cell" / f"R{i}.ply") for i in (1, 3, 4)),
                                          "--spec", str(folder / "cell" / "part.toml"),
                                          "-o", str(folder / "registration.json")])
    assert registered.exit_code == 0, registered.stderr
    return folder


def _spec(cell):
    return cell / "cell" / "part.toml"


def _one_hole(result):
    record = json.loads(result.stdout)
    assert len(record["holes"]) == 1
    return record, record["holes"][0]


def _valid(record, kind="detect_record"):
    jsonschema = pytest.importorskip("jsonschema")
    from holecli.schema import record_schema

    jsonschema.Draft202012Validator(record_schema(kind)).validate(record)


def test_without_the_registration_the_spec_is_in_another_frame(run, cell):
    result = run("detect", cell / "cell" / "R2.ply", "--spec", _spec(cell))
    # R2.ply's stem ties its hole to R2, but the part frame is 600 mm away: no position is checked
    record, hole = _one_hole(result)
    assert hole["name"] == "R2" and "position" not in hole["conformance"]
    assert hole["position_deviation"] is None
    assert [note["code"] for note in hole["notes"]][-1] == "not_in_spec_frame"
    assert record["options"]["tolerances"]["tied"] == {"hole": "R2", "by": "file stem"}
    _valid(record)


def test_detect_with_the_registration_finds_the_hole_at_its_nominal(run, cell):
    registration = cell / "registration.json"
    # R2 did not take part in the registration: its nominal is mapped into the scan's frame
    result = run("detect", cell / "cell" / "R2.ply", "--spec", _spec(cell), "--registration", registration)
    assert result.exit_code == cli.EXIT_OK, result.stderr
    record, hole = _one_hole(result)
    assert hole["name"] == "R2" and hole["in_tolerance"] is True
    position = hole["conformance"]["position"]
    assert position["decision"] == "pass" and position["value"] < 0.01
    # the registration's u at R2 is in U: larger than the measurement's alone, in quadrature
    measured_u = hole["uncertainty"]["center_in_plane"]
    assert position["nominal_uncertainty"] > 0
    assert position["expanded_uncertainty"] > 2 * measured_u
    assert position["expanded_uncertainty"] == pytest.approx(
        2 * (measured_u ** 2 + position["nominal_uncertainty"] ** 2) ** 0.5)
    applied = record["options"]["tolerances"]["registration"]
    assert applied["file"] == str(registration) and applied["spec_file"].endswith("part.toml")
    _valid(record)


def test_the_registration_u_makes_a_guarded_position_undecided(run, cell, tmp_path):
    # a registration 100 times less certain: its u at R2 is then larger than the measurement's and the
    # guarded rule cannot prove the position any more
    data = json.loads((cell / "registration.json").read_text())
    data["uncertainty"]["covariance"] = [[value * 1e6 for value in row] for row in data["uncertainty"]["covariance"]]
    loose = tmp_path / "loose.json"
    loose.write_text(json.dumps(data))
    tight = run("detect", cell / "cell" / "R2.ply", "--spec", _spec(cell), "--registration",
                cell / "registration.json", "--decision-rule", "guarded")
    wide = run("detect", cell / "cell" / "R2.ply", "--spec", _spec(cell), "--registration", loose,
               "--decision-rule", "guarded")
    u_tight = _one_hole(tight)[1]["conformance"]["position"]["expanded_uncertainty"]
    u_wide = _one_hole(wide)[1]["conformance"]["position"]["expanded_uncertainty"]
    assert u_wide > 50 * u_tight
    assert u_wide == pytest.approx(2 * _one_hole(wide)[1]["conformance"]["position"]["nominal_uncertainty"], rel=0.05)


def test_batch_with_the_registration(run, cell, tmp_path):
    output = tmp_path / "shift.jsonl"
    result = run("batch", *(cell / "cell" / f"R{i}.ply" for i in (1, 2)), "--spec", _spec(cell),
                 "--registration", cell / "registration.json", "-o", output, "-q")
    assert result.exit_code == cli.EXIT_OK, result.stderr
    records = [json.loads(line) for line in output.read_text().splitlines()]
    assert sorted(record["holes"][0]["name"] for record in records) == ["R1", "R2"]
    for record in records:
        assert record["verdict"]["in_tolerance"] and not record["verdict"]["missing"]
        assert record["holes"][0]["conformance"]["position"]["nominal_uncertainty"] > 0
        _valid(record, "batch_record")


def test_name_ties_a_scan_of_another_name(run, cell, tmp_path):
    left = tmp_path / "left.ply"
    shutil.copy(cell / "cell" / "R2.ply", left)
    # no stem to go by: by position nothing matches, every spec hole is missing
    untied = run("detect", left, "--spec", _spec(cell), "--registration", cell / "registration.json")
    assert untied.exit_code == cli.EXIT_OUT_OF_TOLERANCE
    assert json.loads(untied.stdout)["holes"][0]["name"] == "R2"  # (mapped, R2's nominal is near it)
    for name in (["--name", "R2"], ["--name", "left.ply=R2"], ["--name", f"{left}=R2"]):
        tied = run("detect", left, "--spec", _spec(cell), "--registration", cell / "registration.json", *name)
        assert tied.exit_code == cli.EXIT_OK, (name, tied.stderr)
        record, hole = _one_hole(tied)
        assert hole["name"] == "R2" and record["verdict"]["missing"] == []
        assert record["options"]["tolerances"]["tied"] == {"hole": "R2", "by": "--name"}
    # tied to the wrong hole: checked against it, and its position fails
    wrong = run("detect", left, "--spec", _spec(cell), "--registration", cell / "registration.json", "--name", "R1")
    assert wrong.exit_code == cli.EXIT_OUT_OF_TOLERANCE
    assert _one_hole(wrong)[1]["failed_checks"] == ["diameter", "position"]


def test_unknown_hole_name_is_an_error_naming_the_spec(run, cell):
    for command, name in (("detect", "R9"), ("batch", "R2.ply=R9")):
        result = run(command, cell / "cell" / "R2.ply", "--spec", _spec(cell), "--name", name)
        assert result.exit_code == cli.EXIT_USAGE
        assert result.stderr.startswith("Error: ") and str(_spec(cell)) in result.stderr and "R9" in result.stderr
        assert result.stdout == ""


def test_name_of_a_scan_not_given_is_an_error(run, cell):
    for command in ("detect", "batch"):
        result = run(command, cell / "cell" / "R2.ply", "--spec", _spec(cell), "--name", "R3.ply=R3")
        assert result.exit_code == cli.EXIT_USAGE, (command, result.stderr)
        assert "R3.ply" in result.stderr and result.stdout == ""


@pytest.mark.parametrize("content, problem", [
    ("not json", "not a registration"),
    ('{"schema": "holecli.detect"}', "not a holecli register record"),
    ('{"schema": "holecli.register", "transform": {"matrix": [[1, 0, 0, 0]]}}', "transform.matrix"),
])
def test_bad_registration_file_is_one_error_line(run, cell, tmp_path, content, problem):
    bad = tmp_path / "bad.json"
    bad.write_text(content)
    for command in ("detect", "batch"):
        result = run(command, cell / "cell" / "R2.ply", "--spec", _spec(cell), "--registration", bad)
        assert result.exit_code == cli.EXIT_INPUT, (command, result.stderr)
        lines = result.stderr.splitlines()
        assert len(lines) == 1 and lines[0].startswith(f"Error: {bad}: ") and problem in lines[0], lines
        assert result.stdout == "" and "Traceback" not in result.stderr


def test_registration_and_name_need_a_spec(run, cell):
    for option in (["--registration", cell / "registration.json"], ["--name", "R2"]):
        result = run("detect", cell / "cell" / "R2.ply", *option)
        assert result.exit_code == cli.EXIT_USAGE and "needs --spec" in result.stderr


def test_a_registration_in_metres_is_converted_into_the_scans_millimetres(run, cell, tmp_path):
    data = json.loads((cell / "registration.json").read_text())
    data["units"] = "m"
    data["transform"]["matrix"] = [[*row[:3], row[3] / 1000] for row in data["transform"]["matrix"][:3]] + [
        [0.0, 0.0, 0.0, 1.0]]
    metres = tmp_path / "metres.json"
    metres.write_text(json.dumps(data))
    scan = cell / "cell" / "R2.ply"
    # the spec in mm: read as metres the translation is 1000 times too short and R2 is far off
    result = run("detect", scan, "--spec", _spec(cell), "--registration", metres, "--units", "mm")
    assert result.exit_code == cli.EXIT_OK, result.stderr
    assert _one_hole(result)[1]["conformance"]["position"]["value"] < 0.01
    unknown = run("detect", scan, "--spec", _spec(cell), "--registration", metres)  # the scan's unit not known
    assert _one_hole(unknown)[1]["conformance"]["position"]["decision"] == "fail"


def test_a_spec_in_inches_is_converted_before_the_registration_maps_it(run, cell, tmp_path):
    # the drawing in inches, the registration and the scan in mm (--units mm): the spec's lengths are
    # put in mm first, then moved into the robot's frame; the other way round, every center would be
    # mapped 25.4 times too close to the part's origin
    import tomllib

    drawn = tomllib.loads(_spec(cell).read_text())
    lines = ['units = "in"']
    for hole in drawn["hole"]:
        lines += ["[[hole]]", f'name = "{hole["name"]}"',
                  f"center = [{', '.join(repr(c / 25.4) for c in hole['center'])}]",
                  f"normal = {hole['normal']!r}", f"diameter = {hole['diameter'] / 25.4!r}",
                  f"tolerance = {hole['tolerance'] / 25.4!r}",
                  f"position_tolerance = {hole['position_tolerance'] / 25.4!r}"]
    spec = tmp_path / "part_in.toml"
    spec.write_text("\n".join(lines) + "\n")
    result = run("detect", cell / "cell" / "R2.ply", "--units", "mm", "--spec", spec,
                 "--registration", cell / "registration.json")
    assert result.exit_code == cli.EXIT_OK, result.stderr
    record, hole = _one_hole(result)
    assert record["units"] == "mm"
    assert hole["name"] == "R2" and hole["conformance"]["position"]["decision"] == "pass"
    assert hole["conformance"]["position"]["value"] < 0.01
