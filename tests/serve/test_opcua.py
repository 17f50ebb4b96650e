"""holecli.serve.opcua: the OPC UA front end, a real asyncua server on 127.0.0.1 in front of a real
Service (warm worker, SQLite store), called by a real asyncua client. One server and one client for the
module (asyncua's server takes ~1.5 s to build its standard address space)."""

import asyncio
import contextlib
import datetime
import ipaddress
import json
import os
import shutil
import signal
import socket
import sys
from pathlib import Path

import pytest

asyncua = pytest.importorskip("asyncua")
from asyncua import ua  # noqa: E402
from asyncua.crypto import cert_gen  # noqa: E402
from cryptography import x509  # noqa: E402
from cryptography.hazmat.primitives import serialization  # noqa: E402
from cryptography.x509.oid import ExtendedKeyUsageOID  # noqa: E402

from holecli.serve.opcua import (APPLICATION_URI, NAMESPACE_URI, MeasureClient, OpcUaBindError,  # noqa: E402
                                 _last_result_values, _parse_meta, _throwaway_certificate, check_bind, endpoint_url,
                                 start_opcua)
from holecli.serve.service import MeasureRequest, Service, ServiceError  # noqa: E402
from holecli.store import open_store  # noqa: E402

REPO = Path(__file__).resolve().parents[2]
SAMPLES = REPO / "sample_clouds"
TABLE1 = str(SAMPLES / "table1.ply")


@pytest.fixture(scope="module")
def anyio_backend():
    """One asyncio loop for the module, so that the server and client fixtures live across tests."""
    return "asyncio"


def _free_port():
    with contextlib.closing(socket.socket()) as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


@pytest.fixture(scope="module")
async def served(anyio_backend, tmp_path_factory):
    """A Service (one warm worker, a SQLite store, sample_clouds allowed, the spec ``panel``) and its OPC
    UA server's URL."""
    folder = tmp_path_factory.mktemp("opcua")
    (folder / "specs").mkdir()
    shutil.copy(SAMPLES / "panel_tolerances.toml", folder / "specs" / "panel.toml")
    service = Service(open_store(folder / "results.sqlite"), workers=1, allow_dirs=[str(SAMPLES)],
                      spec_dir=str(folder / "specs"), metrics=False)
    try:
        await asyncio.to_thread(service.warm)
        port = _free_port()
        server = await start_opcua(service, "127.0.0.1", port)
        try:
            yield service, endpoint_url("127.0.0.1", port)
        finally:
            await server.stop()
    finally:
        await asyncio.to_thread(service.close)


@pytest.fixture(scope="module")
async def client(served):
    async with MeasureClient(served[1]) as connected:
        yield connected


class _Events:
    """An asyncua subscription handler that queues the ResultReady events."""

    def __init__(self):
        self.queue = asyncio.Queue()

    def event_notification(self, event):
        self.queue.put_nowait(event)

    async def next(self, timeout=10.0):
        return await asyncio.wait_for(self.queue.get(), timeout)


@contextlib.asynccontextmanager
async def _result_ready_events(client):
    events = _Events()
    subscription = await client.client.create_subscription(20, events)
    try:
        event_type = client.client.get_node(ua.NodeId("ResultReadyEventType", client.namespace))
        await subscription.subscribe_events(ua.ObjectIds.Server, event_type)
        yield events
    finally:
        await subscription.delete()


async def _children(node):
    return {(await child.read_browse_name()).Name: child for child in await node.get_children()}


