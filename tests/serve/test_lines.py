"""The line protocol over TCP (holecli.serve.lines): its grammar, and a real server on 127.0.0.1."""

import pytest

from holecli.serve.lines import (DECIMALS, MESSAGE_MAX, Auth, Help, LineError, Measure, Ping, Result, Version,
                                 decode_line, format_answer, format_error, hole_verdict, option_value, parse_line,
                                 record_verdict)

# --- the request grammar -------------------------------------------------------------------------------


@pytest.mark.parametrize("line, command", [
    ("PING", Ping()),
    ("ping", Ping()),
    ("  Version\t", Version()),
    ("HELP", Help()),
    ('AUTH "s3cret token"', Auth("s3cret token")),
    ("RESULT 0123456789abcdef0123456789abcdef", Result("0123456789abcdef0123456789abcdef")),
    ("MEASURE scans/a.ply", Measure("scans/a.ply")),
    ("MEASURE scans/a.ply spec=plate registration=cell3 format=xyz part=P-7 serial=S1 cell=3 operator=jd",
     Measure("scans/a.ply", spec="plate", registration="cell3", format="xyz",
             meta={"part": "P-7", "serial": "S1", "cell": "3", "operator": "jd"})),
    # options read as their kinds; keys in any case
    ("MEASURE a.ply MIN_DIAMETER=2.5 view_dir=0,0,-1 full_only=true max_holes=3 units=m",
     Measure("a.ply", options={"min_diameter": 2.5, "view_dir": [0.0, 0.0, -1.0], "full_only": True, "max_holes": 3,
                               "units": "m"})),
    # quotes: spaces, \" and \\ inside them; any other backslash is itself
    ('MEASURE "scans/part 7.ply"', Measure("scans/part 7.ply")),
    (r'MEASURE "a \"b\" c\\d.ply"', Measure('a "b" c\\d.ply')),
    (r'MEASURE "C:\scans\a b.ply"', Measure("C:\\scans\\a b.ply")),
    (r"MEASURE C:\scans\a.ply", Measure("C:\\scans\\a.ply")),
    ('MEASURE dir/"a b".ply operator="Jane Doe"', Measure("dir/a b.ply", meta={"operator": "Jane Doe"})),
    # the path is the first word whatever it holds
    ("MEASURE spec=x.ply", Measure("spec=x.ply")),
])
def test_request_lines_parse_into_their_commands(line, command):
    assert parse_line(line) == command


@pytest.mark.parametrize("line", ["", "   ", "\t"])
def test_a_blank_line_is_no_request(line):
    assert parse_line(line) is None


@pytest.mark.parametrize("line, match", [
    ("FOO", "unknown command 'FOO'"),
    ("MEASUREMENT a.ply", "unknown command"),
    ("MEASURE", "needs a path"),
    ('MEASURE ""', "path is empty"),
    ("MEASURE a.ply b.ply", "expected KEY=VALUE after the path: got 'b.ply'"),
    ('MEASURE a.ply "spec=x"', "expected KEY=VALUE"),
    ("MEASURE a.ply spec=", "spec= has no value"),
    ("MEASURE a.ply spec=a SPEC=b", "spec= given twice"),
    ("MEASURE a.ply part=1 part=2", "part= given twice"),
    ('MEASURE "a.ply', "double quote is not closed"),
    ('MEASURE a.ply operator="Jane', "double quote is not closed"),
    ("RESULT", "RESULT takes one id: got 0"),
    ("RESULT a b", "RESULT takes one id: got 2"),
    ("RESULT a,b", "not an id"),
    ("RESULT " + "a" * 65, "not an id"),
    ("PING now", "PING takes no arguments"),
    ("VERSION 2", "VERSION takes no arguments"),
    ("AUTH", "AUTH takes one token: got 0"),
])
def test_malformed_requests_are_refused_with_400_and_the_reason(line, match):
    with pytest.raises(LineError, match=match) as error:
        parse_line(line)
    assert error.value.status == 400


@pytest.mark.parametrize("name, text, value", [
    ("min_diameter", "0.5", 0.5),
    ("gauge_depth", "1e-1", 0.1),
    ("max_holes", "12", 12),
    ("scan", "0", 0),
    ("full_only", "TRUE", True), ("full_only", "no", False), ("explain", "1", True), ("explain", "false", False),
    ("view_dir", "0,0,-1", [0.0, 0.0, -1.0]),
    ("columns", "x_mm,y_mm,z_mm", ["x_mm", "y_mm", "z_mm"]),
    ("columns", "1,2,3", [1, 2, 3]),
    ("method", "paper", "paper"),
    ("units", "in", "in"),
    # not of their kind: as sent, for the service to refuse by name
    ("min_diameter", "2mm", "2mm"), ("max_holes", "2.5", "2.5"), ("full_only", "maybe", "maybe"),
    ("view_dir", "0,0,down", "0,0,down"),
    ("no_such_option", "1", "1"),
])
def test_options_are_read_as_their_kinds(name, text, value):
    assert option_value(name, text) == value
    assert type(option_value(name, text)) is type(value)


def test_decode_line_takes_utf8_without_its_carriage_return():
    assert decode_line(b"MEASURE \xc3\xa9t\xc3\xa9.ply\r") == "MEASURE été.ply"
    assert decode_line(b"PING") == "PING"
    assert decode_line(b"PING\t") == "PING\t"  # a tab is a space


@pytest.mark.parametrize("raw, match", [
    (b"\xff\xfePING", "not UTF-8"),
    (b"MEASURE a\x00.ply", "control character 0x00"),
    (b"PI\rNG", "control character 0x0d"),
    (b"PING\x1b[A", "control character 0x1b"),
])
def test_decode_line_refuses_garbage_with_400(raw, match):
    with pytest.raises(LineError, match=match) as error:
        decode_line(raw)
    assert error.value.status == 400


