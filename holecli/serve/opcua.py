"""The OPC UA front end of ``holecli serve`` (asyncua, the optional extra ``opcua``).

A cell's PLC or vision client starts a measurement with the method ``Holecli/Measure(path, spec,
meta)``, reads the last result from the variables of ``Holecli/LastResult`` (parallel arrays, one
element per hole) and learns of every stored measurement from a ``ResultReadyEventType`` event, the
one measurements over HTTP and TCP fire too. ``Holecli/GetResult(ResultId)`` returns any stored answer as
JSON. The layout is modelled on OPC 40100 (Machine Vision: a method starts a job, a ResultReady event,
a result fetched by its id, with its processing times) without claiming conformance to it.

Security follows ``holecli serve``'s rule for every front end: on the loopback interface the endpoint
may go without security (policy None); beyond it (:func:`check_bind`) the server needs its certificate
(the only endpoint is then Basic256Sha256, signed and encrypted) and the service's token, which every
session must give as its password (with a token, on any interface).

Every name of the address space is in the namespace :data:`NAMESPACE_URI`; each node also has a string
NodeId, its browse path below ``Objects`` joined with dots (``ns=2;s=Holecli.LastResult.Diameter``), for
clients that address nodes by id (a PLC's OPC UA client). :class:`MeasureClient` is a small client of
it (the tests, ``benchmarks/serve.py``).
"""

from __future__ import annotations

import asyncio
import collections
import contextlib
import datetime
import ipaddress
import json
import logging
import socket

from asyncua import Client, Server, ua
from asyncua.crypto import cert_gen
from asyncua.crypto.permission_rules import User, UserRole
from cryptography import x509
from cryptography.hazmat.primitives import serialization
from cryptography.x509.oid import ExtendedKeyUsageOID

from holecli.errors import HoleCliError
from holecli.serve.security import is_loopback, is_the_token
from holecli.serve.service import MeasureRequest, ServiceError
from holecli.store.schema import hole_verdict_word, verdict_word

__all__ = ["APPLICATION_URI", "ENDPOINT_PATH", "NAMESPACE_URI", "STATUS_OF_ERROR", "MeasureClient", "OpcUaBindError",
           "call_measure", "check_bind", "endpoint_url", "start_opcua"]

NAMESPACE_URI = "urn:holecli:serve"
APPLICATION_URI = "urn:holecli:serve:server"
ENDPOINT_PATH = "/holecli/"

# ServiceError.code -> the status code of a failed Measure or GetResult call
STATUS_OF_ERROR = {
    "bad_request": ua.StatusCodes.BadInvalidArgument,
    "unauthorized": ua.StatusCodes.BadUserAccessDenied,
    "forbidden": ua.StatusCodes.BadUserAccessDenied,
    "not_found": ua.StatusCodes.BadNotFound,
    "timeout": ua.StatusCodes.BadTimeout,
    "too_large": ua.StatusCodes.BadRequestTooLarge,
    "unmeasurable": ua.StatusCodes.BadDataUnavailable,
    "unavailable": ua.StatusCodes.BadResourceUnavailable,
    "internal_error": ua.StatusCodes.BadInternalError,
}

# The variables of LastResult: browse name -> (variant type, meaning: the node's Description)
_SCALARS = {
    "ResultId": (ua.VariantType.String, "the id of the stored answer (GetResult's argument)"),
    "Received": (ua.VariantType.DateTime, "when the service received the request (UTC)"),
    "File": (ua.VariantType.String, "the scan, as the request named it"),
    "Part": (ua.VariantType.String, "meta part"),
    "Serial": (ua.VariantType.String, "meta serial"),
    "ProcessingTimeMs": (ua.VariantType.Double, "wall time from receipt to stored, ms"),
    "MeasuringTimeMs": (ua.VariantType.Double, "the scan's measuring time in the worker (timing.elapsed_ms), ms"),
    "HoleCount": (ua.VariantType.UInt32, "number of holes"),
    "Verdict": (ua.VariantType.String, "pass, fail, undecided, unchecked"),
}
_ARRAYS = {
    "HoleName": (ua.VariantType.String, "the spec's hole name, '' when unnamed"),
    "CenterX": (ua.VariantType.Double, "center x, in the record's unit"),
    "CenterY": (ua.VariantType.Double, "center y, in the record's unit"),
    "CenterZ": (ua.VariantType.Double, "center z, in the record's unit"),
    "Diameter": (ua.VariantType.Double, "diameter, in the record's unit"),
    "NormalX": (ua.VariantType.Double, "unit normal x"),
    "NormalY": (ua.VariantType.Double, "unit normal y"),
    "NormalZ": (ua.VariantType.Double, "unit normal z"),
    "HoleVerdict": (ua.VariantType.String, "pass, fail, undecided, unchecked"),
}

