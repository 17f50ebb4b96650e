"""Decision rules on the command line (ISO 14253-1, issue 14): --decision-rule, --coverage-factor, exit 8.

Real ``robust`` output carries each hole's ``uncertainty``: a nominal equal to the measured diameter
with a one-sided band (``+0.1/-0``) straddles the lower limit, a real end-to-end path to exit 8. The
``paper`` method gives no uncertainty: under the guarded rule its checks are undecided. Where a chosen
uncertainty is needed, ``holecli.tolerance.check`` is wrapped to give each hole one (detect runs
in-process).
"""

import csv
import io
import json

import pytest

from holecli import cli, report, tolerance
from holecli.batch import FileSummary, RecordWriter, Tally
from holecli.cli.exits import exit_code
from holecli.cli.exits import BATCH_EXIT_CODES_HELP, EXIT_CODES_HELP, EXIT_UNDECIDED, EXIT_WARNING
from holecli.io import save_points
from holecli.report import BATCH_CSV_COLUMNS
from holecli.simulation import synth


def _scan(seed, holes=((0.0, 0.0, 2.5),)):
    """About 3,000 points on a 0.1 mm grid, as in test_cli_batch: quick to measure."""
    scene = synth.SceneSpec(holes=tuple(synth.HoleSpec(center=(x, y), diameter=d) for x, y, d in holes),
                            extent=(-2.8, 2.8, -2.8, 2.8) if len(holes) < 2 else (-6.0, 6.0, -3.5, 3.5),
                            spacing=0.1, rotation_deg=(10.0, 5.0, 7.0 * seed), translation=(seed, 2.0, 3.0))
    return synth.make_scan(scene, seed)


@pytest.fixture(scope="module")
def scan(tmp_path_factory):
    """One 2.5 mm through hole: (path, measured diameter)."""
    path = tmp_path_factory.mktemp("decisions") / "one.ply"
    save_points(path, _scan(0).points)
    return path


@pytest.fixture(scope="module")
def two_holes(tmp_path_factory):
    """A 2.5 mm and a 3.0 mm through hole."""
    path = tmp_path_factory.mktemp("decisions") / "two.ply"
    save_points(path, _scan(1, holes=((-3.0, 0.0, 2.5), (3.0, 0.0, 3.0))).points)
    return path


@pytest.fixture(scope="module")
def measured(scan):
    """The measured diameter of ``scan``'s hole (by the same CLI, no tolerances)."""
    from click.testing import CliRunner

    result = CliRunner().invoke(cli.main, ["detect", str(scan)])
    return json.loads(result.stdout)["holes"][0]["diameter"]


@pytest.fixture
def with_uncertainty(monkeypatch):
    """Call with ``u`` (a standard uncertainty of the diameter): every record checked afterwards gives
    each hole ``uncertainty.diameter = u`` (and u for the position), as the other engineer's code will."""
    original = tolerance.check

    def give(u):
        def check(record, spec):
            holes = [dict(hole, uncertainty={"center_in_plane": u, "center_along_normal": None, "diameter": u,
                                             "normal_deg": None, "countersink": None, "counterbore": None,
                                             "bore": None, "axis_deg": None, "perpendicularity_deg": None})
                     for hole in record["holes"]]
            return original(dict(record, holes=holes), spec)

        monkeypatch.setattr(tolerance, "check", check)

    return give


def _detect(run, path, *options):
    result = run("detect", path, *options)
    return result, json.loads(result.stdout) if result.stdout.startswith("{") else None


def test_exit_8_is_documented_in_both_helps():
    assert "  8  undecided (--decision-rule guarded)" in EXIT_CODES_HELP
    assert "  8    --decision-rule guarded" in BATCH_EXIT_CODES_HELP
    assert cli.EXIT_UNDECIDED == EXIT_UNDECIDED == 8