@pytest.mark.anyio
async def test_address_space_layout(client):
    """The nodes the docs' table lists, with their classes, data types and method arguments."""
    objects = client.client.nodes.objects
    holecli = await objects.get_child(f"{client.namespace}:Holecli")
    assert holecli.nodeid == ua.NodeId("Holecli", client.namespace)
    children = await _children(holecli)
    assert {"Measure", "GetResult", "LastError", "LastResult"} <= set(children)
    assert await children["Measure"].read_node_class() == ua.NodeClass.Method
    inputs = await (await children["Measure"].get_child("0:InputArguments")).read_value()
    outputs = await (await children["Measure"].get_child("0:OutputArguments")).read_value()
    assert [(a.Name, a.DataType) for a in inputs] == [("Path", ua.NodeId(ua.ObjectIds.String)),
                                                      ("Spec", ua.NodeId(ua.ObjectIds.String)),
                                                      ("Meta", ua.NodeId(ua.ObjectIds.String))]
    assert [(a.Name, a.DataType) for a in outputs] == [("ResultId", ua.NodeId(ua.ObjectIds.String)),
                                                       ("Holes", ua.NodeId(ua.ObjectIds.UInt32)),
                                                       ("Verdict", ua.NodeId(ua.ObjectIds.String))]
    last = await _children(children["LastResult"])
    assert set(last) == {"ResultId", "Received", "File", "Part", "Serial", "ProcessingTimeMs", "MeasuringTimeMs",
                         "HoleCount", "Verdict", "HoleName", "CenterX", "CenterY", "CenterZ", "Diameter", "NormalX",
                         "NormalY", "NormalZ", "HoleVerdict"}
    assert await last["Diameter"].read_data_type() == ua.NodeId(ua.ObjectIds.Double)
    assert await last["Diameter"].read_value_rank() == ua.ValueRank.OneDimension
    assert await last["HoleCount"].read_data_type() == ua.NodeId(ua.ObjectIds.UInt32)
    assert await last["Received"].read_data_type() == ua.NodeId(ua.ObjectIds.DateTime)
    assert "per hole" in (await last["Diameter"].read_description()).Text
    event_type = await client.client.nodes.base_event_type.get_child(f"{client.namespace}:ResultReadyEventType")
    fields = await _children(event_type)
    assert {"ResultId", "HoleCount", "Verdict", "ProcessingTimeMs"} <= set(fields)
    assert await client.client.get_namespace_index(NAMESPACE_URI) == client.namespace == 2  # as the docs say


@pytest.mark.anyio
async def test_clients_cannot_change_the_address_space_or_the_results(client):
    with pytest.raises(ua.UaStatusCodeError):
        await client.client.nodes.objects.add_folder(client.namespace, "Intruder")
    result_id = client.client.get_node(ua.NodeId("Holecli.LastResult.ResultId", client.namespace))
    with pytest.raises(ua.UaStatusCodeError):
        await result_id.write_value(ua.Variant("forged", ua.VariantType.String))
    assert await result_id.read_value() != "forged"


@pytest.mark.anyio
async def test_measure_table1_updates_last_result_and_fires_one_event(served, client):
    """Measure on Table I: one hole of 3 mm, unchecked; LastResult holds it; one ResultReady event."""
    service = served[0]
    async with _result_ready_events(client) as events:
        result_id, holes, verdict = await client.measure(TABLE1, "", "part=P-7;serial=0042")
        assert (holes, verdict) == (1, "unchecked")
        assert len(result_id) == 32
        event = await events.next()
        assert (event.ResultId, event.HoleCount, event.Verdict) == (result_id, 1, "unchecked")
        assert event.ProcessingTimeMs > 0
        assert event.SourceName == "Holecli"
        with pytest.raises(asyncio.TimeoutError):  # one event per measurement, not one per publisher
            await events.next(timeout=0.3)
    last = await client.last_result()  # written before Measure returned
    assert last["ResultId"] == result_id
    assert last["HoleCount"] == 1 and last["Verdict"] == "unchecked"
    assert last["Diameter"] == [pytest.approx(3.0, abs=0.01)]
    assert last["NormalZ"][0] ** 2 + last["NormalY"][0] ** 2 + last["NormalX"][0] ** 2 == pytest.approx(1.0)
    assert last["HoleVerdict"] == ["unchecked"] and last["HoleName"] == [""]
    assert (last["Part"], last["Serial"], last["File"]) == ("P-7", "0042", TABLE1)
    assert last["ProcessingTimeMs"] >= last["MeasuringTimeMs"] > 0
    stored = await client.result(result_id)  # GetResult: the stored answer
    assert stored["id"] == result_id and stored["stored"] is True
    assert (stored["meta"]["part"], stored["meta"]["serial"]) == ("P-7", "0042")
    assert stored["holes"][0]["diameter"] == pytest.approx(last["Diameter"][0], abs=1e-12)
    assert stored["holes"][0]["center"] == pytest.approx([last["CenterX"][0], last["CenterY"][0], last["CenterZ"][0]])
    assert (await service.result(result_id))["id"] == result_id