# --- the answers ---------------------------------------------------------------------------------------


def _hole(center=(1.5, -2.0, 0.25), diameter=3.0001, normal=(0.0, 0.6, 0.8), **checked):
    return {"center": list(center), "diameter": diameter, "normal": list(normal), **checked}


def test_an_answer_has_a_group_of_eight_fields_per_hole_and_the_records_verdict_last():
    answer = {"id": "ab12", "holes": [_hole(), _hole(center=(10, 20, 30), diameter=4.25, normal=(0, 0, -1))]}
    fields = format_answer(answer).split(",")
    assert fields[:3] == ["OK", "ab12", "2"]
    assert len(fields) == 3 + 8 * 2 + 1
    assert fields[3:11] == ["1.5000", "-2.0000", "0.2500", "3.0001", "0.000000", "0.600000", "0.800000", "unchecked"]
    assert fields[11:19] == ["10.0000", "20.0000", "30.0000", "4.2500", "0.000000", "0.000000", "-1.000000",
                             "unchecked"]
    assert fields[-1] == "unchecked"


def test_no_hole_is_ok_id_0_and_the_verdict():
    assert format_answer({"id": "x1", "holes": []}) == "OK,x1,0,unchecked"
    missing = {"in_tolerance": False, "out_of_tolerance": 0, "undecided": 0, "missing": ["T1"]}
    assert format_answer({"id": "x1", "holes": [], "verdict": missing}) == "OK,x1,0,fail"


def test_lengths_have_fixed_decimals_rounded_and_no_negative_zero():
    answer = {"id": "a", "holes": [_hole(center=(-0.00004, 1 / 3, 2.99996), diameter=2.99994,
                                         normal=(-0.0000004, 0.7071067811865476, 0.7071067811865476))]}
    assert DECIMALS == 4
    assert format_answer(answer).split(",")[3:10] == ["0.0000", "0.3333", "3.0000", "2.9999",
                                                      "0.000000", "0.707107", "0.707107"]


def test_micrometres_are_integers_and_the_normal_integer_millionths():
    answer = {"id": "a", "holes": [_hole(center=(1.5, -2.0, 0.25), diameter=3.0004999, normal=(0.0, 0.6, -0.8))]}
    assert format_answer(answer, units="um") == "OK,a,1,1500,-2000,250,3000,0,600000,-800000,unchecked,unchecked"


@pytest.mark.parametrize("unit, factor", [("mm", 1.0), ("m", 1000.0), ("in", 25.4)])
def test_a_record_that_says_its_unit_is_answered_in_mm(unit, factor):
    hole = _hole(center=(1.0 / factor, 2.0 / factor, 0.0), diameter=3.0 / factor, normal=(0, 0, 1))
    answer = {"id": "a", "units": unit, "holes": [hole]}
    assert format_answer(answer).split(",")[3:7] == ["1.0000", "2.0000", "0.0000", "3.0000"]
    assert format_answer(answer, units="um").split(",")[3:7] == ["1000", "2000", "0", "3000"]


def test_format_answer_refuses_unknown_units():
    with pytest.raises(ValueError, match="units must be one of mm, um"):
        format_answer({"id": "a", "holes": []}, units="inch")
    with pytest.raises(ValueError, match="the record's units 'furlong'"):
        format_answer({"id": "a", "holes": [], "units": "furlong"})


@pytest.mark.parametrize("checked, word", [
    ({}, "unchecked"),                                        # no tolerance given
    ({"in_tolerance": None, "failed_checks": None}, "unchecked"),  # no nominal applies to the hole
    ({"in_tolerance": True, "failed_checks": [], "undecided_checks": []}, "pass"),
    ({"in_tolerance": False, "failed_checks": ["diameter"], "undecided_checks": []}, "fail"),
    ({"in_tolerance": False, "failed_checks": ["diameter"], "undecided_checks": ["position"]}, "fail"),
    ({"in_tolerance": False, "failed_checks": [], "undecided_checks": ["position"]}, "undecided"),
])
def test_a_holes_verdict_word(checked, word):
    assert hole_verdict(_hole(**checked)) == word
    assert format_answer({"id": "a", "holes": [_hole(**checked)]}).split(",")[10] == word


@pytest.mark.parametrize("verdict, word", [
    (None, "unchecked"),
    ({"in_tolerance": True, "out_of_tolerance": 0, "undecided": 0, "missing": []}, "pass"),
    ({"in_tolerance": False, "out_of_tolerance": 1, "undecided": 0, "missing": []}, "fail"),
    ({"in_tolerance": False, "out_of_tolerance": 0, "undecided": 0, "missing": ["B2"]}, "fail"),
    ({"in_tolerance": False, "out_of_tolerance": 0, "undecided": 1, "missing": []}, "undecided"),
])
def test_a_records_verdict_word(verdict, word):
    record = {"id": "a", "holes": []} if verdict is None else {"id": "a", "holes": [], "verdict": verdict}
    assert record_verdict(record) == word


def test_an_error_line_is_one_line_of_three_fields():
    assert format_error(404, "no such file") == "ERR,404,no such file"
    line = format_error(422, "cannot read a,b.ply:\r\n  line 3,\tcolumn 2 \x00bad")
    assert line == "ERR,422,cannot read a;b.ply: line 3; column 2 bad"
    assert format_error(500, "") == "ERR,500,error"
    long = format_error(400, "x" * 1000)
    assert len(long.split(",")[2]) == MESSAGE_MAX and long.endswith("...")