def test_simple_is_the_default_and_reports_u(run, scan, measured):
    result, record = _detect(run, scan, "--nominal-diameter", measured, "--tolerance", "+0.1/-0")
    assert result.exit_code == cli.EXIT_OK, result.stderr
    hole = record["holes"][0]
    entry = hole["conformance"]["diameter"]
    assert entry["decision"] == "pass"
    assert entry["expanded_uncertainty"] == pytest.approx(2.0 * hole["uncertainty"]["diameter"])
    assert (record["verdict"]["decision_rule"], record["verdict"]["coverage_factor"]) == ("simple", 2.0)
    assert record["options"]["tolerances"]["decision_rule"] == "simple"


def test_guarded_with_the_measured_uncertainty_straddling_a_limit_is_undecided_exit_8(run, scan, measured):
    result, record = _detect(run, scan, "--nominal-diameter", measured, "--tolerance", "+0.1/-0",
                             "--decision-rule", "guarded")
    assert result.exit_code == EXIT_UNDECIDED, result.stderr
    hole = record["holes"][0]
    assert hole["uncertainty"]["diameter"] > 0
    assert hole["conformance"]["diameter"]["reason"] == "straddles_lower"
    assert "holecli: undecided: 1 of 1 checked holes (guarded, k=2: conformance not proved)" in result.stderr
    # the same hole against a band its interval clears passes
    result, record = _detect(run, scan, "--nominal-diameter", measured, "--tolerance", "0.1",
                             "--decision-rule", "guarded")
    assert result.exit_code == cli.EXIT_OK, result.stderr
    assert record["holes"][0]["conformance"]["diameter"]["reason"] == "inside_with_uncertainty"


def test_guarded_without_an_uncertainty_is_undecided_exit_8(run, scan, measured):
    # the paper method gives no uncertainty
    result, record = _detect(run, scan, "--method", "paper", "--nominal-diameter", measured, "--tolerance", "0.1",
                             "--decision-rule", "guarded", "--coverage-factor", "3")
    assert result.exit_code == EXIT_UNDECIDED, result.stderr
    hole = record["holes"][0]
    assert hole["conformance"]["diameter"]["reason"] == "uncertainty_unknown"
    assert hole["undecided_checks"] == ["diameter"] and hole["failed_checks"] == [] and hole["in_tolerance"] is False
    assert record["verdict"] == {"checked": 1, "out_of_tolerance": 0, "undecided": 1, "missing": [],
                                 "in_tolerance": False, "decision_rule": "guarded", "coverage_factor": 3.0}
    assert record["options"]["tolerances"]["coverage_factor"] == 3.0
    assert (f"holecli: undecided: 1 of 1 checked holes, 1 with an uncertainty not known (guarded, k=3: "
            f"conformance not proved) in {scan}") in result.stderr
    assert "out of tolerance" not in result.stderr
    quiet = run("detect", scan, "--method", "paper", "--nominal-diameter", measured, "--tolerance", "0.1",
                "--decision-rule", "guarded", "-q")
    assert quiet.exit_code == EXIT_UNDECIDED and quiet.stderr == ""


def test_guarded_records_are_valid_under_the_schema(run, scan, measured):
    jsonschema = pytest.importorskip("jsonschema")
    from holecli.schema import record_schema

    _, record = _detect(run, scan, "--nominal-diameter", measured, "--tolerance", "0.1", "--decision-rule",
                        "guarded", "--bore-diameter", "2.5", "--bore-diameter-tolerance", "0.1")
    assert record["holes"][0]["conformance"]["bore_diameter"]["reason"] == "not_measured"
    jsonschema.Draft202012Validator(record_schema("detect_record")).validate(record)


