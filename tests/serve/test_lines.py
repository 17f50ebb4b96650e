"""The line protocol over TCP (holecli.serve.lines): its grammar, and a real server on 127.0.0.1."""

import asyncio
import json
import os
import re
import shutil
import signal
import socket
import struct
import subprocess
import sys
import threading
import time
from types import SimpleNamespace

import pytest

import holecli
from holecli.serve.lines import (DECIMALS, MESSAGE_MAX, Auth, Help, LineError, Measure, Ping, Result, Version,
                                 decode_line, format_answer, format_error, option_value, parse_line)
from holecli.serve.lines import close_lines, serve_lines
from holecli.serve.service import Service
from holecli.store import open_store

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


_PIECES = ["MEASURE", "measure", "RESULT", "PING", "VERSION", "HELP", "AUTH", "spec=", "part=", "view_dir=",
           "min_diameter=", '"', "\\", '\\"', "=", ",", " ", "\t", "\r", "a.ply", "é", "\u2028", "0", "-1", "x" * 70]


def _random_line(rng):
    return "".join(rng.choice(_PIECES, size=rng.integers(0, 12)))


def test_any_line_parses_into_a_command_or_a_400(rng):
    for _ in range(3000):
        raw = _random_line(rng).encode("utf-8") if rng.random() < 0.8 else rng.bytes(rng.integers(0, 40))
        raw = raw.replace(b"\n", b"")
        try:
            command = parse_line(decode_line(raw))
        except LineError as error:
            assert error.status == 400
            line = format_error(error.status, error.message)
            assert len(line.split(",")) == 3 and "\n" not in line and "\r" not in line, line
        else:
            assert command is None or isinstance(command, (Measure, Result, Ping, Version, Help, Auth))


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
    # the words of holecli.store.schema.hole_verdict_word (the store's and OPC UA's too)
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
    assert format_answer(record).split(",")[-1] == word


def test_an_error_line_is_one_line_of_three_fields():
    assert format_error(404, "no such file") == "ERR,404,no such file"
    line = format_error(422, "cannot read a,b.ply:\r\n  line 3,\tcolumn 2 \x00bad")
    assert line == "ERR,422,cannot read a;b.ply: line 3; column 2 bad"
    assert format_error(500, "") == "ERR,500,error"
    long = format_error(400, "x" * 1000)
    assert len(long.split(",")[2]) == MESSAGE_MAX and long.endswith("...")


# --- a real server on 127.0.0.1, a real service (one warm worker, a SQLite store) ------------------------

# The line protocol's answers come from a real Service on an event loop of its own thread; the tests are
# its clients, with blocking sockets as a robot's.


class Loop:
    """An event loop running in a thread, for the servers and the service."""

    def __init__(self):
        self.loop = asyncio.new_event_loop()
        self.thread = threading.Thread(target=self.loop.run_forever, name="lines-test-loop", daemon=True)
        self.thread.start()

    def run(self, coroutine, timeout=60):
        return asyncio.run_coroutine_threadsafe(coroutine, self.loop).result(timeout)

    def close(self):
        self.loop.call_soon_threadsafe(self.loop.stop)
        self.thread.join(10)
        self.loop.close()


class Client:
    """A blocking TCP client of the line protocol."""

    def __init__(self, port, timeout=60.0):
        self.sock = socket.create_connection(("127.0.0.1", port), timeout=timeout)
        self.buffer = b""

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def close(self):
        self.sock.close()

    def send(self, data: bytes):
        self.sock.sendall(data)

    def line(self) -> str:
        """The next answer line, without its \\r\\n ('' at the end of the connection)."""
        while b"\r\n" not in self.buffer:
            chunk = self.sock.recv(65536)
            if not chunk:
                rest, self.buffer = self.buffer, b""
                assert rest == b"", rest
                return ""
            self.buffer += chunk
        line, self.buffer = self.buffer.split(b"\r\n", 1)
        return line.decode("utf-8")

    def ask(self, request: str) -> str:
        self.send(request.encode("utf-8") + b"\n")
        return self.line()

    def closed(self) -> bool:
        """Whether the server ended the connection (after every answer was read)."""
        return self.line() == ""


