"""The line protocol over TCP: one request a line, one answer a line, for robot controllers and PLC gateways.

In the manner of a sensor's ASCII channel (LMI Gocator's on port 8190): a client opens a TCP
connection, keeps it, and writes requests, each a line ended by ``\\n`` (or ``\\r\\n``); every request
gets exactly one answer line, ended by ``\\r\\n``, in the order of the requests. Requests (the command
word in any case)::

    MEASURE <path> [spec=NAME] [registration=NAME] [format=FMT] [part=..] [serial=..] [cell=..]
            [operator=..] [OPTION=VALUE ...]
    RESULT <id>
    PING
    VERSION
    HELP
    AUTH <token>

Answers::

    OK,<id>,<n>{,<x>,<y>,<z>,<d>,<nx>,<ny>,<nz>,<hole verdict>}*n,<verdict>    (MEASURE, RESULT)
    OK,PONG                                                                   (PING)
    OK,<version>                                                              (VERSION)
    OK,MEASURE,RESULT,PING,VERSION,HELP,AUTH                                  (HELP)
    OK,AUTH                                                                   (AUTH)
    ERR,<status>,<message>

When the server has a token (``holecli serve --token-file``), MEASURE and RESULT are answered
``ERR,401`` until the connection sent ``AUTH <token>``; a wrong token is answered ``ERR,401`` and the
connection closed.

The verdicts are the words ``pass``, ``fail``, ``undecided`` and ``unchecked``. Lengths are in
millimetres with :data:`DECIMALS` decimals (``units="mm"``) or integer micrometres (``units="um"``);
the normal's components with :data:`NORMAL_DECIMALS` decimals, or integers of 1e-6. The status of
``ERR`` is the HTTP-like status of :class:`holecli.serve.service.ServiceError` (400, 401, 403, 404,
408, 413, 422, 500, 503). The full reference, with a robot-side example, is in the docs ("The line
protocol").

The pure parts (:func:`decode_line`, :func:`parse_line`, :func:`format_answer`,
:func:`format_error`) hold the grammar; :func:`serve_lines` runs it on the event loop of
``holecli serve``, a task per connection, so that no client can stop the server or hold up another.
"""

from __future__ import annotations

import asyncio
import logging
import math
import re
import weakref
from dataclasses import dataclass, field
from typing import Mapping, Optional, Union

from holecli.errors import HoleCliError
from holecli.serve.security import is_the_token
from holecli.serve.service import MeasureRequest, ServiceError
from holecli.store.schema import hole_verdict_word, verdict_word
from holecli.units import UNITS, scale_factor

__all__ = ["COMMANDS", "DECIMALS", "IDLE_TIMEOUT", "LINE_TIMEOUT", "LINE_UNITS", "MAX_CONNECTIONS", "MAX_LINE",
           "MESSAGE_MAX", "NORMAL_DECIMALS", "Auth", "Help", "LineError", "Measure", "Ping", "Result", "Version",
           "answer", "close_lines", "decode_line", "format_answer", "format_error", "option_value", "parse_line",
           "serve_lines"]

# The units of the answers' lengths: decimal millimetres, or integer micrometres.
LINE_UNITS = ("mm", "um")
# Decimals of a length in mm (a tenth of a micrometre, as --format table) and of a normal's component.
DECIMALS = 4
NORMAL_DECIMALS = 6
# The longest request line, in bytes without its newline: a path and a few options need far less.
MAX_LINE = 65536
# Seconds a client may stay silent between requests (None: as long as it likes, as a sensor's channel),
# and seconds a line, once begun, may take to arrive whole.
IDLE_TIMEOUT = None
LINE_TIMEOUT = 30.0
# Connections served at once; one more is answered ERR,503 and closed.
MAX_CONNECTIONS = 64
# The longest message of an ERR line, in characters (robot controllers hold short strings).
MESSAGE_MAX = 200
# Seconds the server keeps reading (and discarding) after an ERR that closes the connection, so that the
# client receives the ERR line before the connection ends.
LINGER = 2.0

COMMANDS = ("MEASURE", "RESULT", "PING", "VERSION", "HELP", "AUTH")
# The keys of MEASURE that are fields of the request, and the keys of its metadata; every other key is
# a detection option (holecli.serve.service checks them: an unknown one is refused with 400).
REQUEST_KEYS = ("spec", "registration", "format")
META_KEYS = ("part", "serial", "cell", "operator")
# How the text of an option becomes the value the service takes (holecli.serve.service.OPTIONS); an
# option whose text does not read as its kind is passed on as text, for the service to refuse by name.
NUMBER_OPTIONS = ("min_diameter", "gauge_depth")
INTEGER_OPTIONS = ("max_holes", "scan")
FLAG_OPTIONS = ("full_only", "explain")
_FLAGS = {"true": True, "yes": True, "1": True, "false": False, "no": False, "0": False}