@pytest.mark.anyio
async def test_other_front_ends_measurements_are_published(served, client):
    """A measurement asked for over HTTP or TCP (service.measure directly) fires ResultReady too, and
    a scan without a hole empties the per-hole arrays."""
    service = served[0]
    async with _result_ready_events(client) as events:
        answer = await service.measure(MeasureRequest(path=str(SAMPLES / "no_hole.csv"), channel="http"))
        event = await events.next()
    assert event.ResultId == answer["id"] and event.HoleCount == 0
    last = await client.last_result()
    assert last["ResultId"] == answer["id"]
    assert last["HoleCount"] == 0 and last["Diameter"] == [] and last["HoleVerdict"] == []


@pytest.mark.anyio
async def test_measure_with_a_spec_gives_each_holes_name_and_verdict(client):
    """The panel with its spec by name: every hole named and in tolerance, as holecli detect --spec says."""
    result_id, holes, verdict = await client.measure("panel.ply", "panel", '{"part": "panel", "serial": "1"}')
    assert verdict == "pass"
    last = await client.last_result()
    assert last["ResultId"] == result_id and last["HoleCount"] == holes == len(last["Diameter"])
    stored = await client.result(result_id)
    assert last["HoleName"] == [hole.get("name") or "" for hole in stored["holes"]]
    assert {"T1", "C1"} <= set(last["HoleName"])
    assert set(last["HoleVerdict"]) == {"pass"}


@pytest.mark.anyio
async def test_two_clients_measure_at_once(served, client):
    """Two connections' Measure calls run side by side (the loop is never blocked): both answered,
    both stored, one event each."""
    async with MeasureClient(served[1]) as other, _result_ready_events(client) as events:
        answers = await asyncio.gather(client.measure(TABLE1), other.measure(str(SAMPLES / "no_hole.csv")))
        received = {(await events.next()).ResultId, (await events.next()).ResultId}
    assert [holes for _, holes, _ in answers] == [1, 0]
    assert received == {result_id for result_id, _, _ in answers}


@pytest.mark.anyio
@pytest.mark.parametrize("arguments, status, code", [
    (("nope.ply", "", ""), "BadNotFound", "not_found"),
    (("/etc/hostname", "", ""), "BadUserAccessDenied", "forbidden"),
    ((str(SAMPLES / "table1.truth.json"), "", ""), "BadDataUnavailable", "unmeasurable"),
    ((TABLE1, "", "{not json"), "BadInvalidArgument", "bad_request"),
    ((TABLE1, "", "part"), "BadInvalidArgument", "bad_request"),
    ((TABLE1, "", '{"part": 7}'), "BadInvalidArgument", "bad_request"),
    ((TABLE1, "plate-A", ""), "BadNotFound", "not_found"),  # no spec of that name in the spec folder
])
async def test_refused_measure_is_a_bad_status_and_the_server_goes_on(client, arguments, status, code):
    """A refused Measure answers a Bad status code and says why in LastError; the server still answers."""
    with pytest.raises(ua.UaStatusCodeError) as raised:
        await client.measure(*arguments)
    assert type(raised.value).__name__ == status
    assert (await client.last_error()).startswith(f"{code}: ")
    assert (await client.measure(TABLE1))[1] == 1


@pytest.mark.anyio
async def test_wrong_arguments_and_unknown_result(client):
    measure = ua.QualifiedName("Measure", client.namespace)
    with pytest.raises(ua.uaerrors.BadInvalidArgument):
        await client.holecli.call_method(measure, TABLE1, "")
    with pytest.raises(ua.uaerrors.BadInvalidArgument):
        await client.holecli.call_method(measure, TABLE1, ua.Variant(3, ua.VariantType.UInt32), "")
    assert "must be a String" in await client.last_error()
    with pytest.raises(ua.uaerrors.BadNotFound):
        await client.result("0" * 32)
    with pytest.raises(ua.uaerrors.BadInvalidArgument):
        await client.result("../x")
    assert (await client.measure(TABLE1))[1] == 1


@pytest.mark.anyio
@pytest.mark.parametrize("host, port", [("0.0.0.0", 4840), ("192.0.2.7", 4840), ("example.com", 4840),
                                        ("127.0.0.1", 0)])