_EVENT_FIELDS = {"ResultId": ua.VariantType.String, "HoleCount": ua.VariantType.UInt32,
                 "Verdict": ua.VariantType.String, "ProcessingTimeMs": ua.VariantType.Double}
_PUBLISHED_IDS_KEPT = 64  # answers published recently, so that one answer fires one event
_log = logging.getLogger(__name__)


class AnswersToClients(logging.Filter):
    """Drops asyncua's log of each Bad status it answers a client with ("sending service fault
    response ...", at ERROR): the client's own business (a Publish for the subscription it has just
    deleted while disconnecting: BadNoSubscription), not a fault of the service, and it went to the
    service's stderr."""

    def filter(self, record):
        return not str(record.msg).startswith("sending service fault response")


_PROCESSOR_LOG = logging.getLogger("asyncua.server.uaprocessor")


class OpcUaBindError(HoleCliError, ValueError):
    """The OPC UA server was asked to listen beyond the loopback interface without security, or on no port."""


def endpoint_url(host, port):
    """The endpoint URL of a server on ``host:port``: ``opc.tcp://host:port/holecli/`` (an IPv6 address
    in brackets)."""
    shown = f"[{host}]" if ":" in host else host
    return f"opc.tcp://{shown}:{port}{ENDPOINT_PATH}"


async def start_opcua(service, host, port, *, token=None, certificate=None, private_key=None):
    """Start the OPC UA server of ``service`` on ``host:port``.

    Parameters
    ----------
    service : holecli.serve.service.Service
        The service whose ``measure`` and ``result`` the methods call; the server subscribes to it, so
        that every stored measurement (over any front end) updates ``LastResult`` and fires ResultReady.
    host : str
        The address to bind. Beyond the loopback interface (``127.0.0.1``, ``::1``, ``localhost``)
        ``token``, ``certificate`` and ``private_key`` are required.
    port : int
        The TCP port (4840 is OPC UA's registered one); 0 is refused (the endpoint URL names the port).
    token : str, optional
        The service's bearer token: a session must then log in with a user name (any) and this
        password. Without ``certificate`` the server makes itself a throwaway certificate, so that the
        password crosses the loopback interface encrypted.
    certificate, private_key : str, optional
        The server's application instance certificate and its RSA key (PEM or DER files): the endpoint
        ``Basic256Sha256`` signed and encrypted is then offered, and beyond the loopback interface it
        is the only one. Its subject alternative names should hold the URI ``urn:holecli:serve:server``
        and the host's name.

    Returns
    -------
    asyncua.Server
        The started server; the caller stops it (``await server.stop()``).

    Raises
    ------
    OpcUaBindError
        See :func:`check_bind`.
    """
    check_bind(host, port, token=token, certificate=certificate, private_key=private_key)
    if not any(isinstance(item, AnswersToClients) for item in _PROCESSOR_LOG.filters):
        _PROCESSOR_LOG.addFilter(AnswersToClients())
    server = _Server(user_manager=_TokenUsers(token) if token is not None else None)
    await server.init()
    server.allow_remote_admin(False)  # asyncua's default lets a user named admin change the address space
    server.set_endpoint(endpoint_url(host, port))
    server.set_server_name("holecli serve")
    await server.set_application_uri(APPLICATION_URI)
    policies = [ua.SecurityPolicyType.Basic256Sha256_SignAndEncrypt]
    if is_loopback(host):
        policies.insert(0, ua.SecurityPolicyType.NoSecurity)
    if certificate is not None:
        await server.load_certificate(certificate, format=_key_format(certificate))
        await server.load_private_key(private_key, format=_key_format(private_key))
    elif token is not None:
        der_certificate, der_key = _throwaway_certificate(host)
        await server.load_certificate(der_certificate, format="der")
        await server.load_private_key(der_key, format="der")
    else:
        policies = [ua.SecurityPolicyType.NoSecurity]
    server.set_security_policy(policies)
    server.set_identity_tokens([ua.UserNameIdentityToken] if token is not None else [ua.AnonymousIdentityToken])
    namespace = await server.register_namespace(NAMESPACE_URI)
    front = server.front = _OpcUaFront(service, server, namespace)
    await front.build()
    await server.start()
    service.subscribe(front.on_answer)
    return server