_TERMINATOR = b"\r\n"
_KEY = re.compile(r"([A-Za-z_][A-Za-z0-9_]*)=(.*)\Z", re.DOTALL)
_RESULT_ID = re.compile(r"[A-Za-z0-9]{1,64}\Z")
# C0 controls and DEL; a tab counts as a space.
_CONTROL = re.compile(r"[\x00-\x08\x0a-\x1f\x7f]")
_LOG = logging.getLogger(__name__)


class LineError(HoleCliError):
    """A request line that is not a request (400), too long (413) or too slow (408).

    Parameters
    ----------
    status : int
        The status of the ``ERR`` answer, as :class:`holecli.serve.service.ServiceError`'s.
    message : str
        What is wrong, one line.
    """

    def __init__(self, status, message):
        self.status = int(status)
        self.message = message
        super().__init__(f"{status}: {message}")


@dataclass(frozen=True)
class Measure:
    """``MEASURE <path> [KEY=VALUE ...]``: measure a file the server may read.

    Attributes
    ----------
    path : str
        The file, as sent (the service resolves it inside its ``--allow-dir`` folders).
    spec, registration : str or None
        Names in the service's ``--spec-dir``.
    format : str or None
        The file's format when its extension does not say it (``input_format``).
    options : dict
        Detection options (``min_diameter=0.5``, ``view_dir=0,0,-1``, ...), each value read as its
        kind (:func:`option_value`).
    meta : dict of str to str
        ``part``, ``serial``, ``cell``, ``operator``: stored with the measurement.
    """

    path: str
    spec: Optional[str] = None
    registration: Optional[str] = None
    format: Optional[str] = None
    options: Mapping = field(default_factory=dict)
    meta: Mapping = field(default_factory=dict)

    def request(self) -> MeasureRequest:
        """The service's request for this command (``channel="tcp"``)."""
        return MeasureRequest(path=self.path, format=self.format, options=dict(self.options), spec=self.spec,
                              registration=self.registration, meta=dict(self.meta), channel="tcp")


@dataclass(frozen=True)
class Result:
    """``RESULT <id>``: the answer of a stored measurement, again."""

    id: str


@dataclass(frozen=True)
class Ping:
    """``PING``: answered ``OK,PONG`` (is the server there?)."""


@dataclass(frozen=True)
class Version:
    """``VERSION``: answered ``OK,<holecli version>``."""


@dataclass(frozen=True)
class Help:
    """``HELP``: answered ``OK,`` and the command words."""


@dataclass(frozen=True)
class Auth:
    """``AUTH <token>``: the token of a server that asks for one (``holecli serve --token-file``)."""

    token: str = field(repr=False)


Command = Union[Measure, Result, Ping, Version, Help, Auth]


def decode_line(raw: bytes) -> str:
    """The text of one request line: UTF-8, without its ``\\r``, without control characters.

    Parameters
    ----------
    raw : bytes
        The line as received, without its ``\\n``.

    Returns
    -------
    str

    Raises
    ------
    LineError
        400 for bytes that are not UTF-8, or a control character (a tab is a space).

    Examples
    --------
    >>> decode_line(b"PING\\r")
    'PING'
    """
    if raw.endswith(b"\r"):
        raw = raw[:-1]
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as error:
        raise LineError(400, f"the line is not UTF-8 (byte {error.start})") from None
    control = _CONTROL.search(text)
    if control:
        raise LineError(400, f"control character 0x{ord(control.group()):02x} at character {control.start()} "
                             "of the line")
    return text


