"""``holecli serve``: the measurement service of a drilling cell (HTTP, a TCP line protocol, OPC UA),
every answered measurement stored (SQLite or PostgreSQL). The service itself is :mod:`holecli.serve`."""

from __future__ import annotations

import json
import os
import sys

import click

from holecli.cli.exits import EXIT_INPUT, EXIT_OK, Failure, run_guarded
from holecli.cli.types import Decimal

SERVE_EXIT_CODES_HELP = (
    "\b\nExit codes:\n"
    "  0  stopped by SIGTERM or Ctrl-C, after answering the requests in flight\n"
    "  1  internal error (a bug)\n"
    "  2  usage error (a bind beyond the loopback interface without --token-file; a --token-file, --allow-dir or\n"
    "     --spec-dir that does not exist)\n"
    "  3  cannot start: the store cannot be opened, a port is in use, the token file is unreadable, readable by\n"
    "     others or its token shorter than 16 characters\n"
    "  130  a second SIGTERM or Ctrl-C while stopping, or one while starting"
)


@click.command(epilog=SERVE_EXIT_CODES_HELP)
@click.option("--host", default="127.0.0.1", show_default=True,
              help="The address every front end binds to; beyond the loopback interface --token-file is required.")
@click.option("--port", type=click.IntRange(0, 65535), default=8000, show_default=True,
              help="The HTTP port (0: a free one, said on stdout when ready).")
@click.option("--tcp-port", type=click.IntRange(0, 65535), default=None, metavar="PORT",
              help="Also answer the line protocol on this TCP port (0: a free one; LMI Gocator's ASCII channel is "
                   "8190).")
@click.option("--tcp-units", type=click.Choice(["mm", "um"]), default="mm", show_default=True,
              help="The line protocol's lengths: decimal millimetres (4 decimals), or integer micrometres.")
@click.option("--opcua-port", type=click.IntRange(0, 65535), default=None, metavar="PORT",
              help="Also serve OPC UA on this port (0: a free one; the usual is 4840). Needs the extra opcua "
                   "(asyncua).")
@click.option("--opcua-cert", type=click.Path(exists=True, dir_okay=False, path_type=str), default=None,
              metavar="PEM",
              help="The OPC UA server's certificate: its endpoint then offers Basic256Sha256 (signed and encrypted) "
                   "only; needed, with --opcua-key and --token-file, beyond the loopback interface.")
@click.option("--opcua-key", type=click.Path(exists=True, dir_okay=False, path_type=str), default=None,
              metavar="PEM",
              help="The private key of --opcua-cert.")
@click.option("--store", "store_location", default="results.sqlite", show_default=True, metavar="FILE|URL",
              help="Where every answered measurement is committed before the answer leaves: a SQLite file, or "
                   "postgresql://USER@HOST/DB (the extra postgres).")
@click.option("--spec-dir", type=click.Path(exists=True, file_okay=False, path_type=str), default=None,
              help="The named specs (NAME.toml) and registrations (NAME.json) a request may name.")
@click.option("--allow-dir", "allow_dirs", multiple=True,
              type=click.Path(exists=True, file_okay=False, path_type=str),
              help="A folder whose scans a request may name (repeatable); without one, scans must be uploaded.")
@click.option("--token-file", type=click.Path(exists=True, dir_okay=False, path_type=str), default=None,
              help="A file (mode 600) whose first line is the bearer token every request must carry.")
@click.option("--workers", type=click.IntRange(min=1), default=None, metavar="N",
              help="Worker processes measuring scans  [default: the cores this process may use]")
@click.option("--max-upload-mb", type=Decimal(min=0, min_open=True), default=256, show_default=True,
              help="The largest scan a request may carry.")
@click.option("--request-timeout", type=Decimal(min=0, min_open=True), default=60, show_default=True,
              metavar="SECONDS", help="The longest a scan may take to measure (then 408).")
@click.option("--worker-memory-mb", type=Decimal(min=0, min_open=True), default=4096, show_default=True,
              help="The memory a worker may add to its size when ready (a larger scan gets 413).")