async def test_refuses_non_loopback_hosts(served, host, port):
    """No security on the endpoint: only a loopback address, and a port the endpoint URL can name."""
    with pytest.raises(OpcUaBindError, match="loopback|port"):
        await start_opcua(served[0], host, port)


@pytest.mark.slow
@pytest.mark.anyio
async def test_holecli_serve_with_opcua(tmp_path):
    """``holecli serve --opcua-port 0``: the ready line names the endpoint; a measurement over HTTP fires
    ResultReady for the OPC UA client and fills LastResult; SIGTERM stops it, exit 0, nothing on stderr."""
    httpx = pytest.importorskip("httpx")
    process = await asyncio.create_subprocess_exec(
        sys.executable, "-m", "holecli", "serve", "--port", "0", "--opcua-port", "0", "--workers", "1", "-q",
        "--allow-dir", str(SAMPLES), "--store", str(tmp_path / "results.sqlite"),
        stdout=asyncio.subprocess.PIPE, stderr=asyncio.subprocess.PIPE, env=dict(os.environ, PYTHONPATH=str(REPO)))
    try:
        addresses = json.loads(await asyncio.wait_for(process.stdout.readline(), 120))
        assert addresses["opcua"].startswith("opc.tcp://127.0.0.1:") and addresses["opcua"].endswith("/holecli/")
        async with MeasureClient(addresses["opcua"]) as client, _result_ready_events(client) as events, \
                httpx.AsyncClient(base_url=addresses["http"], timeout=60) as http:
            answer = (await http.post("/v1/measure", json={"path": "table1.ply"})).json()
            assert (await events.next()).ResultId == answer["id"]
            last = await client.last_result()
            assert last["ResultId"] == answer["id"] and last["Diameter"] == [pytest.approx(3.0, abs=0.01)]
            result_id, _, _ = await client.measure("table1.ply")
            assert (await http.get(f"/v1/results/{result_id}")).json()["holes"][0]["diameter"] == \
                pytest.approx(last["Diameter"][0])
    finally:
        if process.returncode is None:
            process.send_signal(signal.SIGTERM)
        _, err = await asyncio.wait_for(process.communicate(), 60)
    assert process.returncode == 0 and err.decode() == ""


def _certificate(folder, name, uri, usage):
    """A self-signed application certificate (DER) and its key (PEM) in ``folder``."""
    key = cert_gen.generate_private_key()
    certificate = cert_gen.generate_self_signed_app_certificate(
        key, name, {}, [x509.UniformResourceIdentifier(uri), x509.DNSName(socket.gethostname()),
                        x509.DNSName("localhost"), x509.IPAddress(ipaddress.ip_address("127.0.0.1"))], [usage])
    certificate_path, key_path = folder / f"{name}.der", folder / f"{name}.pem"
    certificate_path.write_bytes(certificate.public_bytes(serialization.Encoding.DER))
    key_path.write_bytes(key.private_bytes(serialization.Encoding.PEM, serialization.PrivateFormat.PKCS8,
                                           serialization.NoEncryption()))
    return str(certificate_path), str(key_path)


@pytest.mark.anyio
async def test_secured_endpoint_and_token(served, tmp_path):
    """With a certificate and a token: Basic256Sha256 signed and encrypted, and a session logs in with the
    token as its password; without it, or with another, it is refused."""
    token = "a-token-of-24-characters"
    server_certificate, server_key = _certificate(tmp_path, "server", APPLICATION_URI, ExtendedKeyUsageOID.SERVER_AUTH)
    client_certificate, client_key = _certificate(tmp_path, "client", "urn:holecli:test:client",
                                                  ExtendedKeyUsageOID.CLIENT_AUTH)
    security = f"Basic256Sha256,SignAndEncrypt,{client_certificate},{client_key},{server_certificate}"
    port = _free_port()
    url = endpoint_url("127.0.0.1", port)
    server = await start_opcua(served[0], "127.0.0.1", port, token=token, certificate=server_certificate,
                               private_key=server_key)
    try:
        policies = {(endpoint.SecurityPolicyUri.rsplit("#", 1)[-1], endpoint.SecurityMode.name,
                     tuple(policy.TokenType.name for policy in endpoint.UserIdentityTokens))
                    for endpoint in await server.get_endpoints()}
        assert policies == {("None", "None_", ("UserName",)), ("Basic256Sha256", "SignAndEncrypt", ("UserName",))}
        secured = MeasureClient(url, token=token, security=security)
        secured.client.application_uri = "urn:holecli:test:client"
        async with secured:
            assert (await secured.measure(TABLE1))[1] == 1
        for kwargs, refusal in (({"security": security}, ua.uaerrors.BadIdentityTokenRejected),
                                ({"token": "another-token-of-24-chars"}, ua.uaerrors.BadUserAccessDenied)):
            with pytest.raises(refusal):
                async with MeasureClient(url, **kwargs):
                    pass
    finally:
        await server.stop()


