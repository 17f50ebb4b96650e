"""Reading a point cloud from a stream (standard input): :func:`read_stream` copies it into a temporary
file that leaves nothing behind and reads that as :func:`holecli.io.cloud.read_cloud` reads a file."""

from __future__ import annotations

import os
import re
import secrets
import tempfile

from holecli.errors import LoadError
from holecli.io._common import _describe
from holecli.io.cloud import Cloud, _check_scan, _extension, _finite_cloud, _read_checked

__all__ = ["MAX_STREAM_BYTES", "STDIN_NAME", "read_stream"]

# What messages and records call standard input.
STDIN_NAME = "<stdin>"
# The most :func:`read_stream` reads: a stream has no size to check beforehand and may never end
# (``cat /dev/zero |``). 2 GiB is some 89 million points of a binary PLY with double x, y, z, far
# beyond a scan of one part; a larger cloud can still be read from a file.
MAX_STREAM_BYTES = 2 << 30

def read_stream(stream, input_format, name=STDIN_NAME, max_bytes=None, scan=None, columns=None) -> Cloud:
    """Read the points of a cloud from a binary stream (standard input: ``sys.stdin.buffer``).

    The stream is copied, up to ``max_bytes``, into a temporary file in :func:`tempfile.gettempdir`,
    which is then read and checked exactly as :func:`read_cloud` reads and checks a file of that
    format: damaged data is refused alike. The readers that open a file by its name (E57, LAS) get
    it as ``/proc/self/fd/N``. On Linux that file has no name at all (``O_TMPFILE``, else it is
    unlinked as soon as it is made): whatever happens, a SIGKILL in the middle of the copy too,
    nothing is left behind. Where there is no ``/proc/self/fd``, the file is named
    ``holecli-stdin-PID-XXXXXXXX.FORMAT`` and removed before this returns, and one left by a
    process that was killed is removed by the next :func:`read_stream` (as are the
    ``holecli-stdin-XXXXXXXX.FORMAT`` of holecli before 0.2 once an hour old).

    Parameters
    ----------
    stream : binary file object
        Read to its end (``read`` returning ``b""``).
    input_format : {"ply", "pcd", "csv", "txt", "xyz"}
        Its format: a stream has no extension.
    name : str
        What messages and :attr:`Cloud.path` call the stream.
    max_bytes : int, optional
        The most that is read (default :data:`MAX_STREAM_BYTES`); a longer stream is refused (it is
        read no further).
    scan : int, optional
        As for :func:`read_cloud` (an E57 stream's scan).
    columns : sequence of 3 (str or int), optional
        As for :func:`read_cloud`.

    Returns
    -------
    Cloud
        As :func:`read_cloud`, with ``path`` ``name``.

    Raises
    ------
    LoadError
        Named ``name``: the stream is longer than ``max_bytes``, cannot be read, or holds no valid
        cloud of that format (as :func:`read_cloud`), or the temporary file cannot be written.
    ValueError
        When ``input_format`` is not one of :data:`INPUT_FORMATS`.

    Examples
    --------
    >>> import io
    >>> from holecli.io import read_stream
    >>> read_stream(io.BytesIO(b"x,y,z\\n0,0,0\\n1,0,0\\n0,1,0\\n"), "csv").points.shape
    (3, 3)
    >>> read_stream(io.BytesIO(b""), "ply")
    Traceback (most recent call last):
        ...
    holecli.errors.LoadError: <stdin>: empty file
    """
    _check_scan(scan)
    extension = _extension("", input_format)
    max_bytes = MAX_STREAM_BYTES if max_bytes is None else max_bytes
    try:
        descriptor, path, temporary = _stream_copy_file(extension)
    except OSError as exc:
        raise LoadError(name, f"cannot make a temporary file to read it into ({_describe(exc)})") from None
    try:
        with os.fdopen(descriptor, "wb", closefd=False) as copy:
            _copy_stream(stream, copy, max_bytes, name)
        raw, flagged, units, read = _read_checked(path, extension, name, scan, columns)
        return _finite_cloud(raw, name, flagged, units, read)
    finally:
        os.close(descriptor)
        if temporary is not None:
            try:
                os.unlink(temporary)
            except OSError:
                pass


# The names of read_stream's copies: holecli-stdin-PID-XXXXXXXX.FORMAT, and those of holecli before
# 0.2 (mkstemp's, no PID), taken for stale once _LEGACY_COPY_AGE_S old (a copy in use is written to
# or read within seconds; a stream of 2 GiB is copied in minutes).
_COPY_PREFIX = "holecli-stdin-"
_COPY_NAME = re.compile(r"holecli-stdin-([0-9]+)-[a-z0-9_]{8}\.[a-z0-9]+")
_LEGACY_COPY_NAME = re.compile(r"holecli-stdin-[a-z0-9_]{8}\.[a-z0-9]+")
_LEGACY_COPY_AGE_S = 3600.0
# Where a process's open files have a path (Linux): the copy of a stream needs no name of its own.
_FD_FOLDER = "/proc/{pid}/fd"


def _stream_copy_file(extension):
    """A new file for :func:`read_stream`'s copy: ``(descriptor, path to read it by, name to remove)``.

    With ``/proc/self/fd`` (Linux) the file has no name, so that nothing can be left of it: the path
    is ``/proc/self/fd/N`` and the name to remove None. Otherwise a file named by this process's id,
    which this run removes, or a later one when this process was killed.
    """
    folder = tempfile.gettempdir()
    _remove_stale_copies(folder)
    fd_folder = _FD_FOLDER.format(pid=os.getpid())
    if os.path.isdir(fd_folder):
        descriptor = None
        if hasattr(os, "O_TMPFILE"):
            try:
                descriptor = os.open(folder, os.O_TMPFILE | os.O_RDWR, 0o600)
            except OSError:  # a file system without O_TMPFILE: a named file, unlinked at once
                descriptor = None
        if descriptor is None:
            descriptor, temporary = tempfile.mkstemp(prefix=f"{_COPY_PREFIX}{os.getpid()}-", suffix=extension)
            os.unlink(temporary)
        return descriptor, os.path.join(fd_folder, str(descriptor)), None
    descriptor, temporary = _named_copy(folder, extension)
    return descriptor, temporary, temporary


def _named_copy(folder, extension):
    while True:
        temporary = os.path.join(folder, f"{_COPY_PREFIX}{os.getpid()}-{secrets.token_hex(4)}{extension}")
        try:
            return os.open(temporary, os.O_RDWR | os.O_CREAT | os.O_EXCL, 0o600), temporary
        except FileExistsError:
            continue


def _remove_stale_copies(folder):
    """Remove the copies of standard input that killed processes left in ``folder``."""
    from holecli.io.outfile import remove_stale

    remove_stale(folder, _COPY_NAME, _LEGACY_COPY_NAME, _LEGACY_COPY_AGE_S)


def _copy_stream(stream, copy, max_bytes, name):
    """Copy ``stream`` to the file ``copy``, refusing more than ``max_bytes``."""
    copied = 0
    while True:
        try:
            chunk = stream.read(min(1 << 20, max_bytes + 1 - copied))
        except OSError as exc:
            raise LoadError(name, f"cannot read ({_describe(exc)})") from None
        if not chunk:
            return
        copied += len(chunk)
        if copied > max_bytes:
            raise LoadError(name, f"more than {max_bytes} bytes: too large to read from a stream "
                                  f"(give the file's name instead)")
        try:
            copy.write(chunk)
        except OSError as exc:
            raise LoadError(name, f"cannot copy it into a temporary file ({_describe(exc)})") from None
