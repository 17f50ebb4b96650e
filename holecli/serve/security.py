"""What a request may touch: the folders whose scans it may name (``--allow-dir``), and the bearer
token a service bound beyond the loopback interface asks for (``--token-file``).

Pure checks on strings and the file system; no web framework here.
"""

from __future__ import annotations

import hmac
import ipaddress
import os

__all__ = ["AccessError", "confine", "is_loopback", "is_the_token", "read_token", "token_matches"]


class AccessError(Exception):
    """A path a request may not read; ``status`` 400 (malformed), 403 (outside the allowed folders)
    or 404 (no such file)."""

    def __init__(self, message, status):
        super().__init__(message)
        self.status = status


def confine(path, allowed):
    """The real path of the scan ``path`` when it is a regular file inside one of ``allowed``.

    Parameters
    ----------
    path : str
        As the request names it: absolute, or relative to the first allowed folder.
    allowed : sequence of str
        The ``--allow-dir`` folders, real paths (no symbolic link left in them).

    Returns
    -------
    str
        The file's real path (every symbolic link resolved), which is what the worker reads: a link
        inside an allowed folder that points outside it is refused.

    Raises
    ------
    AccessError
        400: empty, a NUL byte, a ``..`` component (refused as written, before any resolution);
        403: no allowed folder, or the file (resolved) is outside them; 404: not a regular file.
    """
    if not isinstance(path, str) or not path or "\x00" in path:
        raise AccessError("the path is empty or holds a NUL character", 400)
    if ".." in path.replace("\\", "/").split("/"):
        raise AccessError(f"{path}: a path with '..' is refused", 400)
    if not allowed:
        raise AccessError(f"{path}: this service reads no files (start it with --allow-dir)", 403)
    candidate = path if os.path.isabs(path) else os.path.join(allowed[0], path)
    real = os.path.realpath(candidate)
    if not any(_inside(real, folder) for folder in allowed):
        raise AccessError(f"{path}: outside the folders this service may read (--allow-dir)", 403)
    if not os.path.isfile(real):
        raise AccessError(f"{path}: file not found", 404)
    return real


def _inside(path, folder):
    try:
        return os.path.commonpath([path, folder]) == folder
    except ValueError:
        return False


def is_loopback(host) -> bool:
    """Whether ``host`` (an address or ``localhost``) is the loopback interface only."""
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def read_token(path) -> str:
    """The bearer token in the file ``path`` (its first line, stripped; at least 16 characters).

    Raises
    ------
    ValueError
        When it is shorter, or the file is readable by others than its owner.
    """
    mode = os.stat(path).st_mode
    if mode & 0o077:
        raise ValueError(f"{path}: the token file is readable by others (chmod 600 it)")
    with open(path, encoding="utf-8") as stream:
        token = stream.readline().strip()
    if len(token) < 16:
        raise ValueError(f"{path}: the token is shorter than 16 characters")
    return token


def is_the_token(given, token) -> bool:
    """Whether ``given`` (str or bytes: the line protocol's ``AUTH``, an OPC UA password) is ``token``,
    compared in constant time."""
    given = given.encode() if isinstance(given, str) else bytes(given)
    return hmac.compare_digest(given, token.encode())


def token_matches(header, token) -> bool:
    """Whether the ``Authorization`` header ``header`` is ``Bearer <token>`` (compared in constant time)."""
    if token is None:
        return True
    if not header or not header.startswith("Bearer "):
        return False
    return is_the_token(header[len("Bearer "):].strip(), token)