def ask(port, request):
    with Client(port) as client:
        return client.ask(request)


@pytest.fixture(scope="module")
def cell(tmp_path_factory, repo_root):
    """A service reading scans/ (table1.ply, panel.ply, broken.ply) with the spec "panel", a SQLite store,
    and line servers on free ports: ``port`` (mm), ``um_port`` (micrometres), ``token_port`` (token
    "a-token-of-16-chars+"), ``tight_port`` (line_timeout and idle_timeout 0.5 s)."""
    tmp = tmp_path_factory.mktemp("lines")
    scans, specs = tmp / "scans", tmp / "specs"
    scans.mkdir()
    specs.mkdir()
    for name in ("table1.ply", "panel.ply"):
        shutil.copy(repo_root / "sample_clouds" / name, scans / name)
    (scans / "broken.ply").write_bytes(b"ply\nformat nonsense\n\x00\x01")
    (scans / "with space.ply").write_bytes((repo_root / "sample_clouds" / "table1.ply").read_bytes())
    shutil.copy(repo_root / "sample_clouds" / "panel_tolerances.toml", specs / "panel.toml")
    service = Service(open_store(tmp / "s.sqlite"), workers=1, allow_dirs=[str(scans)], spec_dir=str(specs),
                      request_timeout=60, metrics=False)
    loop = None
    servers = []
    try:
        service.warm()
        loop = Loop()

        def start(**settings):
            server = loop.run(serve_lines(service, "127.0.0.1", 0, **settings))
            servers.append(server)
            return server.sockets[0].getsockname()[1]

        yield SimpleNamespace(service=service, loop=loop, scans=scans, outside=tmp, port=start(),
                              um_port=start(units="um"), token_port=start(token=TOKEN),
                              tight_port=start(line_timeout=0.5, idle_timeout=0.5))
    finally:
        if loop is not None:
            for server in servers:
                loop.run(close_lines(server, timeout=5))
            loop.close()
        service.close()


TOKEN = "a-token-of-16-chars+"
_ID = re.compile(r"[0-9a-f]{32}\Z")


def _fields(line):
    return line.split(",")


def test_measure_answers_the_hole_of_table1_and_result_answers_it_again(cell):
    with Client(cell.port) as client:
        line = client.ask("MEASURE table1.ply part=P-7 serial=S-0001 cell=3 operator=jd")
        fields = _fields(line)
        assert fields[0] == "OK" and _ID.match(fields[1]), line
        assert fields[2] == "1" and len(fields) == 3 + 8 + 1
        x, y, z, d, nx, ny, nz = (float(value) for value in fields[3:10])
        assert d == pytest.approx(3.0, abs=0.01)
        assert (x, y, z) == pytest.approx((3.6498, 5.1392, 5.5300), abs=2e-3)
        assert (nx, ny, nz) == pytest.approx((0.181243, -0.497961, 0.848048), abs=1e-5)
        assert all(len(value.split(".")[1]) == 4 for value in fields[3:7])
        assert all(len(value.split(".")[1]) == 6 for value in fields[7:10])
        assert fields[10:] == ["unchecked", "unchecked"]
        # the same answer again, from the store, on this connection and on another
        assert client.ask(f"RESULT {fields[1]}") == line
    assert ask(cell.port, f"result {fields[1]}") == line
    stored = cell.loop.run(cell.service.result(fields[1]))
    assert stored["meta"] == {"part": "P-7", "serial": "S-0001", "cell": "3", "operator": "jd"}
    assert stored["file"] == "table1.ply"