def check_bind(host, port, *, token=None, certificate=None, private_key=None):
    """Refuse an OPC UA configuration that would expose the service: beyond the loopback interface the
    endpoint must be signed and encrypted (``certificate`` and ``private_key``) and sessions must log in
    (``token``).

    Raises
    ------
    OpcUaBindError
        Naming what is missing; or ``port`` is not in 1..65535; or only one of ``certificate`` and
        ``private_key`` is given.
    """
    if isinstance(port, bool) or not isinstance(port, int) or not 0 < port < 65536:
        raise OpcUaBindError(f"OPC UA port must be in 1..65535 (the endpoint URL names it), not {port!r}")
    if (certificate is None) != (private_key is None):
        raise OpcUaBindError("OPC UA needs both the server's certificate and its private key, or neither")
    if not is_loopback(host) and (certificate is None or token is None):
        missing = " and ".join(what for what, given in (("a server certificate and key", certificate),
                                                        ("a token", token)) if given is None)
        raise OpcUaBindError(f"OPC UA on {host} (beyond the loopback interface) needs {missing}: without them "
                             "its endpoint has no signing, encryption or login; bind it to 127.0.0.1, or reach "
                             "it over an SSH tunnel or a gateway")


class _TokenUsers:
    """asyncua's user manager: a session logs in with any user name and the service's token as password."""

    def __init__(self, token):
        self._token = token

    def get_user(self, iserver, username=None, password=None, certificate=None):
        if password is None:
            return None
        return User(role=UserRole.User, name=username) if is_the_token(password, self._token) else None


def _key_format(path):
    """asyncua's ``format`` of a certificate or key file: ``pem`` when it is text, else ``der``."""
    with open(path, "rb") as stream:
        return "pem" if stream.read(11) == b"-----BEGIN " else "der"


def _throwaway_certificate(host):
    """A self-signed certificate and RSA key (DER bytes) valid for a day, for this run only: it encrypts
    the password on the loopback interface; nobody is meant to trust it."""
    key = cert_gen.generate_private_key()
    names = [x509.UniformResourceIdentifier(APPLICATION_URI), x509.DNSName(socket.gethostname()),
             x509.DNSName("localhost")]
    with contextlib.suppress(ValueError):
        names.append(x509.IPAddress(ipaddress.ip_address(host)))
    certificate = cert_gen.generate_self_signed_app_certificate(
        key, "holecli serve", {}, names, [ExtendedKeyUsageOID.SERVER_AUTH], days=1)
    return (certificate.public_bytes(serialization.Encoding.DER),
            key.private_bytes(serialization.Encoding.DER, serialization.PrivateFormat.PKCS8,
                              serialization.NoEncryption()))


class _Server(Server):
    """asyncua's server, whose stop also stops publishing the service's answers (the service has no
    unsubscribe: its callback stays, and does nothing)."""

    front = None

    async def stop(self):
        if self.front is not None:
            self.front.stopped = True
        await super().stop()