def parse_line(text: str) -> Optional[Command]:
    """The command of one request line.

    Words are separated by spaces or tabs. A word may hold double-quoted parts, which may hold spaces
    and, escaped with a backslash, ``\\"`` and ``\\\\`` (a backslash before any other character is
    itself); outside quotes a backslash is an ordinary character. The command word is read in any
    case, so are the keys of ``KEY=VALUE``.

    Parameters
    ----------
    text : str
        The line from :func:`decode_line`.

    Returns
    -------
    Measure, Result, Ping, Version, Help, Auth, or None
        None for a blank line (no request: not answered).

    Raises
    ------
    LineError
        400 for an unknown command, a missing or extra argument, a word that is not ``KEY=VALUE``
        after MEASURE's path, a key given twice, an empty value, an unterminated quote.

    Examples
    --------
    >>> parse_line('MEASURE "scans/part 7.ply" spec=plate part=P-7 min_diameter=2')
    Measure(path='scans/part 7.ply', spec='plate', registration=None, format=None, options={'min_diameter': 2.0}, meta={'part': 'P-7'})
    >>> parse_line("ping")
    Ping()
    """
    words = _split_words(text)
    if not words:
        return None
    name = words[0].upper()
    arguments = words[1:]
    if name == "MEASURE":
        return _measure(arguments)
    if name == "RESULT":
        if len(arguments) != 1:
            raise LineError(400, f"RESULT takes one id: got {len(arguments)} words")
        result_id = _unquote(arguments[0])
        if not _RESULT_ID.match(result_id):
            raise LineError(400, f"not an id: {_shorten(result_id, 40)!r} (at most 64 letters and digits)")
        return Result(result_id)
    if name == "AUTH":
        if len(arguments) != 1:
            raise LineError(400, f"AUTH takes one token: got {len(arguments)} words")
        return Auth(_unquote(arguments[0]))
    simple = {"PING": Ping, "VERSION": Version, "HELP": Help}
    if name in simple:
        if arguments:
            raise LineError(400, f"{name} takes no arguments")
        return simple[name]()
    raise LineError(400, f"unknown command {_shorten(words[0], 40)!r} (expected {' '.join(COMMANDS)})")


def _measure(arguments) -> Measure:
    if not arguments:
        raise LineError(400, "MEASURE needs a path: MEASURE <path> [KEY=VALUE ...]")
    path = _unquote(arguments[0])
    if not path:
        raise LineError(400, "MEASURE's path is empty")
    fields, options, meta = {}, {}, {}
    for word in arguments[1:]:
        match = _KEY.match(word)
        if not match:
            raise LineError(400, f"expected KEY=VALUE after the path: got {_shorten(_unquote(word), 40)!r}")
        key, value = match.group(1).lower(), _unquote(match.group(2))
        if key in fields or key in options or key in meta:
            raise LineError(400, f"{key}= given twice")
        if not value:
            raise LineError(400, f"{key}= has no value")
        if key in REQUEST_KEYS:
            fields[key] = value
        elif key in META_KEYS:
            meta[key] = value
        else:
            options[key] = option_value(key, value)
    return Measure(path=path, options=options, meta=meta, **fields)


def option_value(name: str, text: str):
    """The value of the detection option ``name`` written ``text``, as the service takes it.

    ``min_diameter``, ``gauge_depth``: a float; ``max_holes``, ``scan``: an int; ``full_only``,
    ``explain``: true/false (also yes/no, 1/0, any case); ``view_dir``: three floats separated by
    commas; ``columns``: three names or 0-based numbers separated by commas; any other option its text.
    A text that does not read as its kind is returned as it is (the service refuses it by name).

    Examples
    --------
    >>> option_value("view_dir", "0,0,-1"), option_value("full_only", "YES"), option_value("columns", "x_mm,2,z")
    ([0.0, 0.0, -1.0], True, ['x_mm', 2, 'z'])
    >>> option_value("min_diameter", "2mm")
    '2mm'
    """
    try:
        if name in NUMBER_OPTIONS:
            return float(text)
        if name in INTEGER_OPTIONS:
            return int(text)
        if name == "view_dir":
            return [float(item) for item in text.split(",")]
    except ValueError:
        return text
    if name in FLAG_OPTIONS:
        return _FLAGS.get(text.lower(), text)
    if name == "columns":
        return [int(item) if item.isdigit() else item for item in text.split(",")]
    return text


def _split_words(text: str) -> list:
    """The words of ``text``, each as written (its quotes kept): split at spaces and tabs outside quotes."""
    words, word, quoted, escaped, in_word = [], [], False, False, False
    for char in text:
        if escaped:
            escaped = False
        elif quoted and char == "\\":
            escaped = True
        elif char == '"':
            quoted = not quoted
        elif not quoted and char in " \t":
            if in_word:
                words.append("".join(word))
                word, in_word = [], False
            continue
        word.append(char)
        in_word = True
    if quoted:
        raise LineError(400, "a double quote is not closed")
    if in_word:
        words.append("".join(word))
    return words