def test_micrometres_are_integers(cell):
    fields = _fields(ask(cell.um_port, 'MEASURE "with space.ply" min_diameter=1'))
    assert fields[0] == "OK" and fields[2] == "1", fields
    assert all(re.fullmatch(r"-?\d+", value) for value in fields[3:10])
    assert int(fields[6]) == pytest.approx(3000, abs=10)
    assert int(fields[9]) == pytest.approx(848048, abs=10)


def test_the_record_in_another_unit_is_answered_in_mm(cell):
    # the file declared in metres and the record asked for in metres: 3 "m" of diameter are 3000 mm
    fields = _fields(ask(cell.port, "MEASURE table1.ply units=m output_units=m"))
    assert fields[0] == "OK", fields
    assert float(fields[6]) == pytest.approx(3000.0, abs=10)


def test_measure_with_a_spec_gives_each_holes_verdict_and_the_records(cell):
    fields = _fields(ask(cell.port, "MEASURE panel.ply spec=panel part=PANEL"))
    assert fields[:1] == ["OK"] and fields[2] == "4", fields
    assert len(fields) == 3 + 8 * 4 + 1
    assert [fields[3 + 8 * index + 7] for index in range(4)] == ["pass"] * 4
    assert fields[-1] == "pass"


def test_ping_version_help(cell):
    with Client(cell.port) as client:
        assert client.ask("PING") == "OK,PONG"
        assert client.ask("VERSION") == f"OK,{holecli.__version__}"
        assert client.ask("HELP") == "OK,MEASURE,RESULT,PING,VERSION,HELP,AUTH"
        assert client.ask("AUTH anything") == "OK,AUTH"  # a server without a token takes any


@pytest.mark.parametrize("request_line, status, words", [
    ("MEASURE nothing_here.ply", 404, "file not found"),
    ("MEASURE /etc/passwd", 403, "outside the folders"),
    ("MEASURE ../s.sqlite", 400, "'..'"),
    ("MEASURE broken.ply", 422, "broken.ply"),
    ("MEASURE table1.ply spec=nonesuch", 404, "nonesuch"),
    ("MEASURE table1.ply min_diameter=2mm", 400, "min_diameter"),
    ("MEASURE table1.ply colour=red", 400, "colour"),
    ("MEASURE table1.ply format=docx", 400, "format"),
    ("RESULT 0123456789abcdef0123456789abcdef", 404, "not in the store"),
    ("DANCE", 400, "unknown command 'DANCE'"),
    ("MEASURE", 400, "needs a path"),
])
def test_refusals_are_err_lines_with_the_services_status(cell, request_line, status, words):
    line = ask(cell.port, request_line)
    assert line.startswith(f"ERR,{status},"), line
    assert len(_fields(line)) == 3 and words in line


def test_requests_sent_at_once_are_answered_in_order_and_crlf_is_taken(cell):
    with Client(cell.port) as client:
        client.send(b"PING\r\nVERSION\n\n   \r\nDANCE\r\nPING\n")
        assert [client.line() for _ in range(4)] == ["OK,PONG", f"OK,{holecli.__version__}",
                                                     "ERR,400,unknown command 'DANCE' (expected MEASURE RESULT PING "
                                                     "VERSION HELP AUTH)", "OK,PONG"]


def _alive(port):
    assert ask(port, "PING") == "OK,PONG"


@pytest.mark.parametrize("garbage", [
    b"\xff\xfe\x00\x01garbage\n",
    b"PING\x00\n",
    bytes(byte for byte in range(256) if byte != 10) + b"\n",
    b"\xc3\x28\r\n",
])
def test_garbage_is_answered_400_and_the_connection_goes_on(cell, garbage):
    with Client(cell.port) as client:
        client.send(garbage)
        line = client.line()
        assert line.startswith("ERR,400,"), line
        assert client.ask("PING") == "OK,PONG"
    _alive(cell.port)