class _OpcUaFront:
    """The address space of one server and the callbacks that fill it."""

    def __init__(self, service, server, namespace):
        self.service = service
        self.server = server
        self.ns = namespace
        self.variables = {}  # LastResult's browse name -> NodeId
        self.last_error = None  # the NodeId of Holecli/LastError
        self.events = None  # the ResultReady EventGenerator
        self._lock = asyncio.Lock()
        self._published = collections.deque(maxlen=_PUBLISHED_IDS_KEPT)
        self._tasks = set()
        self.stopped = False

    def _id(self, *path):
        return ua.NodeId(".".join(path), self.ns)

    async def build(self):
        objects = self.server.nodes.objects
        holecli = await objects.add_object(self._id("Holecli"), ua.QualifiedName("Holecli", self.ns))
        await _describe(holecli, "holecli serve: measure drilled holes in scans, the last result, ResultReady events")
        measure = await holecli.add_method(
            self._id("Holecli", "Measure"), ua.QualifiedName("Measure", self.ns), self._measure,
            [_argument("Path", ua.VariantType.String,
                       "the scan's path on the server (inside an --allow-dir; a relative one: in the first)"),
             _argument("Spec", ua.VariantType.String, "a spec name in --spec-dir, '' for none"),
             _argument("Meta", ua.VariantType.String,
                       'part, serial, cell, operator: a JSON object or "key=value;key=value", "" for none')],
            [_argument("ResultId", ua.VariantType.String, "the stored answer's id"),
             _argument("Holes", ua.VariantType.UInt32, "number of holes found"),
             _argument("Verdict", ua.VariantType.String, "pass, fail, undecided or unchecked")])
        await _describe(measure, "measure and store the scan at Path; returns once it is stored (OPC 40100's "
                                 "StartSingleJob, synchronous)")
        get_result = await holecli.add_method(
            self._id("Holecli", "GetResult"), ua.QualifiedName("GetResult", self.ns), self._get_result,
            [_argument("ResultId", ua.VariantType.String, "a stored answer's id")],
            [_argument("Result", ua.VariantType.String, "the answer as JSON (the record holecli detect writes, "
                                                         "plus id, received, processing_ms, stored, meta)")])
        await _describe(get_result, "a stored answer by its id, as JSON (OPC 40100's GetResultById)")
        last_error = await holecli.add_variable(self._id("Holecli", "LastError"),
                                                ua.QualifiedName("LastError", self.ns),
                                                ua.Variant("", ua.VariantType.String))
        await _describe(last_error, "code: message of the last refused Measure or GetResult call")
        self.last_error = last_error.nodeid
        folder = await holecli.add_folder(self._id("Holecli", "LastResult"), ua.QualifiedName("LastResult", self.ns))
        await _describe(folder, "the last stored measurement (from any front end); arrays: one element per hole")
        for name, (vtype, meaning) in _SCALARS.items():
            node = await folder.add_variable(self._id("Holecli", "LastResult", name), ua.QualifiedName(name, self.ns),
                                             ua.Variant(_EMPTY[vtype], vtype))
            await _describe(node, meaning)
            self.variables[name] = node.nodeid
        for name, (vtype, meaning) in _ARRAYS.items():
            node = await folder.add_variable(self._id("Holecli", "LastResult", name), ua.QualifiedName(name, self.ns),
                                             ua.Variant([], vtype))
            await node.write_value_rank(ua.ValueRank.OneDimension)
            await _describe(node, meaning + ", per hole")
            self.variables[name] = node.nodeid
        base_event_type = self.server.get_node(ua.ObjectIds.BaseEventType)
        event_type = await base_event_type.add_object_type(self._id("ResultReadyEventType"),
                                                           ua.QualifiedName("ResultReadyEventType", self.ns))
        for name, vtype in _EVENT_FIELDS.items():
            field = await event_type.add_property(self._id("ResultReadyEventType", name),
                                                  ua.QualifiedName(name, self.ns), ua.Variant(_EMPTY[vtype], vtype))
            await field.set_modelling_rule(True)
        # fired by the Server object (where clients subscribe to events by default), its source Holecli
        self.events = await self.server.get_event_generator(event_type, ua.ObjectIds.Server)
        self.events.event.SourceNode = holecli.nodeid
        self.events.event.SourceName = "Holecli"
        if self.service.last is not None:
            await self._write_last(self.service.last)

    async def _measure(self, parent, *arguments):
        """Measure(Path, Spec, Meta) -> (ResultId, Holes, Verdict); a Bad status when the service refuses."""
        try:
            path, spec, meta = _strings(arguments, 3)
            request = MeasureRequest(path=path, spec=spec or None, meta=_parse_meta(meta), channel="opcua")
            answer = await self.service.measure(request)
        except ServiceError as error:
            return await self._refuse(error.code, error.message)
        await self.publish(answer)
        verdict = verdict_word(answer)
        return [ua.Variant(answer["id"], ua.VariantType.String),
                ua.Variant(len(answer.get("holes", ())), ua.VariantType.UInt32),
                ua.Variant(verdict, ua.VariantType.String)]

    async def _get_result(self, parent, *arguments):
        """GetResult(ResultId) -> the stored answer as JSON."""
        try:
            (result_id,) = _strings(arguments, 1)
            answer = await self.service.result(result_id)
        except ServiceError as error:
            return await self._refuse(error.code, error.message)
        return [ua.Variant(json.dumps(answer, separators=(",", ":"), allow_nan=False), ua.VariantType.String)]

    async def _refuse(self, code, message):
        """The Bad status of a refused call; its message goes to Holecli/LastError (a status has no text)."""
        await self.server.write_attribute_value(
            self.last_error, ua.DataValue(ua.Variant(f"{code}: {message}", ua.VariantType.String)))
        return ua.StatusCode(STATUS_OF_ERROR.get(code, ua.StatusCodes.BadInternalError))

    def on_answer(self, answer):
        """The service's callback after every stored measurement: publish it on the event loop."""
        if self.stopped:
            return
        task = asyncio.get_running_loop().create_task(self.publish(answer))
        self._tasks.add(task)
        task.add_done_callback(self._published_or_said)

    def _published_or_said(self, task):
        self._tasks.discard(task)
        if not task.cancelled() and task.exception() is not None:
            _log.error("OPC UA: the result could not be published", exc_info=task.exception())

    async def publish(self, answer):
        """Write ``answer`` to LastResult and fire ResultReady, once per answer (Measure and the service's
        callback both publish its own; the lock keeps the writes of two answers from interleaving)."""
        async with self._lock:
            if answer["id"] in self._published:
                return
            self._published.append(answer["id"])
            await self._write_last(answer)
            event = self.events.event
            event.ResultId = answer["id"]
            event.HoleCount = ua.Variant(len(answer.get("holes", ())), ua.VariantType.UInt32)
            event.Verdict = verdict_word(answer)
            event.ProcessingTimeMs = float(answer.get("processing_ms") or 0.0)
            await self.events.trigger(message=f"result {answer['id']} ready")

    async def _write_last(self, answer):
        now = datetime.datetime.now(datetime.timezone.utc)
        for name, variant in _last_result_values(answer).items():
            await self.server.write_attribute_value(self.variables[name],
                                                    ua.DataValue(variant, SourceTimestamp=now, ServerTimestamp=now))


