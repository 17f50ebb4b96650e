"""Tests of ``holecli register``: synthetic scans of a part's reference holes placed by a known transform."""

import csv
import io
import json
import os
import shutil

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from holecli import cli
from holecli.io import save_points
from holecli.simulation import synth

# The part (CAD) frame: hole name -> (center, normal); normals out of the material.
LAYOUT = {
    "A1": ((0.0, 0.0, 0.0), (0.0, 0.0, 1.0)),
    "A2": ((60.0, 0.0, 0.0), (0.0, 0.0, 1.0)),
    "A3": ((60.0, 40.0, 2.0), (0.15, 0.0, 1.0)),
    "A4": ((0.0, 40.0, 0.0), (0.0, 0.2, 1.0)),
    "A5": ((30.0, 20.0, -3.0), (0.0, 0.0, 1.0)),
}
TRUE_ROTATION = Rotation.from_euler("xyz", [3.0, -2.0, 25.0], degrees=True).as_matrix()
TRUE_TRANSLATION = np.array([400.0, -120.0, 55.0])


def _unit(vector):
    vector = np.asarray(vector, dtype=float)
    return vector / np.linalg.norm(vector)


def _local_to_part(normal):
    """A rotation taking the local z axis onto ``normal`` (shortest)."""
    z = _unit(normal)
    axis = np.cross([0.0, 0.0, 1.0], z)
    if np.linalg.norm(axis) < 1e-15:
        return np.eye(3)
    return Rotation.from_rotvec(_unit(axis) * np.arccos(np.clip(z[2], -1, 1))).as_matrix()


def _scan(name, offset=(0.0, 0.0)):
    """Points of a flat patch around hole ``name``, in the measuring frame; ``offset`` (local x, y) moves the hole."""
    center, normal = LAYOUT[name]
    local = _local_to_part(normal)
    rotation = TRUE_ROTATION @ local
    translation = TRUE_ROTATION @ np.asarray(center) + TRUE_TRANSLATION
    scene = synth.SceneSpec(holes=(synth.HoleSpec(center=tuple(offset), diameter=3.0),),
                            extent=(-3.5, 3.5, -3.5, 3.5), spacing=0.09,
                            rotation_deg=tuple(Rotation.from_matrix(rotation).as_euler("xyz", degrees=True)),
                            translation=tuple(translation))
    return synth.make_scan(scene, 0).points


def _spec_text(names):
    blocks = []
    for name in names:
        center, normal = LAYOUT[name]
        blocks.append(f'[[hole]]\nname = "{name}"\ncenter = {list(center)}\nnormal = {list(normal)}\n'
                      'diameter = 3.0\ntolerance = 0.05\n')
    return "\n".join(blocks)


@pytest.fixture
def reg(run):
    """``holecli register ARGS...`` in-process (the ``run`` fixture of tests/conftest.py)."""
    return lambda *args: run("register", *args)


@pytest.fixture(scope="module")
def part(tmp_path_factory):
    """Scans A1..A5.ply, a displaced A3 (A3_moved.ply: 0.2 mm in its plane), spec files and targets."""
    folder = tmp_path_factory.mktemp("part")
    for name in LAYOUT:
        save_points(folder / f"{name}.ply", _scan(name))
    save_points(folder / "A3_moved.ply", _scan("A3", offset=(0.2, 0.0)))
    save_points(folder / "A3_diagonal.ply", _scan("A3", offset=(0.1, 0.1)))
    plain = synth.SceneSpec(holes=(), extent=(-3.5, 3.5, -3.5, 3.5), spacing=0.09)
    save_points(folder / "flat.ply", synth.make_scan(plain, 0).points)
    (folder / "part.toml").write_text(_spec_text(LAYOUT))
    (folder / "targets.csv").write_text("name,x,y,z,nx,ny,nz\nT1,10,5,0,0,0,1\nT2,50,30,0,0,0.6,0.8\n")
    return folder


def _paths(part, *names):
    return [part / f"{name}.ply" for name in names]


def _assert_one_line_error(result, *texts, code=cli.EXIT_INPUT):
    assert result.exit_code == code, (result.exit_code, result.stderr, result.exception)
    assert result.stdout == ""
    lines = result.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("Error: "), result.stderr
    for text in texts:
        assert str(text) in lines[0], lines[0]
    assert "Traceback" not in result.stderr