@pytest.mark.parametrize("host, kwargs, match", [
    ("192.0.2.7", {"token": "t" * 16}, "needs a server certificate and key:"),
    ("192.0.2.7", {"certificate": "c.der", "private_key": "k.pem"}, "needs a token:"),
    ("0.0.0.0", {}, "needs a server certificate and key and a token"),
    ("127.0.0.1", {"certificate": "c.der"}, "both"),
])
def test_check_bind_refuses(host, kwargs, match):
    with pytest.raises(OpcUaBindError, match=match):
        check_bind(host, 4840, **kwargs)


@pytest.mark.parametrize("host, kwargs", [
    ("127.0.0.1", {}), ("::1", {"token": "t" * 16}), ("localhost", {}),
    ("192.0.2.7", {"token": "t" * 16, "certificate": "c.der", "private_key": "k.pem"}),
])
def test_check_bind_accepts(host, kwargs):
    check_bind(host, 4840, **kwargs)


def test_throwaway_certificate_names_the_application():
    certificate = x509.load_der_x509_certificate(_throwaway_certificate("127.0.0.1")[0])
    names = certificate.extensions.get_extension_for_class(x509.SubjectAlternativeName).value
    assert APPLICATION_URI in names.get_values_for_type(x509.UniformResourceIdentifier)
    assert "127.0.0.1" in [str(address) for address in names.get_values_for_type(x509.IPAddress)]
    assert certificate.not_valid_after_utc - certificate.not_valid_before_utc <= datetime.timedelta(days=1)


@pytest.mark.parametrize("hole, verdict", [
    ({}, "unchecked"), ({"in_tolerance": None}, "unchecked"), ({"in_tolerance": True}, "pass"),
    ({"in_tolerance": False, "failed_checks": ["diameter"]}, "fail"),
    ({"in_tolerance": False, "failed_checks": [], "undecided_checks": ["position"]}, "undecided"),
    ({"in_tolerance": False, "failed_checks": [], "undecided_checks": []}, "fail"),
])
def test_hole_verdict(hole, verdict):
    # LastResult/HoleVerdict gives each hole's word of holecli.store.schema.hole_verdict_word
    answer = {"id": "a" * 32, "holes": [dict(hole, center=[0.0, 0.0, 0.0], diameter=3.0, normal=[0.0, 0.0, 1.0])]}
    assert _last_result_values(answer)["HoleVerdict"].Value == [verdict]


@pytest.mark.parametrize("text, meta", [
    ("", {}), ("  ", {}), ("part=P-7;serial=0042", {"part": "P-7", "serial": "0042"}),
    ("part = P 7 ; serial=;", {"part": "P 7", "serial": ""}), ('{"cell": "C2"}', {"cell": "C2"}),
])
def test_parse_meta(text, meta):
    assert _parse_meta(text) == meta


@pytest.mark.parametrize("text, match", [("part", "key=value"), ("=x", "key=value"), ("{", "JSON"),
                                         ('{"a": 1', "JSON"), ("[1]", "key=value")])
def test_parse_meta_refuses(text, match):
    with pytest.raises(ServiceError, match=match) as raised:
        _parse_meta(text)
    assert raised.value.status == 400


def test_the_faults_answered_to_clients_stay_out_of_the_services_log():
    import logging

    from holecli.serve.opcua import AnswersToClients

    def record(message, *args):
        return logging.LogRecord("asyncua.server.uaprocessor", logging.ERROR, __file__, 1, message, args, None)

    keep = AnswersToClients().filter
    assert not keep(record("sending service fault response: %s (%s)", "no subscription", "BadNoSubscription"))
    assert keep(record("Error while processing message"))