_EMPTY = {ua.VariantType.String: "", ua.VariantType.Double: 0.0, ua.VariantType.UInt32: 0,
          ua.VariantType.DateTime: datetime.datetime(1601, 1, 1, tzinfo=datetime.timezone.utc)}


async def _describe(node, text):
    """Set ``node``'s Description (what a browsing client such as UaExpert shows)."""
    await node.write_attribute(ua.AttributeIds.Description, ua.DataValue(ua.Variant(ua.LocalizedText(text))))


def _argument(name, vtype, description):
    argument = ua.Argument()
    argument.Name = name
    argument.DataType = ua.NodeId(vtype.value)
    argument.ValueRank = ua.ValueRank.Scalar
    argument.Description = ua.LocalizedText(description)
    return argument


def _strings(arguments, count):
    """The values of ``count`` String arguments; a ServiceError (bad_request) otherwise."""
    if len(arguments) != count:
        raise ServiceError(400, f"expected {count} arguments, got {len(arguments)}")
    values = [argument.Value for argument in arguments]
    for index, value in enumerate(values):
        if value is not None and not isinstance(value, str):
            raise ServiceError(400, f"argument {index + 1} must be a String, got {type(value).__name__}")
    return [value or "" for value in values]


def _parse_meta(text):
    """The meta of a Measure call: a JSON object, or ``key=value`` pairs separated by ``;`` ("" for none)."""
    text = text.strip()
    if not text:
        return {}
    if text.startswith("{"):
        try:
            meta = json.loads(text)
        except json.JSONDecodeError as error:
            raise ServiceError(400, f"meta is not valid JSON: {error}") from None
        if not isinstance(meta, dict):
            raise ServiceError(400, "meta must be a JSON object")
        return meta
    meta = {}
    for pair in text.split(";"):
        if not pair.strip():
            continue
        key, sep, value = pair.partition("=")
        if not sep or not key.strip():
            raise ServiceError(400, f"meta must be key=value pairs separated by ';', got {pair!r}")
        meta[key.strip()] = value.strip()
    return meta