@click.option("--quiet", "-q", is_flag=True, help="Say nothing on stderr but errors.")
def serve(host, port, tcp_port, tcp_units, opcua_port, opcua_cert, opcua_key, store_location, spec_dir, allow_dirs,
          token_file, workers, max_upload_mb, request_timeout, worker_memory_mb, quiet):
    """Measure scans on request, as a service of the cell: HTTP, a line protocol over TCP, OPC UA.

    One process loads once and answers: POST /v1/measure (a file it may read, or the scan itself),
    GET /v1/results/ID, GET /v1/results?part=&serial=&since=&verdict=, GET /v1/health, GET /metrics,
    /openapi.json. Every answer is the record holecli detect writes, with id, received,
    processing_ms and stored, and it is in the store before it leaves. When every front end listens,
    one JSON line on stdout gives their addresses.

    \b
    Examples:
      holecli serve --allow-dir /data/scans --spec-dir /etc/holecli/specs
      holecli serve --tcp-port 8190 --store postgresql://holecli@db/cell7
      curl -s localhost:8000/v1/measure -H 'Content-Type: application/json' -d '{"path": "hole7.ply"}'
    """
    run_guarded(_serve, host, port, tcp_port, tcp_units, opcua_port, opcua_cert, opcua_key, store_location, spec_dir,
                allow_dirs, token_file, workers, max_upload_mb, request_timeout, worker_memory_mb, quiet)
    sys.exit(EXIT_OK)


def _serve(host, port, tcp_port, tcp_units, opcua_port, opcua_cert, opcua_key, store_location, spec_dir, allow_dirs,
           token_file, workers, max_upload_mb, request_timeout, worker_memory_mb, quiet):
    import asyncio

    from holecli.batch.discover import default_jobs
    from holecli.serve.security import is_loopback, read_token

    if not is_loopback(host) and token_file is None:
        raise click.UsageError(f"--host {host} is beyond the loopback interface: give --token-file, the bearer "
                               "token every request must carry")
    token = None
    if token_file is not None:
        try:
            token = read_token(token_file)
        except (OSError, ValueError) as error:
            raise Failure(str(error) if isinstance(error, ValueError) else f"{token_file}: {error.strerror or error}",
                          EXIT_INPUT) from None
    opcua = None
    if opcua_port is not None:
        try:
            from holecli.serve.opcua import OpcUaBindError, check_bind
        except ImportError as error:
            raise Failure(f"--opcua-port needs the extra opcua (pip install 'holecli[opcua]'): {error}", EXIT_INPUT) \
                from None
        try:  # (port 0, a free one, is chosen later: any port passes here)
            check_bind(host, opcua_port or 4840, token=token, certificate=opcua_cert, private_key=opcua_key)
        except OpcUaBindError as error:
            raise click.UsageError(str(error)) from None
        opcua = {"port": opcua_port, "certificate": opcua_cert, "private_key": opcua_key}
    elif opcua_cert is not None or opcua_key is not None:
        raise click.UsageError("--opcua-cert and --opcua-key are for --opcua-port")
    try:
        from holecli.serve import server
        from holecli.serve.service import Service
    except ImportError as error:
        raise Failure(f"holecli serve needs the extra serve (pip install 'holecli[serve]'): {error}", EXIT_INPUT) \
            from None
    from holecli.store import StoreError, open_store

    def cannot_listen(name, number, error):
        option = "--port" if name == "http" else "--tcp-port"
        return Failure(f"{host}:{number}: cannot listen there ({option}): {error.strerror or error}", EXIT_INPUT)

    listeners = server.Listeners()
    try:
        for name, number in (("http", port), ("tcp", tcp_port)):
            if number is not None:
                try:
                    setattr(listeners, name, server.bind(host, number))
                except OSError as error:
                    raise cannot_listen(name, number, error) from None
        try:
            store = open_store(store_location)
        except StoreError as error:
            raise Failure(str(error), EXIT_INPUT) from None
        service = Service(store, workers=workers or default_jobs(), allow_dirs=allow_dirs, spec_dir=spec_dir,
                          max_upload_bytes=int(max_upload_mb * 2**20), request_timeout=request_timeout,
                          worker_memory_mb=worker_memory_mb)
        try:
            service.warm()
            for name in ("http", "tcp"):
                sock = getattr(listeners, name)
                try:  # only now (refused until the workers are warm); another server may have bound it too
                    if sock is not None:
                        sock.listen(128)
                except OSError as error:
                    raise cannot_listen(name, sock.getsockname()[1], error) from None

            def ready(addresses):
                line = json.dumps(dict(addresses, store=store.location, workers=service.workers, pid=os.getpid()))
                sys.stdout.write(line + "\n")
                sys.stdout.flush()
                if not quiet:
                    shown = ", ".join(f"{key} {value}" for key, value in addresses.items() if value)
                    click.echo(f"holecli serve: {shown}; store {store.location}; {service.workers} workers", err=True)

            asyncio.run(server.run(service, listeners, host=host, token=token, tcp_units=tcp_units,
                                   opcua=opcua, ready=ready, graceful_seconds=request_timeout + 5))
        finally:
            service.close()
    finally:
        listeners.close()
    if not quiet:
        click.echo("holecli serve: stopped", err=True)