def _unquote(word: str) -> str:
    """``word`` with its quotes removed and ``\\"``, ``\\\\`` inside them resolved (a well-formed word)."""
    out, quoted, index = [], False, 0
    while index < len(word):
        char = word[index]
        if char == '"':
            quoted = not quoted
        elif quoted and char == "\\" and index + 1 < len(word) and word[index + 1] in '"\\':
            index += 1
            out.append(word[index])
        else:
            out.append(char)
        index += 1
    return "".join(out)


def format_answer(answer: Mapping, units: str = "mm") -> str:
    """The ``OK`` line of a measurement (without its line end).

    ``OK,<id>,<n>`` then, for each of the n holes in the record's order, ``x,y,z`` (center),
    ``d`` (diameter), ``nx,ny,nz`` (unit normal) and the hole's verdict word, and last the record's
    verdict word. A record that says its unit (``"units"``: mm, m or in) is converted into mm; a
    record that does not (the file's unit, not declared) is taken to be in mm.

    Parameters
    ----------
    answer : mapping
        The service's answer: a record with ``"id"`` and ``"holes"``.
    units : {"mm", "um"}
        Lengths in mm with :data:`DECIMALS` decimals and the normal with :data:`NORMAL_DECIMALS`, or
        lengths in integer micrometres and the normal in integer millionths.

    Returns
    -------
    str

    Examples
    --------
    >>> hole = {"center": [1.5, -2.0, 0.25], "diameter": 3.0001, "normal": [0.0, 0.0, 1.0]}
    >>> format_answer({"id": "ab12", "holes": [hole]})
    'OK,ab12,1,1.5000,-2.0000,0.2500,3.0001,0.000000,0.000000,1.000000,unchecked,unchecked'
    >>> format_answer({"id": "ab12", "holes": [hole], "units": "m"}, units="um")
    'OK,ab12,1,1500000,-2000000,250000,3000100,0,0,1000000,unchecked,unchecked'
    """
    if units not in LINE_UNITS:
        raise ValueError(f"units must be one of {', '.join(LINE_UNITS)}, got {units!r}")
    unit = answer.get("units")
    if unit is not None and unit not in UNITS:
        raise ValueError(f"the record's units {unit!r} are not one of {', '.join(UNITS)}")
    to_mm = scale_factor(unit, "mm") if unit is not None else 1.0
    holes = answer.get("holes") or []
    fields = ["OK", str(answer["id"]), str(len(holes))]
    for hole in holes:
        fields.extend(_length(value * to_mm, units) for value in hole["center"])
        fields.append(_length(hole["diameter"] * to_mm, units))
        fields.extend(_component(value, units) for value in hole["normal"])
        fields.append(hole_verdict_word(hole))
    fields.append(verdict_word(answer))
    return ",".join(fields)


def _length(value_mm: float, units: str) -> str:
    if units == "um":
        return str(round(value_mm * 1000.0))
    return _decimal(value_mm, DECIMALS)


def _component(value: float, units: str) -> str:
    if units == "um":
        return str(round(value * 1e6))
    return _decimal(value, NORMAL_DECIMALS)


def _decimal(value: float, decimals: int) -> str:
    if not math.isfinite(value):
        raise ValueError(f"not a finite number: {value!r}")
    text = f"{value:.{decimals}f}"
    # -0.00001 rounds to "-0.0000": a PLC's parser need not meet a negative zero.
    return text[1:] if text.startswith("-") and not text.strip("-0.") else text


def format_error(status: int, message: str) -> str:
    """The ``ERR`` line of a refusal (without its line end): ``ERR,<status>,<message>``.

    The message is made one field of one line: every control character (a newline, a tab) becomes a
    space, every comma a semicolon, runs of spaces one space; it is cut to :data:`MESSAGE_MAX`
    characters (ending ``...`` when cut).

    Examples
    --------
    >>> format_error(404, "no such file: scans/a,b.ply\\n(inside /data)")
    'ERR,404,no such file: scans/a;b.ply (inside /data)'
    """
    text = " ".join(_CONTROL.sub(" ", str(message)).replace("\t", " ").replace(",", ";").split())
    return f"ERR,{int(status)},{_shorten(text, MESSAGE_MAX) or 'error'}"


def _shorten(text: str, limit: int) -> str:
    return text if len(text) <= limit else text[:limit - 3] + "..."