def _rotation_error_deg(matrix):
    return np.degrees(Rotation.from_matrix(np.asarray(matrix)[:3, :3] @ TRUE_ROTATION.T).magnitude())


def test_recovers_the_transform_and_writes_corrected_targets(reg, part, tmp_path):
    corrected = tmp_path / "corrected.csv"
    result = reg(*_paths(part, "A1", "A2", "A3", "A4"), "--spec", part / "part.toml", "--max-residual", 0.01,
                 "--targets", part / "targets.csv", "--targets-output", corrected)
    assert result.exit_code == cli.EXIT_OK, result.stderr
    record = json.loads(result.stdout)
    assert record["schema"] == "holecli.register" and record["schema_version"] == 1
    assert record["schema_minor_version"] == 2 and record["notes"] == []  # 1.1: notes (issue 24), 1.2: consistency
    transform = record["transform"]
    assert np.allclose(transform["translation"], TRUE_TRANSLATION, atol=3e-3)
    assert _rotation_error_deg(transform["matrix"]) < 0.005
    assert np.asarray(transform["matrix"])[3].tolist() == [0, 0, 0, 1]
    expected_q = Rotation.from_matrix(TRUE_ROTATION).as_quat()  # x, y, z, w
    assert transform["quaternion_wxyz"] == pytest.approx([expected_q[3], *expected_q[:3]], abs=1e-4)
    assert transform["roll_pitch_yaw_deg"] == pytest.approx([3.0, -2.0, 25.0], abs=0.005)
    assert record["match"]["method"] == "names"
    assert [hole["name"] for hole in record["holes"]] == ["A1", "A2", "A3", "A4"]
    assert all(hole["residual"]["in_plane"] < 0.003 for hole in record["holes"])
    assert record["outliers"] == [] and record["free_dofs"] == [] and record["verdict"] == "pass"
    assert record["uncertainty"]["source"] == "sigmas"
    assert all(u > 0 for u in record["uncertainty"]["translation"] + record["uncertainty"]["rotation_deg"])
    with corrected.open() as handle:
        rows = list(csv.DictReader(handle))
    assert [row["name"] for row in rows] == ["T1", "T2"]
    truth = np.array([[10, 5, 0], [50, 30, 0]]) @ TRUE_ROTATION.T + TRUE_TRANSLATION
    got = np.array([[float(row[k]) for k in ("x", "y", "z")] for row in rows])
    assert np.allclose(got, truth, atol=5e-3)
    assert np.allclose([float(rows[1][k]) for k in ("nx", "ny", "nz")], TRUE_ROTATION @ [0, 0.6, 0.8], atol=1e-4)
    assert all(0 < float(row["u_x"]) < 0.01 for row in rows)


def test_unnamed_scans_match_by_distances(reg, part, tmp_path):
    # copies named so that no stem is a spec hole's name
    paths = []
    for index, name in enumerate(("A4", "A1", "A3", "A2")):
        target = tmp_path / f"scan{index}.ply"
        target.write_bytes((part / f"{name}.ply").read_bytes())
        paths.append(target)
    result = reg(*paths, "--spec", part / "part.toml")
    assert result.exit_code == cli.EXIT_OK, result.stderr
    record = json.loads(result.stdout)
    assert record["match"]["method"] == "distances"
    assert [hole["name"] for hole in record["holes"]] == ["A4", "A1", "A3", "A2"]
    assert np.allclose(record["transform"]["translation"], TRUE_TRANSLATION, atol=3e-3)


def test_names_a_displaced_hole_as_the_outlier(reg, part):
    result = reg(*_paths(part, "A1", "A2", "A3_moved", "A4", "A5"), "--name", "A3_moved=A3",
                 "--spec", part / "part.toml", "--max-residual", 0.05)
    assert result.exit_code == cli.EXIT_OUT_OF_TOLERANCE, result.stderr
    record = json.loads(result.stdout)
    assert record["outliers"] == ["A3"]
    a3 = next(hole for hole in record["holes"] if hole["name"] == "A3")
    assert a3["outlier"] and not a3["used"]
    assert a3["residual"]["in_plane"] == pytest.approx(0.2, abs=0.01)
    assert np.allclose(record["transform"]["translation"], TRUE_TRANSLATION, atol=3e-3)
    assert _rotation_error_deg(record["transform"]["matrix"]) < 0.005
    assert record["verdict"] == "fail" and record["failed"] == ["A3: outlier"]
    assert "outlier" in result.stderr and "A3" in result.stderr


