"""``holecli serve``'s one event loop: the HTTP server (uvicorn), the TCP line protocol and OPC UA side
by side, started on sockets bound beforehand, and stopped on SIGTERM or Ctrl-C after the requests in
flight are answered.

uvicorn handles signals itself and raises them again once it has drained its connections (the
process would then die of SIGTERM, exit status 143); here the loop's own handlers stop every front end
and :func:`run` returns, so that ``holecli serve`` exits 0.
"""

from __future__ import annotations

import asyncio
import contextlib
import signal
import socket

from holecli import interrupts
from holecli.serve.lines import close_lines, serve_lines

__all__ = ["Listeners", "bind", "run"]


class Listeners:
    """The sockets of the front ends, bound before the workers start (so that a port in use is said at
    once), listening only once the service is ready."""

    def __init__(self):
        self.http = None
        self.tcp = None

    def close(self):
        for sock in (self.http, self.tcp):
            if sock is not None:
                sock.close()


def bind(host, port) -> socket.socket:
    """A TCP socket bound to ``host:port`` (0: a free port), address reuse on, not yet listening.

    Raises
    ------
    OSError
        The port is in use, the address is not this machine's, ...
    """
    family = socket.AF_INET6 if ":" in host else socket.AF_INET
    # IPPROTO_TCP, not 0: asyncio turns Nagle's algorithm off (TCP_NODELAY) only on sockets that say
    # they are TCP; with it on, each answer on a kept-alive connection waited 40 ms for the client's
    # delayed acknowledgement of its headers before sending its body.
    sock = socket.socket(family, socket.SOCK_STREAM, socket.IPPROTO_TCP)
    try:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        sock.bind((host, port))
        sock.set_inheritable(False)
    except OSError:
        sock.close()
        raise
    return sock


def _free_port(host):
    with contextlib.closing(bind(host, 0)) as sock:
        return sock.getsockname()[1]


def _url(scheme, host, port):
    shown = f"[{host}]" if ":" in host else host
    return f"{scheme}://{shown}:{port}"


async def run(service, listeners, *, host, token=None, tcp_units="mm", opcua=None, ready=None,
              graceful_seconds=65.0):
    """Serve ``service`` until SIGTERM or SIGINT, then answer what is in flight and return.

    Parameters
    ----------
    service : holecli.serve.service.Service
    listeners : Listeners
        ``http`` listening (always), ``tcp`` listening or None: bound before the workers started,
        listening once they are warm (``holecli serve`` does both).
    host : str
        Where OPC UA binds.
    token : str, optional
        The bearer token HTTP asks for (and the line protocol's ``AUTH``, OPC UA's login password).
    tcp_units : {"mm", "um"}
        How the line protocol writes lengths.
    opcua : dict, optional
        Serve OPC UA: ``port`` (0: a free one), ``certificate`` and ``private_key`` (PEM files, or None;
        see :func:`holecli.serve.opcua.start_opcua`).
    ready : callable, optional
        Called with ``{"http": URL, "tcp": "HOST:PORT" or None, "opcua": URL or None}`` once every
        front end listens.
    graceful_seconds : float
        How long requests in flight may take to finish after a stop signal.
    """
    import uvicorn

    from holecli.serve.http import create_app

    class Server(uvicorn.Server):
        @contextlib.contextmanager
        def capture_signals(self):  # the loop's own handlers below: no signal is raised again
            yield

    http = Server(uvicorn.Config(create_app(service, token), log_level="warning", lifespan="off", access_log=False,
                                 server_header=False, timeout_keep_alive=15,
                                 timeout_graceful_shutdown=graceful_seconds))
    loop = asyncio.get_running_loop()
    stopped = asyncio.Event()

    def stop(number):
        if stopped.is_set():
            http.force_exit = True
            interrupts.record(number)  # a second signal cuts the requests in flight: holecli serve exits 130
        stopped.set()
        service.stopping = True  # new requests get 503 on every front end; those in flight go on
        http.should_exit = True

    previous = {number: signal.getsignal(number) for number in (signal.SIGINT, signal.SIGTERM)}
    for number in (signal.SIGINT, signal.SIGTERM):
        loop.add_signal_handler(number, stop, number)
    lines = opcua_server = None
    try:
        http_task = asyncio.create_task(http.serve(sockets=[listeners.http]))
        while not http.started:
            if http_task.done():
                await http_task
                return
            await asyncio.sleep(0.01)
        addresses = {"http": _url("http", host, listeners.http.getsockname()[1]), "tcp": None, "opcua": None}
        if listeners.tcp is not None:
            lines = await serve_lines(service, sock=listeners.tcp, units=tcp_units, token=token)
            addresses["tcp"] = "%s:%d" % (host, listeners.tcp.getsockname()[1])
        if opcua is not None:
            from holecli.serve.opcua import endpoint_url, start_opcua

            port = opcua["port"] or _free_port(host)
            opcua_server = await start_opcua(service, host, port, token=token, certificate=opcua.get("certificate"),
                                             private_key=opcua.get("private_key"))
            addresses["opcua"] = endpoint_url(host, port)
        if ready is not None:
            ready(addresses)
        await http_task  # returns once a signal stopped it and its requests in flight were answered
    finally:
        service.stopping = True
        if lines is not None:
            # answers the requests in flight, closes the idle connections (asyncio.Server.wait_closed
            # does not wait for its connections in Python 3.11)
            with contextlib.suppress(Exception):
                await close_lines(lines, graceful_seconds)
        if opcua_server is not None:
            with contextlib.suppress(Exception):
                await opcua_server.stop()
        for number in (signal.SIGINT, signal.SIGTERM):
            loop.remove_signal_handler(number)
            if previous[number] is not None:  # holecli's handlers again: asyncio leaves SIGTERM's default (death)
                signal.signal(number, previous[number])