async def answer(service, command: Command, units: str = "mm") -> str:
    """The answer line (without its line end) of one command, from the service.

    Parameters
    ----------
    service : holecli.serve.service.Service
    command : Measure, Result, Ping, Version or Help
        (AUTH is the connection's: :func:`serve_lines` answers it.)
    units : {"mm", "um"}

    Returns
    -------
    str
        The ``OK`` line; a stored record that is a failed file of a batch (it holds ``"error"``) is
        answered ``ERR,422,<its error>``.

    Raises
    ------
    holecli.serve.service.ServiceError
        The service's refusal.
    """
    if isinstance(command, Ping):
        return "OK,PONG"
    if isinstance(command, Version):
        return f"OK,{service.version}"
    if isinstance(command, Help):
        return "OK," + ",".join(COMMANDS)
    if isinstance(command, Measure):
        record = await service.measure(command.request())
    elif isinstance(command, Result):
        record = await service.result(command.id)
    else:
        raise TypeError(f"not a command answer() answers: {command!r}")
    if record.get("error"):
        return format_error(422, record["error"])
    return format_answer(record, units)


class _Closing(Exception):
    """The connection ends: with an ERR line (``line``) or quietly (``line`` None)."""

    def __init__(self, line=None):
        self.line = line
        super().__init__(line)


class _Channel:
    """The line protocol of one server: its settings and its open connections."""

    def __init__(self, service, units, token, max_line, idle_timeout, line_timeout, max_connections):
        self.service = service
        self.units = units
        self.token = token
        self.max_line = max_line
        self.idle_timeout = idle_timeout
        self.line_timeout = line_timeout
        self.max_connections = max_connections
        # writer -> True while it is answering a request (close_lines lets it finish).
        self.connections = {}
        self.closing = False

    async def handle(self, reader, writer):
        """One connection: its requests in sequence until it ends; never raises but CancelledError."""
        if self.closing or len(self.connections) >= self.max_connections:
            why = "server stopping" if self.closing else f"too many connections (at most {self.max_connections})"
            await self._end(reader, writer, format_error(503, why))
            return
        self.connections[writer] = False
        try:
            await self._serve(reader, writer)
        except _Closing as closing:
            await self._end(reader, writer, closing.line)
        except (ConnectionError, asyncio.TimeoutError):
            await self._end(reader, writer, None)
        except Exception:  # a bug here must cost one connection, not the server
            _LOG.exception("line protocol: connection from %s failed", writer.get_extra_info("peername"))
            writer.transport.abort()
        finally:
            self.connections.pop(writer, None)
            if not writer.transport.is_closing():
                writer.transport.abort()

    async def _serve(self, reader, writer):
        buffer, scanned = bytearray(), [0]
        session = {"authorized": self.token is None}
        while not self.closing:
            raw = await self._next_line(reader, buffer, scanned)
            if raw is None:
                await self._end(reader, writer, None)
                return
            self.connections[writer] = True
            line = await self._answer(raw, session)
            if line is not None:
                writer.write(line.encode("utf-8") + _TERMINATOR)
                await asyncio.wait_for(writer.drain(), self.line_timeout)
            self.connections[writer] = False
        await self._end(reader, writer, None)

    async def _next_line(self, reader, buffer, scanned):
        """The next line without its newline, or None at the end of the stream (a half line dropped)."""
        while True:
            end = buffer.find(b"\n", scanned[0])
            if end > self.max_line or (end < 0 and len(buffer) > self.max_line):
                raise _Closing(format_error(413, f"line too long (at most {self.max_line} bytes)"))
            if end >= 0:
                line = bytes(buffer[:end])
                del buffer[:end + 1]
                scanned[0] = 0
                return line
            scanned[0] = len(buffer)
            timeout = self.line_timeout if buffer else self.idle_timeout
            try:
                chunk = await asyncio.wait_for(reader.read(self.max_line + 1), timeout)
            except asyncio.TimeoutError:
                why = (f"line not ended within {self.line_timeout:g} s" if buffer
                       else f"idle for {self.idle_timeout:g} s")
                raise _Closing(format_error(408, why)) from None
            if not chunk:
                return None
            buffer += chunk

    async def _answer(self, raw, session):
        try:
            command = parse_line(decode_line(raw))
            if command is None:
                return None
            if isinstance(command, Auth):
                if self.token is not None and not is_the_token(command.token, self.token):
                    raise _Closing(format_error(401, "wrong token"))
                session["authorized"] = True
                return "OK,AUTH"
            if not session["authorized"] and isinstance(command, (Measure, Result)):
                return format_error(401, "this server asks for a token: send AUTH <token> first")
            return await answer(self.service, command, self.units)
        except _Closing:
            raise
        except (LineError, ServiceError) as error:
            return format_error(error.status, error.message)
        except Exception:
            _LOG.exception("line protocol: internal error answering %r", raw[:200])
            return format_error(500, "internal error")

    async def _end(self, reader, writer, line):
        """Close the connection, after ``line`` (an ERR) when given: the client reads it before the end."""
        try:
            if line is not None:
                writer.write(line.encode("utf-8") + _TERMINATOR)
                await asyncio.wait_for(writer.drain(), LINGER)
                if writer.can_write_eof():
                    writer.write_eof()
                # Closing with unread input makes the kernel reset the connection, which can lose the ERR
                # line at the client: read and drop what it still sends, for a moment.
                await asyncio.wait_for(_discard(reader), LINGER)
        except (ConnectionError, asyncio.TimeoutError):
            pass
        finally:
            writer.close()
            try:
                await asyncio.wait_for(writer.wait_closed(), LINGER)
            except (ConnectionError, asyncio.TimeoutError):
                writer.transport.abort()