def test_two_holes_use_the_normals(reg, part):
    result = reg(*_paths(part, "A3", "A4"), "--spec", part / "part.toml")
    assert result.exit_code == cli.EXIT_OK, result.stderr
    record = json.loads(result.stdout)
    assert record["free_dofs"] == []
    assert _rotation_error_deg(record["transform"]["matrix"]) < 0.005


def test_one_hole_reports_the_free_rotation(reg, part):
    result = reg(*_paths(part, "A3"), "--spec", part / "part.toml")
    assert result.exit_code == cli.EXIT_OK, result.stderr
    record = json.loads(result.stdout)
    assert record["free_dofs"] == ["rotation about the normal"]
    matrix = np.asarray(record["transform"]["matrix"])
    center = np.asarray(LAYOUT["A3"][0])
    assert np.allclose(matrix[:3, :3] @ center + matrix[:3, 3], TRUE_ROTATION @ center + TRUE_TRANSLATION, atol=3e-3)
    assert "free_dofs" in result.stderr


def test_csv_output(reg, part):
    result = reg(*_paths(part, "A1", "A2", "A3", "A4"), "--spec", part / "part.toml", "--format", "csv")
    assert result.exit_code == cli.EXIT_OK, result.stderr
    rows = list(csv.DictReader(io.StringIO(result.stdout)))
    assert [row["name"] for row in rows] == ["A1", "A2", "A3", "A4"]
    assert rows[0]["used"] == "true" and rows[0]["scan"].endswith("A1.ply")
    assert [float(rows[0][k]) for k in ("t_x", "t_y", "t_z")] == pytest.approx(TRUE_TRANSLATION.tolist(), abs=3e-3)
    assert rows[0]["t_x"] == rows[3]["t_x"]


def test_table_output_and_output_file(reg, part, tmp_path):
    out = tmp_path / "reg.txt"
    result = reg(*_paths(part, "A1", "A2", "A3"), "--spec", part / "part.toml", "--format", "table", "-o", out)
    assert result.exit_code == cli.EXIT_OK, result.stderr
    assert result.stdout == ""
    text = out.read_text()
    assert "translation" in text and "A3" in text and "residuals after the fit" in text


def test_missing_spec(reg, part, tmp_path):
    _assert_one_line_error(reg(*_paths(part, "A1"), "--spec", tmp_path / "nope.toml"), "nope.toml")


def test_bad_targets_names_the_line_and_writes_nothing(reg, part, tmp_path):
    bad = tmp_path / "bad.csv"
    bad.write_text("name,x,y,z,nx,ny,nz\nT1,1,2,3,0,0,1\nT2,1,2,x,0,0,1\n")
    out, corrected = tmp_path / "out.json", tmp_path / "corrected.csv"
    result = reg(*_paths(part, "A1"), "--spec", part / "part.toml", "--targets", bad, "--targets-output", corrected,
                 "-o", out)
    _assert_one_line_error(result, "bad.csv", "line 3")
    assert not out.exists() and not corrected.exists()


def test_scan_without_hole(reg, part, tmp_path):
    out = tmp_path / "out.json"
    result = reg(*_paths(part, "A1", "flat"), "--spec", part / "part.toml", "-o", out)
    _assert_one_line_error(result, "flat.ply", "no hole", code=cli.EXIT_NO_HOLE)
    assert not out.exists()


def test_unknown_name_hole(reg, part):
    result = reg(*_paths(part, "A1"), "--spec", part / "part.toml", "--name", "A1=B7")
    _assert_one_line_error(result, "B7", code=cli.EXIT_USAGE)


def test_unnamed_single_scan_cannot_be_matched(reg, part, tmp_path):
    scan = tmp_path / "lonely.ply"
    scan.write_bytes((part / "A1.ply").read_bytes())
    _assert_one_line_error(reg(scan, "--spec", part / "part.toml"), "cannot register")


def test_targets_output_needs_targets(reg, part, tmp_path):
    result = reg(*_paths(part, "A1"), "--spec", part / "part.toml", "--targets-output", tmp_path / "c.csv")
    assert result.exit_code == cli.EXIT_USAGE