def _last_result_values(answer):
    """LastResult's variable name -> its Variant for ``answer``."""
    holes = answer.get("holes", ())
    meta = answer.get("meta") or {}
    received = answer.get("received")
    received = (datetime.datetime.fromisoformat(received.replace("Z", "+00:00")) if received
                else _EMPTY[ua.VariantType.DateTime])
    timing = answer.get("timing") or {}
    scalars = {"ResultId": answer["id"], "Received": received, "File": answer.get("file") or "",
               "Part": str(meta.get("part") or ""), "Serial": str(meta.get("serial") or ""),
               "ProcessingTimeMs": float(answer.get("processing_ms") or 0.0),
               "MeasuringTimeMs": float(timing.get("elapsed_ms") or 0.0),
               "HoleCount": len(holes), "Verdict": verdict_word(answer)}
    arrays = {"HoleName": [hole.get("name") or "" for hole in holes],
              "CenterX": [float(hole["center"][0]) for hole in holes],
              "CenterY": [float(hole["center"][1]) for hole in holes],
              "CenterZ": [float(hole["center"][2]) for hole in holes],
              "Diameter": [float(hole["diameter"]) for hole in holes],
              "NormalX": [float(hole["normal"][0]) for hole in holes],
              "NormalY": [float(hole["normal"][1]) for hole in holes],
              "NormalZ": [float(hole["normal"][2]) for hole in holes],
              "HoleVerdict": [hole_verdict_word(hole) for hole in holes]}
    values = {name: ua.Variant(value, _SCALARS[name][0]) for name, value in scalars.items()}
    values.update({name: ua.Variant(value, _ARRAYS[name][0]) for name, value in arrays.items()})
    return values


class MeasureClient:
    """A client of the server: ``async with MeasureClient(url) as client: await client.measure(path)``.

    Parameters
    ----------
    url : str
        The endpoint, e.g. ``opc.tcp://127.0.0.1:4840/holecli/``.
    timeout : float
        Seconds a request may take (a measurement of a large scan takes seconds).
    token : str, optional
        The service's token (the session's password; user name ``holecli``).
    security : str, optional
        asyncua's security string, e.g. ``"Basic256Sha256,SignAndEncrypt,client.der,client.pem,server.der"``
        (the client's certificate and key, and the server's certificate it trusts).
    """

    def __init__(self, url, timeout=30.0, *, token=None, security=None):
        self.client = Client(url, timeout=timeout)
        self.client.session_timeout = 600_000  # asyncua servers grant at most 10 min (and warn when asked for more)
        if token is not None:
            self.client.set_user("holecli")
            self.client.set_password(token)
        self.security = security
        self.namespace = None
        self.holecli = None

    async def __aenter__(self):
        if self.security is not None:
            await self.client.set_security_string(self.security)
        await self.client.connect()
        try:
            self.namespace = await self.client.get_namespace_index(NAMESPACE_URI)
            self.holecli = self.client.get_node(ua.NodeId("Holecli", self.namespace))
        except BaseException:
            await self.client.disconnect()
            raise
        return self

    async def __aexit__(self, *exc_info):
        await self.client.disconnect()

    async def measure(self, path, spec="", meta=""):
        """Call Measure: ``(result_id, holes, verdict)``; a Bad status raises ``asyncua.ua.UaStatusCodeError``."""
        result_id, holes, verdict = await self.holecli.call_method(ua.QualifiedName("Measure", self.namespace),
                                                                   path, spec, meta)
        return result_id, holes, verdict

    async def result(self, result_id):
        """Call GetResult: the stored answer as a dict."""
        return json.loads(await self.holecli.call_method(ua.QualifiedName("GetResult", self.namespace), result_id))

    async def last_result(self):
        """The values of the LastResult variables, by name."""
        names = list(_SCALARS) + list(_ARRAYS)
        nodes = [self.client.get_node(ua.NodeId(f"Holecli.LastResult.{name}", self.namespace)) for name in names]
        values = await self.client.read_values(nodes)
        return dict(zip(names, values))

    async def last_error(self):
        """The text of the last refused call (``code: message``)."""
        return await self.client.get_node(ua.NodeId("Holecli.LastError", self.namespace)).read_value()


async def call_measure(url, path, spec="", meta=""):
    """Connect to ``url``, call Measure once and disconnect: ``(result_id, holes, verdict)``."""
    async with MeasureClient(url) as client:
        return await client.measure(path, spec, meta)