@pytest.mark.parametrize(
    "offset, u, code, decision",
    [
        (0.05, 0.002, cli.EXIT_OK, "pass"),  # 0.05 +- 0.004 inside [0, +0.1]
        (0.001, 0.002, EXIT_UNDECIDED, "undecided"),  # 0.001 +- 0.004 straddles the lower limit 0
        (-0.01, 0.002, cli.EXIT_OUT_OF_TOLERANCE, "fail"),  # -0.01 +- 0.004 wholly below
    ],
)
def test_guarded_with_a_known_uncertainty(run, scan, measured, with_uncertainty, offset, u, code, decision):
    with_uncertainty(u)
    # nominal = measured - offset: the deviation is offset, against +0.1/-0
    result, record = _detect(run, scan, "--nominal-diameter", measured - offset, "--tolerance", "+0.1/-0",
                             "--decision-rule", "guarded")
    assert result.exit_code == code, result.stderr
    entry = record["holes"][0]["conformance"]["diameter"]
    assert entry["value"] == pytest.approx(offset, abs=1e-9)
    assert entry["expanded_uncertainty"] == pytest.approx(2 * u)
    assert entry["decision"] == decision
    simple, _ = _detect(run, scan, "--nominal-diameter", measured - offset, "--tolerance", "+0.1/-0")
    assert simple.exit_code == (cli.EXIT_OUT_OF_TOLERANCE if offset < 0 else cli.EXIT_OK)


@pytest.mark.parametrize("k, code", [("1", cli.EXIT_OK), ("3", EXIT_UNDECIDED)])
def test_the_coverage_factor_changes_the_exit_code(run, scan, measured, with_uncertainty, k, code):
    with_uncertainty(0.002)
    # deviation 0.005: 0.005 - 0.002 >= 0 at k = 1, 0.005 - 0.006 < 0 at k = 3
    result, record = _detect(run, scan, "--nominal-diameter", measured - 0.005, "--tolerance", "+0.1/-0",
                             "--decision-rule", "guarded", "--coverage-factor", k)
    assert result.exit_code == code, result.stderr


def test_5_takes_precedence_over_8(run, two_holes, with_uncertainty):
    with_uncertainty(0.03)
    # the 2.5 mm hole: 0 +- 0.06 straddles +-0.05 (undecided); the 3.0 mm hole: 0.5 - 0.06 > 0.05 (fail)
    result, record = _detect(run, two_holes, "--nominal-diameter", "2.5", "--tolerance", "0.05",
                             "--decision-rule", "guarded")
    assert result.exit_code == cli.EXIT_OUT_OF_TOLERANCE, result.stderr
    assert sorted(hole["conformance"]["diameter"]["decision"] for hole in record["holes"]) == ["fail", "undecided"]
    assert (record["verdict"]["out_of_tolerance"], record["verdict"]["undecided"]) == (1, 1)
    assert f"holecli: out of tolerance: 1 of 2 checked holes, 1 undecided in {two_holes}" in result.stderr
    assert "holecli: undecided" not in result.stderr


def test_5_over_8_for_a_check_not_measured(run, scan, measured):
    # the diameter undecided (its interval straddles the lower limit), the bore of a through hole not
    # measured: a fail under either rule
    result, record = _detect(run, scan, "--nominal-diameter", measured, "--tolerance", "+0.1/-0", "--decision-rule",
                             "guarded", "--bore-diameter", "2.5", "--bore-diameter-tolerance", "0.1")
    assert result.exit_code == cli.EXIT_OUT_OF_TOLERANCE
    hole = record["holes"][0]
    assert hole["failed_checks"] == ["bore_diameter_not_measured"] and hole["undecided_checks"] == ["diameter"]


def test_8_takes_precedence_over_7(run, tmp_path):
    # reflections inside the hole: the warning points_inside, which --fail-on-warning any selects
    scene = synth.SceneSpec(holes=(synth.HoleSpec(center=(0.0, 0.0), diameter=2.5, inside_points=100),),
                            extent=(-2.8, 2.8, -2.8, 2.8), spacing=0.1, rotation_deg=(10.0, 5.0, 0.0),
                            translation=(0.0, 2.0, 3.0))
    scan = tmp_path / "reflections.ply"
    save_points(scan, synth.make_scan(scene, 0).points)
    [hole] = json.loads(run("detect", scan).stdout)["holes"]
    assert "points_inside" in [warning["code"] for warning in hole["warnings"]]
    options = ("--nominal-diameter", hole["diameter"], "--tolerance", "+0.1/-0", "--fail-on-warning", "any")
    assert run("detect", scan, *options).exit_code == EXIT_WARNING
    assert run("detect", scan, *options, "--decision-rule", "guarded").exit_code == EXIT_UNDECIDED