# --- outputs all or none, never over an input, never into a FIFO nobody reads (issue 23) ---------------

EARLIER_TARGETS = "name,x,y,z,nx,ny,nz,u_x,u_y,u_z,u_normal_deg\nT1,1,2,3,0,0,1,0,0,0,0\n"


def test_result_that_cannot_be_written_leaves_the_earlier_corrected_targets(reg, part, tmp_path):
    # the robot drives from corrected.csv: a run that fails must not have replaced it
    corrected = tmp_path / "corrected.csv"
    corrected.write_text(EARLIER_TARGETS)
    output = tmp_path / "missing" / "registration.json"
    result = reg(*_paths(part, "A1", "A2", "A3"), "--spec", part / "part.toml", "--targets", part / "targets.csv",
                 "--targets-output", corrected, "-o", output)
    _assert_one_line_error(result, output, "cannot write output")
    assert corrected.read_text() == EARLIER_TARGETS
    assert os.listdir(tmp_path) == ["corrected.csv"]  # no temporary left


def test_targets_that_cannot_be_written_print_no_result(reg, part, tmp_path):
    corrected = tmp_path / "missing" / "corrected.csv"
    result = reg(*_paths(part, "A1", "A2", "A3"), "--spec", part / "part.toml", "--targets", part / "targets.csv",
                 "--targets-output", corrected)
    _assert_one_line_error(result, corrected, "cannot write the corrected targets")  # stdout "" checked there


def _inputs_copy(part, tmp_path):
    """The spec, the targets and a scan copied here: these tests try to write over them."""
    for name in ("part.toml", "targets.csv", "A1.ply"):
        shutil.copyfile(part / name, tmp_path / name)
    return tmp_path / "part.toml", tmp_path / "targets.csv", tmp_path / "A1.ply"


@pytest.mark.parametrize("case", ["--targets-output --targets", "--targets-output hard link of --targets",
                                  "-o --spec", "-o symlink to --spec", "-o SCAN", "-o --targets-output"])
def test_an_output_that_is_an_input_or_the_other_output_is_a_usage_error(reg, part, tmp_path, case):
    spec, targets, scan = _inputs_copy(part, tmp_path)
    os.link(targets, tmp_path / "hard.csv")
    (tmp_path / "latest.toml").symlink_to("part.toml")
    both = tmp_path / "both.csv"
    outputs, names = {
        "--targets-output --targets": (["--targets-output", targets], ["--targets-output", "--targets"]),
        "--targets-output hard link of --targets": (["--targets-output", tmp_path / "hard.csv"],
                                                    ["hard.csv", "targets.csv"]),
        "-o --spec": (["--targets-output", tmp_path / "c.csv", "-o", spec], ["-o/--output", "--spec"]),
        "-o symlink to --spec": (["--targets-output", tmp_path / "c.csv", "-o", tmp_path / "latest.toml"],
                                 ["latest.toml", "part.toml"]),
        "-o SCAN": (["--targets-output", tmp_path / "c.csv", "-o", scan], ["-o/--output", "SCAN"]),
        "-o --targets-output": (["--targets-output", both, "-o", both], ["--targets-output", "-o/--output"]),
    }[case]
    before = {name: (tmp_path / name).read_bytes() for name in ("part.toml", "targets.csv", "A1.ply")}
    result = reg(scan, "--spec", spec, "--targets", targets, *outputs)
    _assert_one_line_error(result, *names, code=cli.EXIT_USAGE)
    assert {name: (tmp_path / name).read_bytes() for name in before} == before
    assert not (tmp_path / "c.csv").exists() and not both.exists()


def test_targets_output_into_a_fifo_without_a_reader_is_refused_not_waited_for(holecli_process, part, tmp_path):
    fifo = tmp_path / "robot"
    os.mkfifo(fifo)
    output = tmp_path / "registration.json"
    output.write_text('{"earlier": true}\n')
    # without the check this never ends: the timeout fails the test
    result = holecli_process("register", *_paths(part, "A1", "A2", "A3"), "--spec", part / "part.toml",
                             "--targets", part / "targets.csv", "--targets-output", fifo, "-o", output, timeout=90)
    assert result.returncode == cli.EXIT_INPUT, result.stderr
    assert result.stderr.splitlines() == [f"Error: {fifo}: cannot write the corrected targets: a FIFO that no "
                                          "process reads (refused rather than waiting for a reader)"]
    assert output.read_text() == '{"earlier": true}\n'