def test_random_lines_get_an_ok_or_a_4xx_never_a_5xx(cell, rng):
    lines = [_random_line(rng).replace("\r", "").encode("utf-8") for _ in range(300)]
    requests = [line for line in lines if line.strip(b" \t")]  # a blank line is not answered
    with Client(cell.port) as client:
        client.send(b"\n".join(lines) + b"\n")
        answers = [client.line() for _ in requests]
        assert client.ask("PING") == "OK,PONG"
    assert all(re.match(r"(OK,|ERR,4\d\d,)", answer) for answer in answers), \
        [(request, answer) for request, answer in zip(requests, answers) if not re.match(r"(OK,|ERR,4)", answer)]
    _alive(cell.port)


def test_a_1mb_line_is_answered_413_and_the_connection_closed(cell):
    with Client(cell.port) as client:
        client.send(b"MEASURE " + b"a" * 2**20 + b"\n")
        assert client.line() == "ERR,413,line too long (at most 65536 bytes)"
        assert client.closed()
    with Client(cell.port) as client:  # without a newline at all
        client.send(b"x" * (2**20))
        assert client.line().startswith("ERR,413,")
        assert client.closed()
    _alive(cell.port)


def test_a_line_of_max_line_bytes_is_still_read(cell):
    line = ask(cell.port, "MEASURE " + "a" * (65536 - len("MEASURE ")))
    assert line.startswith("ERR,404,") or line.startswith("ERR,400,"), line  # read, and refused by the service


def test_half_lines_and_dropped_connections_leave_the_server_answering(cell):
    with Client(cell.port) as client:
        client.send(b"MEASURE table1.p")  # a half line, then the end
    _alive(cell.port)
    with Client(cell.port) as client:
        client.send(b"PING\nPIN")
        assert client.line() == "OK,PONG"
        client.sock.shutdown(socket.SHUT_WR)
        assert client.closed()  # the half line is dropped unanswered
    clients = [Client(cell.port) for _ in range(50)]
    for index, client in enumerate(clients):
        if index % 3 == 0:
            client.send(b"MEASURE half")
        elif index % 3 == 1:
            client.send(b"PING\n")
    for client in clients:
        client.sock.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))  # a reset
        client.close()
    _alive(cell.port)


def test_slow_and_silent_clients_are_closed_with_408(cell):
    with Client(cell.tight_port) as client:
        client.send(b"PIN")
        assert client.line() == "ERR,408,line not ended within 0.5 s"
        assert client.closed()
    with Client(cell.tight_port) as client:
        assert client.ask("PING") == "OK,PONG"
        assert client.line() == "ERR,408,idle for 0.5 s"
        assert client.closed()
    _alive(cell.tight_port)


def _answers_ping_soon(port):
    """Whether a fresh connection gets OK,PONG within 5 s (the server sees clients' ends a moment later)."""
    deadline = time.monotonic() + 5
    while True:
        with Client(port) as client:
            line = client.ask("PING")
        if line == "OK,PONG" or time.monotonic() > deadline:
            return line == "OK,PONG"
        time.sleep(0.05)


def test_connections_beyond_the_limit_get_503(cell):
    server = cell.loop.run(serve_lines(cell.service, "127.0.0.1", 0, max_connections=2))
    port = server.sockets[0].getsockname()[1]
    try:
        with Client(port) as first, Client(port) as second:
            assert first.ask("PING") == "OK,PONG" and second.ask("PING") == "OK,PONG"
            with Client(port) as third:
                assert third.line() == "ERR,503,too many connections (at most 2)"
                assert third.closed()
        assert _answers_ping_soon(port)
    finally:
        cell.loop.run(close_lines(server, timeout=5))