def test_a_note_is_no_warning(run, scan, measured):
    # the through hole's bore_not_seen and axis_not_measured are notes: --fail-on-warning any passes
    options = ("--nominal-diameter", measured, "--tolerance", "+0.1/-0", "--fail-on-warning", "any")
    assert run("detect", scan, *options).exit_code == cli.EXIT_OK


@pytest.mark.parametrize("command", ["detect", "batch"])
@pytest.mark.parametrize("value", ["0", "-1", "nan", "inf", "two"])
def test_an_invalid_coverage_factor_is_a_usage_error(run, scan, command, value):
    result = run(command, scan, "--nominal-diameter", "2.5", "--tolerance", "0.1", "--coverage-factor", value)
    assert result.exit_code == cli.EXIT_USAGE
    errors = [line for line in result.stderr.splitlines() if line.startswith("Error")]
    assert len(errors) == 1 and "--coverage-factor" in errors[0], result.stderr
    assert "Traceback" not in result.stderr and result.stdout == ""


@pytest.mark.parametrize("command", ["detect", "batch"])
@pytest.mark.parametrize("options, named", [(("--decision-rule", "guarded"), "--decision-rule needs"),
                                            (("--coverage-factor", "2"), "--coverage-factor needs"),
                                            (("--decision-rule", "simple", "--coverage-factor", "2"),
                                             "--decision-rule and --coverage-factor need")])
def test_the_decision_options_need_tolerances(run, scan, command, options, named):
    result = run(command, scan, *options)
    assert result.exit_code == cli.EXIT_USAGE
    assert f"{named} tolerance options or --spec" in result.stderr


def test_an_unknown_decision_rule_is_a_usage_error(run, scan):
    result = run("detect", scan, "--nominal-diameter", "2.5", "--tolerance", "0.1", "--decision-rule", "strict")
    assert result.exit_code == cli.EXIT_USAGE and "'strict' is not one of 'simple', 'guarded'" in result.stderr


def test_the_table_shows_each_check_with_its_limits_u_and_decision(run, scan, measured, with_uncertainty):
    with_uncertainty(0.002)
    result = run("detect", scan, "--format", "table", "--nominal-diameter", measured - 0.001, "--tolerance",
                 "+0.1/-0", "--decision-rule", "guarded")
    assert result.exit_code == EXIT_UNDECIDED
    text = " ".join(result.stdout.replace("│", " ").split())
    assert "UNDECIDED: diameter" in text
    assert "diameter +0.001 in [+0, +0.1] U 0.004: undecided" in text
    assert "UNDECIDED: 1 checked, 0 out, 1 undecided (guarded rule, k=2)" in text


def test_the_table_cell_lists_the_conformance_of_every_check():
    from holecli.cli.render import verdict_cell

    conformance = {
        "diameter": {"value": -0.0031, "lower": 0.0, "upper": 0.036, "expanded_uncertainty": 0.004,
                     "decision": "fail", "reason": "outside"},
        "position": {"value": 0.061, "lower": None, "upper": 0.1, "expanded_uncertainty": None,
                     "decision": "undecided", "reason": "uncertainty_unknown"},
        "bore_diameter": {"value": None, "lower": -0.05, "upper": 0.05, "expanded_uncertainty": None,
                          "decision": "fail", "reason": "not_measured"},
    }
    hole = {"name": "A1", "in_tolerance": False, "diameter_deviation": -0.0031,
            "failed_checks": ["diameter", "bore_diameter_not_measured"], "undecided_checks": ["position"],
            "conformance": conformance}
    assert verdict_cell(hole).splitlines() == [
        "A1: OUT: diameter -0.0031, bore_diameter not measured; undecided: position",
        "diameter -0.0031 in [+0, +0.036] U 0.004: fail",
        "position 0.061 <= 0.1 U -: undecided",
        "bore_diameter not measured in [-0.05, +0.05] U -: fail",
    ]