def _mirrored_spec_text(names):
    """The spec as drawn from the wrong side: every center and normal mirrored x -> -x."""
    blocks = []
    for name in names:
        (x, y, z), (nx, ny, nz) = LAYOUT[name]
        blocks.append(f'[[hole]]\nname = "{name}"\ncenter = {[-x, y, z]}\nnormal = {[-nx, ny, nz]}\n'
                      'diameter = 3.0\ntolerance = 0.05\n')
    return "\n".join(blocks)


@pytest.mark.parametrize("by", ["names", "distances"])
def test_spec_of_the_mirror_image_is_refused_and_nothing_is_replaced(reg, part, tmp_path, by):
    # Issue 23: the planar holes A1, A2, A4 against their mirror image matched by a turn-over, fitted
    # exactly with every normal pointing down, exit 0. Now refused (exit 3), the outputs left as they were.
    spec = tmp_path / "mirrored.toml"
    spec.write_text(_mirrored_spec_text(["A1", "A2", "A4"]))
    paths = _paths(part, "A1", "A2", "A4")
    if by == "distances":
        paths = []
        for index, name in enumerate(("A2", "A4", "A1")):
            paths.append(tmp_path / f"scan{index}.ply")
            paths[-1].write_bytes((part / f"{name}.ply").read_bytes())
    out, corrected = tmp_path / "out.json", tmp_path / "corrected.csv"
    corrected.write_text("previous\n")
    result = reg(*paths, "--spec", spec, "--max-residual", 0.01, "--targets", part / "targets.csv",
                 "--targets-output", corrected, "-o", out)
    _assert_one_line_error(result, "mirrored.toml: cannot register: normals_reversed", "A1 ", "A2 ", "A4 ",
                           "mirror image")
    assert not out.exists() and corrected.read_text() == "previous\n"
    # the same scans against the spec as drawn: unaffected
    right = tmp_path / "right.toml"
    right.write_text(_spec_text(["A1", "A2", "A4"]))
    result = reg(*paths, "--spec", right, "--max-residual", 0.01)
    assert result.exit_code == cli.EXIT_OK, result.stderr
    record = json.loads(result.stdout)
    assert not any(hole["normal_flipped"] for hole in record["holes"])
    assert _rotation_error_deg(record["transform"]["matrix"]) < 0.01
    assert "normals_reversed" not in result.stderr


def test_verbose_says_each_scan_the_match_and_the_residuals(reg, run, part):
    result = reg(*_paths(part, "A1", "A2", "A3"), "--spec", part / "part.toml", "-v")
    assert result.exit_code == cli.EXIT_OK, result.stderr
    record = json.loads(result.stdout)
    assert result.stderr.count("point spacing") == 3  # each scan's account, as detect -v gives it
    assert "holecli: register: match by names, 3 holes; spec holes not measured: A4, A5" in result.stderr
    for hole in record["holes"]:
        assert (f"holecli:   {hole['name']} = {hole['scan']} hole 0: used; residual "
                f"{hole['residual']['in_plane']:.3g} in plane") in result.stderr
    assert "degrees of freedom left" in result.stderr
    assert "match by" not in reg(*_paths(part, "A1", "A2", "A3"), "--spec", part / "part.toml").stderr
    before = run("-v", "register", *_paths(part, "A1", "A2", "A3"), "--spec", part / "part.toml")
    assert "match by names" in before.stderr
    both = reg(*_paths(part, "A1", "A2"), "--spec", part / "part.toml", "-q", "-v")
    assert both.exit_code == cli.EXIT_USAGE and "--quiet and --verbose cannot be combined" in both.stderr


