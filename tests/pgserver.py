"""A throwaway PostgreSQL server for the tests and benchmarks of the results store.

:func:`postgres_server` runs Debian's ``postgresql`` package's binaries (``initdb``, ``pg_ctl``) on a
new cluster in a folder of its own under /tmp, listening only on 127.0.0.1 at a free port, with
trust authentication for the user ``holecli``; it stops the server and removes the folder on exit,
whatever happened. As root (initdb refuses root) the server runs as the user ``postgres``.
"""

from __future__ import annotations

import glob
import os
import re
import shutil
import socket
import subprocess
import tempfile
from contextlib import contextmanager

USER = "holecli"
"""The database superuser of the throwaway cluster (trust authentication on 127.0.0.1)."""


class NoPostgres(RuntimeError):
    """No PostgreSQL binaries (``initdb``) on this machine."""


def postgres_bindir() -> str:
    """The folder of ``initdb`` and ``pg_ctl``: the highest version of /usr/lib/postgresql/*/bin, else
    ``pg_config --bindir``'s, else the folder of ``initdb`` on PATH.

    Raises
    ------
    NoPostgres
        When no ``initdb`` is found.
    """
    def version(folder):
        match = re.search(r"/postgresql/(\d+)(?:\.(\d+))?/bin$", folder)
        return tuple(int(part or 0) for part in match.groups()) if match else (0, 0)

    candidates = sorted((os.path.dirname(path) for path in glob.glob("/usr/lib/postgresql/*/bin/initdb")),
                        key=version)
    if candidates:
        return candidates[-1]
    if shutil.which("pg_config"):
        found = subprocess.run(["pg_config", "--bindir"], capture_output=True, text=True).stdout.strip()
        if found and os.path.exists(os.path.join(found, "initdb")):
            return found
    initdb = shutil.which("initdb")
    if initdb:
        return os.path.dirname(initdb)
    raise NoPostgres("no PostgreSQL initdb found (/usr/lib/postgresql/*/bin, pg_config, PATH): "
                     "install Debian's postgresql package (scripts/setup.sh does)")


def _free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


def _as_server_user(command):
    """``command`` run as the user ``postgres`` when this process is root (initdb refuses root)."""
    if os.geteuid() == 0:
        return ["runuser", "-u", "postgres", "--", *command]
    return list(command)


def _run(command, timeout=60):
    result = subprocess.run(_as_server_user(command), capture_output=True, text=True, timeout=timeout)
    if result.returncode != 0:
        raise RuntimeError(f"{' '.join(command)} failed ({result.returncode}): {result.stderr.strip()[-2000:]}")
    return result


@contextmanager
def postgres_server(fsync=True):
    """Run a throwaway PostgreSQL server for the block.

    Parameters
    ----------
    fsync : bool
        The server's ``fsync`` (on, PostgreSQL's default: a committed transaction is on disk; off only
        for speed where durability does not matter).

    Yields
    ------
    str
        The URL of its ``postgres`` database, ``postgresql://holecli@127.0.0.1:PORT/postgres``.

    Raises
    ------
    NoPostgres
        When no ``initdb`` is found.
    RuntimeError
        When the cluster cannot be made or the server does not start (the message holds its log).
    """
    bindir = postgres_bindir()
    # not pytest's tmp_path: /tmp/pytest-of-root is closed to the user postgres
    folder = tempfile.mkdtemp(prefix="holecli-pg-", dir="/tmp")
    data = os.path.join(folder, "data")
    log = os.path.join(folder, "log")
    started = False
    try:
        if os.geteuid() == 0:
            import pwd

            user = pwd.getpwnam("postgres")
            os.chown(folder, user.pw_uid, user.pw_gid)
        os.chmod(folder, 0o700)
        _run([os.path.join(bindir, "initdb"), "-D", data, "-U", USER, "--auth=trust", "-E", "UTF8",
              "--locale=C.UTF-8", "--no-sync"])
        for attempt in range(2):  # a port taken between choosing and binding it: once more
            port = _free_port()
            settings = f"-c listen_addresses=127.0.0.1 -p {port} -k {folder}" + ("" if fsync else " -c fsync=off")
            result = subprocess.run(_as_server_user([os.path.join(bindir, "pg_ctl"), "-D", data, "-l", log, "-w",
                                                     "-t", "30", "-o", settings, "start"]),
                                    capture_output=True, text=True, timeout=60)
            if result.returncode == 0:
                started = True
                break
        if not started:
            text = open(log, encoding="utf-8", errors="replace").read()[-2000:] if os.path.exists(log) else ""
            raise RuntimeError(f"PostgreSQL did not start: {result.stderr.strip()} {text}")
        yield f"postgresql://{USER}@127.0.0.1:{port}/postgres"
    finally:
        if started:
            subprocess.run(_as_server_user([os.path.join(bindir, "pg_ctl"), "-D", data, "-m", "fast", "-w", "stop"]),
                           capture_output=True, timeout=60)
        shutil.rmtree(folder, ignore_errors=True)


def database_url(server_url, name) -> str:
    """The URL of the database ``name`` on the server of ``server_url``."""
    return server_url.rsplit("/", 1)[0] + "/" + name


@contextmanager
def fresh_database(server_url):
    """A new, empty database on the server for the block (dropped afterwards, even with
    connections left open).

    Yields
    ------
    str
        Its URL.
    """
    import uuid

    import psycopg

    name = "holecli_" + uuid.uuid4().hex[:16]
    with psycopg.connect(server_url, autocommit=True) as connection:
        connection.execute(f"CREATE DATABASE {name}")
    try:
        yield database_url(server_url, name)
    finally:
        with psycopg.connect(server_url, autocommit=True) as connection:
            connection.execute(f"DROP DATABASE IF EXISTS {name} WITH (FORCE)")