def test_csv_has_the_conformance_and_the_decision_rule(run, scan, measured):
    result = run("detect", scan, "--format", "csv", "--nominal-diameter", measured, "--tolerance", "+0.1/-0",
                 "--decision-rule", "guarded", "--coverage-factor", "2.5")
    assert result.exit_code == EXIT_UNDECIDED
    rows = list(csv.reader(io.StringIO(result.stdout)))
    assert rows[0] == list(report.CSV_COLUMNS)
    row = dict(zip(report.CSV_COLUMNS, rows[1]))
    assert (row["in_tolerance"], row["failed_checks"], row["undecided_checks"]) == ("false", "", "diameter")
    assert json.loads(row["conformance"])["diameter"]["decision"] == "undecided"
    assert (row["decision_rule"], row["coverage_factor"]) == ("guarded", "2.5")


def test_batch_guarded_without_an_uncertainty_exits_8(run, scan, tmp_path):
    output = tmp_path / "out.csv"
    result = run("batch", scan, "--method", "paper", "--nominal-diameter", "2.5", "--tolerance", "0.1",
                 "--decision-rule", "guarded", "--format", "csv", "-o", output)
    assert result.exit_code == EXIT_UNDECIDED, result.stderr
    assert ("parts rejected: 0 of 1, undecided: 1; holes out of tolerance: 0, undecided: 1, nominal holes "
            "missing: 0") in result.stderr
    # a resumed CSV counts the undecided hole as undecided, not as out of tolerance
    rows = [dict(zip(BATCH_CSV_COLUMNS, row)) for row in list(csv.reader(io.StringIO(output.read_text())))[1:]]
    summary = FileSummary.of_csv_rows(str(scan), rows)
    assert (summary.out_of_tolerance, summary.undecided) == (0, 1)
    resumed = run("batch", scan, "--method", "paper", "--nominal-diameter", "2.5", "--tolerance", "0.1",
                  "--decision-rule", "guarded", "--format", "csv", "-o", output, "--resume")
    assert resumed.exit_code == EXIT_UNDECIDED, resumed.stderr


def test_batch_5_over_8_over_6(run, scan, measured, tmp_path):
    plain = tmp_path / "plain.ply"
    save_points(plain, _scan(5, holes=()).points)
    broken = tmp_path / "empty.csv"
    broken.write_text("")
    guarded = ("--method", "paper", "--nominal-diameter", "2.5", "--tolerance", "0.1", "--decision-rule", "guarded")
    assert run("batch", scan, broken, *guarded).exit_code == EXIT_UNDECIDED  # 8 before 6
    assert run("batch", scan, broken, "--nominal-diameter", "2.5", "--tolerance", "0.1").exit_code == \
        cli.EXIT_FILE_FAILED  # simple: in tolerance, a file failed
    # robust: the hole's interval straddles the lower limit (undecided), the plain scan's hole is missing
    straddling = ("--nominal-diameter", measured, "--tolerance", "+0.1/-0", "--decision-rule", "guarded")
    assert run("batch", scan, *straddling).exit_code == EXIT_UNDECIDED
    assert run("batch", scan, plain, *straddling).exit_code == cli.EXIT_OUT_OF_TOLERANCE  # missing: 5 before 8


@pytest.mark.parametrize(
    "counts, warnings, code",
    [
        ({"undecided": 1}, None, EXIT_UNDECIDED),
        ({"undecided": 1, "out_of_tolerance": 1}, None, cli.EXIT_OUT_OF_TOLERANCE),
        ({"undecided": 1, "missing": 1}, None, cli.EXIT_OUT_OF_TOLERANCE),
        ({"undecided": 1, "failed": 1}, None, EXIT_UNDECIDED),
        ({"undecided": 1, "without_hole": 1}, None, EXIT_UNDECIDED),
        ({"undecided": 1}, frozenset({"any"}), EXIT_UNDECIDED),
        ({}, frozenset({"any"}), EXIT_WARNING),
    ],
)
def test_batch_exit_code_order(counts, warnings, code):
    tally = Tally(**counts, warning_codes={"rim_gap": 1})
    assert exit_code(tally, warnings) == code