def test_two_holes_one_moved_warn_widen_and_exit_8(reg, part, tmp_path):
    # issue 25: R2 drilled 0.2 mm off, two holes: exit 0, no warning, targets 0.17 mm off with u 0.4 um
    clean = reg(*_paths(part, "A1", "A3"), "--spec", part / "part.toml")
    assert clean.exit_code == cli.EXIT_OK, clean.stderr
    clean_record = json.loads(clean.stdout)
    assert clean_record["consistency"]["checked"] and clean_record["consistency"]["consistent"]
    corrected = tmp_path / "corrected.csv"
    result = reg(*_paths(part, "A1", "A3_moved"), "--name", "A3_moved.ply=A3", "--spec", part / "part.toml",
                 "--targets", part / "targets.csv", "--targets-output", corrected)
    assert result.exit_code == cli.EXIT_UNDECIDED, result.stderr
    record = json.loads(result.stdout)
    assert [w["code"] for w in record["warnings"]] == ["inconsistent_holes", "unchecked_direction"]
    assert "holecli: warning: register: inconsistent_holes:" in result.stderr and "A1-A3" in result.stderr
    consistency = record["consistency"]
    assert not consistency["consistent"] and consistency["added_sigma"] > 0.02
    pair = consistency["pairs"][0]
    assert pair["holes"] == ["A1", "A3"] and abs(abs(pair["difference"]) - 0.2) < 0.05
    # widened: an added sigma of the discrepancy's size on every hole
    for widened, tight in zip(record["uncertainty"]["translation"], clean_record["uncertainty"]["translation"]):
        assert widened > 10 * tight
    with corrected.open() as handle:
        rows = list(csv.DictReader(handle))
    assert all(float(row["u_x"]) > 0.01 for row in rows)
    with_verdict = reg(*_paths(part, "A1", "A3_moved"), "--name", "A3_moved.ply=A3", "--spec", part / "part.toml",
                       "--max-residual", 0.5)
    assert with_verdict.exit_code == cli.EXIT_OUT_OF_TOLERANCE  # 5 takes precedence over 8
    assert "inconsistent_holes" in json.loads(with_verdict.stdout)["failed"]


def test_three_holes_one_moved_names_it(reg, part):
    # A3 moved 0.14 mm diagonally changes A1-A3 and A2-A3: A1-A2 agree, A3 is named
    result = reg(*_paths(part, "A1", "A2", "A3_diagonal"), "--name", "A3_diagonal.ply=A3", "--spec", part / "part.toml")
    assert result.exit_code == cli.EXIT_UNDECIDED, result.stderr
    record = json.loads(result.stdout)
    assert record["consistency"]["suspects"] == ["A3"]
    assert "A3 is off (A1-A2 agree)" in record["warnings"][0]["message"]
    # A3 moved along x (parallel to A1-A2) changes A1-A3 only: A1 moved along y would do the same
    across = reg(*_paths(part, "A1", "A2", "A3_moved"), "--name", "A3_moved.ply=A3", "--spec", part / "part.toml")
    assert across.exit_code == cli.EXIT_UNDECIDED, across.stderr
    assert "A1 or A3 is off (only their distance disagrees)" in json.loads(across.stdout)["warnings"][0]["message"]
    clean = reg(*_paths(part, "A1", "A2", "A3"), "--spec", part / "part.toml")
    assert clean.exit_code == cli.EXIT_OK and json.loads(clean.stdout)["warnings"] == []


def test_an_outlier_without_max_residual_exits_8(reg, part):
    # four holes: A3 is named and left out; the transform is sound, but the part's reference hole is not
    result = reg(*_paths(part, "A1", "A2", "A3_moved", "A4"), "--name", "A3_moved.ply=A3", "--spec", part / "part.toml")
    assert result.exit_code == cli.EXIT_UNDECIDED, result.stderr
    record = json.loads(result.stdout)
    assert record["outliers"] == ["A3"] and record["consistency"]["consistent"]


def test_two_holes_say_the_direction_nothing_checks(reg, part):
    # whatever the layout, two holes cannot see a hole moved across their line (a rotation about the
    # normal absorbs it): the registration says so instead of a silent exit 0 with a tight u
    two = reg(*_paths(part, "A1", "A3"), "--spec", part / "part.toml")
    record = json.loads(two.stdout)
    assert two.exit_code == cli.EXIT_OK, two.stderr
    assert [w["code"] for w in record["warnings"]] == ["unchecked_direction"]
    assert "holecli: warning: register: unchecked_direction: with two holes, A1 or A3" in two.stderr
    three = reg(*_paths(part, "A1", "A2", "A3"), "--spec", part / "part.toml")
    assert "unchecked_direction" not in three.stderr