async def _discard(reader):
    while await reader.read(65536):
        pass


# The channel of each server serve_lines started (for close_lines).
_CHANNELS = weakref.WeakKeyDictionary()


async def serve_lines(service, host: Optional[str] = None, port: Optional[int] = None, *, sock=None,
                      units: str = "mm", token: Optional[str] = None, max_line: int = MAX_LINE,
                      idle_timeout: Optional[float] = IDLE_TIMEOUT, line_timeout: float = LINE_TIMEOUT,
                      max_connections: int = MAX_CONNECTIONS) -> asyncio.AbstractServer:
    """Start the line protocol on ``host:port`` (0: a free port), or on the bound socket ``sock``, on
    the running event loop.

    Each connection is its own task and answers its requests in sequence; a line longer than
    ``max_line`` is answered ``ERR,413`` and its connection closed; a line begun and not ended within
    ``line_timeout`` seconds, or silence longer than ``idle_timeout`` (None: no limit), ``ERR,408``
    and closed; a line cut by the end of the connection is dropped unanswered; beyond
    ``max_connections`` connections at once a new one gets ``ERR,503`` and is closed. Errors of the
    service are ``ERR,<status>,<message>``; anything else ``ERR,500,internal error`` (logged to the
    ``holecli.serve.lines`` logger), and the server goes on.

    Parameters
    ----------
    service : holecli.serve.service.Service
    host, port : str, int
        Where to listen (not with ``sock``).
    sock : socket.socket, optional
        A bound TCP socket, not yet listening (``holecli serve`` binds before it starts its workers).
    units : {"mm", "um"}
        The answers' lengths: decimal millimetres or integer micrometres.
    token : str, optional
        The token MEASURE and RESULT need, sent once per connection with ``AUTH <token>``.
    max_line : int
        Bytes of a request line, without its newline.
    idle_timeout, line_timeout : float or None, float
        Seconds.
    max_connections : int

    Returns
    -------
    asyncio.Server
        Serving; its sockets give the bound addresses. Stop it with :func:`close_lines`.
    """
    if units not in LINE_UNITS:
        raise ValueError(f"units must be one of {', '.join(LINE_UNITS)}, got {units!r}")
    if max_line < 1 or max_connections < 1:
        raise ValueError(f"max_line and max_connections must be positive, got {max_line} and {max_connections}")
    channel = _Channel(service, units, token, max_line, idle_timeout, line_timeout, max_connections)
    if sock is not None:
        server = await asyncio.start_server(channel.handle, sock=sock, limit=max_line + 2)
    else:
        server = await asyncio.start_server(channel.handle, host, port, limit=max_line + 2)
    _CHANNELS[server] = channel
    return server


async def close_lines(server: asyncio.AbstractServer, timeout: float = 30.0) -> None:
    """Stop a server of :func:`serve_lines`: no new connections, idle ones closed, requests in flight
    answered (for at most ``timeout`` seconds, then their connections are cut).

    Parameters
    ----------
    server : asyncio.Server
        As returned by :func:`serve_lines`.
    timeout : float
        Seconds to wait for the requests in flight.
    """
    server.close()
    channel = _CHANNELS.get(server)
    if channel is not None:
        channel.closing = True
        for writer, busy in list(channel.connections.items()):
            if not busy:
                writer.transport.close()
        loop = asyncio.get_running_loop()
        deadline = loop.time() + timeout
        while channel.connections and loop.time() < deadline:
            await asyncio.sleep(0.05)
        for writer in list(channel.connections):
            writer.transport.abort()
    await server.wait_closed()