def test_the_csv_summary_of_an_undecided_record_matches_the_record():
    calls = []
    record = {"file": "g.ply", "holes": [
        {"index": 0, "center": [0, 0, 0], "diameter": 3.0, "normal": [0, 0, 1], "in_tolerance": False,
         "failed_checks": [], "undecided_checks": ["diameter"]},
        {"index": 1, "center": [9, 0, 0], "diameter": 3.0, "normal": [0, 0, 1], "in_tolerance": False,
         "failed_checks": ["diameter"], "undecided_checks": ["position"]}],
        "verdict": {"checked": 2, "out_of_tolerance": 1, "undecided": 1, "missing": [], "in_tolerance": False}}
    RecordWriter(calls.append, "csv", header=False).write(record)
    rows = [dict(zip(BATCH_CSV_COLUMNS, row)) for row in csv.reader(io.StringIO(calls[0]))]
    assert FileSummary.of_csv_rows("g.ply", rows) == FileSummary.of_record(record)


def test_the_h9_example_of_issue_14_is_undecided_in_guarded_mode(run, repo_root):
    """The exact Table I grid: a 3.000 hole measured 2.9969; H9 (+0.036/-0) fails it on the value alone
    (simple) but its interval straddles the lower limit (guarded: undecided, exit 8)."""
    scan = repo_root / "sample_clouds" / "table1.ply"
    options = ("--nominal-diameter", "3", "--tolerance", "+0.036/-0")
    simple = run("detect", scan, *options)
    assert simple.exit_code == cli.EXIT_OUT_OF_TOLERANCE
    guarded = run("detect", scan, *options, "--decision-rule", "guarded")
    assert guarded.exit_code == EXIT_UNDECIDED, guarded.stderr
    entry = json.loads(guarded.stdout)["holes"][0]["conformance"]["diameter"]
    assert (entry["decision"], entry["reason"]) == ("undecided", "straddles_lower")


def test_guarded_says_on_stderr_a_check_that_can_never_pass(run):
    import os

    table1 = os.path.join(os.path.dirname(__file__), "..", "..", "sample_clouds", "table1.ply")
    options = ["--nominal-diameter", "3", "--tolerance", "0.002"]  # zone 0.004, U(d) 0.0095
    result = run("detect", table1, *options, "--decision-rule", "guarded")
    assert result.exit_code in (cli.EXIT_UNDECIDED, cli.EXIT_OUT_OF_TOLERANCE)
    line = next(line for line in result.stderr.splitlines() if "uncertainty_exceeds_tolerance" in line)
    assert line.startswith("holecli: note: ") and "hole 0: uncertainty_exceeds_tolerance: diameter: 2U = 0.019" in line
    record = json.loads(result.stdout)
    assert "uncertainty_exceeds_tolerance" in [note["code"] for note in record["holes"][0]["notes"]]
    assert "uncertainty_exceeds_tolerance" not in run("detect", table1, *options).stderr
    assert run("detect", table1, *options, "--decision-rule", "guarded", "-q").stderr == ""


def test_batch_says_on_stderr_a_check_that_can_never_pass(run):
    import os

    table1 = os.path.join(os.path.dirname(__file__), "..", "..", "sample_clouds", "table1.ply")
    options = ["--nominal-diameter", "3", "--tolerance", "0.002"]  # zone 0.004, U(d) 0.0095
    result = run("batch", table1, *options, "--decision-rule", "guarded")
    line = next(line for line in result.stderr.splitlines() if "uncertainty_exceeds_tolerance" in line)
    assert line.startswith("holecli: note: ") and "uncertainty_exceeds_tolerance: diameter: 2U = 0.019" in line
    assert "uncertainty_exceeds_tolerance" not in run("batch", table1, *options).stderr
    assert "uncertainty_exceeds_tolerance" not in run("batch", table1, *options, "--decision-rule", "guarded",
                                                      "-q").stderr