def test_a_token_is_asked_for_before_measure_and_result(cell):
    with Client(cell.token_port) as client:
        assert client.ask("PING") == "OK,PONG"
        assert client.ask("MEASURE table1.ply").startswith("ERR,401,")
        assert client.ask("RESULT 0123456789abcdef0123456789abcdef").startswith("ERR,401,")
        assert client.ask(f"AUTH {TOKEN}") == "OK,AUTH"
        assert client.ask("RESULT 0123456789abcdef0123456789abcdef").startswith("ERR,404,")
    with Client(cell.token_port) as client:
        assert client.ask("AUTH not-the-token") == "ERR,401,wrong token"
        assert client.closed()
    _alive(cell.token_port)


def test_a_request_that_fails_inside_is_500_and_the_server_goes_on(cell, caplog):
    # a service answer the protocol cannot write (a record holding a hole without a center): a bug's stand-in
    record = {"id": "0" * 32, "holes": [{"diameter": 3.0}]}
    stored_id = cell.loop.run(_in_store(cell.service, record))
    with Client(cell.port) as client:
        assert client.ask(f"RESULT {stored_id}") == "ERR,500,internal error"
        assert client.ask("PING") == "OK,PONG"
    assert "internal error answering" in caplog.text


async def _in_store(service, record):
    loop = asyncio.get_running_loop()
    return await loop.run_in_executor(service._store_thread, lambda: service.store.add(record))


def test_close_lines_answers_the_request_in_flight_and_closes_the_idle(cell):
    server = cell.loop.run(serve_lines(cell.service, "127.0.0.1", 0))
    port = server.sockets[0].getsockname()[1]
    with Client(port) as busy, Client(port) as idle:
        assert idle.ask("PING") == "OK,PONG"
        busy.send(b"MEASURE table1.ply\n")
        deadline = time.monotonic() + 10
        while cell.service.queue_depth == 0 and time.monotonic() < deadline:
            time.sleep(0.002)
        assert cell.service.queue_depth == 1
        cell.loop.run(close_lines(server, timeout=30))
        assert busy.line().startswith("OK,")
        assert busy.closed() and idle.closed()
    with pytest.raises(ConnectionRefusedError):
        socket.create_connection(("127.0.0.1", port), timeout=5).close()


# --- through holecli serve ---------------------------------------------------------------------------


@pytest.mark.slow
def test_holecli_serve_answers_the_line_protocol_and_stops_with_a_connection_open(tmp_path, repo_root):
    token_file = tmp_path / "token"
    token_file.write_text(TOKEN + "\n", encoding="utf-8")
    token_file.chmod(0o600)
    command = [sys.executable, "-m", "holecli", "serve", "--port", "0", "--tcp-port", "0", "--tcp-units", "um",
               "--store", str(tmp_path / "s.sqlite"), "--allow-dir", str(repo_root / "sample_clouds"),
               "--token-file", str(token_file), "--workers", "1", "--quiet"]
    environment = dict(os.environ, PYTHONPATH=str(repo_root))
    with subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=environment,
                          start_new_session=True) as server:
        try:
            ready = json.loads(server.stdout.readline())  # one JSON line once every front end listens
            host, port = ready["tcp"].rsplit(":", 1)
            assert host == "127.0.0.1"
            with Client(int(port)) as client:
                assert client.ask("MEASURE table1.ply").startswith("ERR,401,")
                assert client.ask(f"AUTH {TOKEN}") == "OK,AUTH"
                fields = _fields(client.ask("MEASURE table1.ply part=P-7"))
                assert fields[0] == "OK" and fields[2] == "1", fields
                assert int(fields[6]) == pytest.approx(3000, abs=10)  # micrometres
                assert client.ask(f"RESULT {fields[1]}") == ",".join(fields)
                assert client.ask("PING") == "OK,PONG"
                server.send_signal(signal.SIGTERM)  # this connection open and idle
                assert server.wait(30) == 0
                assert client.closed()
        finally:
            if server.poll() is None:
                server.kill()
                server.wait()
    with open_store(tmp_path / "s.sqlite") as store:
        assert store.get(fields[1])["meta"]["part"] == "P-7"
