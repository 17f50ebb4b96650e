"""Writing result files without ever destroying anything.

A result goes where its path says, by the kind of thing that is there:

* a regular file, or a path where nothing is yet: written atomically, through a temporary file in
  the same folder and a rename, so the path holds either the old file or the complete new one (an
  existing file keeps its permissions);
* a symbolic link: its target is what gets written (atomically, when it is a regular file or does
  not exist yet); the link itself stays;
* a character device (``/dev/null``, a terminal) or a FIFO: opened and written directly, never
  replaced;
* ``-``: standard output;
* anything else (a folder, a block device, a socket): refused with an :class:`OSError`, untouched.

A process killed in the middle of an atomic write (SIGKILL, power loss) leaves its temporary file
``.NAME.PID.XXXXXXXX.tmp`` behind; the next write to the same target removes the temporaries whose
process is gone.
"""

from __future__ import annotations

import errno
import os
import re
import secrets
import stat
import sys
import time

__all__ = ["STDOUT", "destination", "write_bytes", "write_bytes_atomic", "write_text", "write_text_atomic"]

# The path that means standard output.
STDOUT = "-"

# Temporaries of holecli 0.1.0 (``.NAME.XXXXXXXX.tmp``, from mkstemp) name no process: they are taken
# for stale once they are this old (an atomic write of a result takes milliseconds).
_LEGACY_TEMPORARY_AGE_S = 600.0


def write_text(path, text):
    """:func:`write_bytes` for UTF-8 text (a file name that is not UTF-8, decoded by Python with
    ``surrogateescape``, is written as its own bytes).

    Parameters
    ----------
    path : str or os.PathLike
        The destination; ``"-"`` is standard output.
    text : str
        The whole content.

    Returns
    -------
    None

    Raises
    ------
    OSError
        As :func:`write_bytes`.
    """
    write_bytes(path, text.encode("utf-8", "surrogateescape"))


def write_bytes(path, payload):
    """Write ``payload`` to ``path`` by what is there (see the module's docstring).

    Parameters
    ----------
    path : str or os.PathLike
        The destination; ``"-"`` is standard output.
    payload : bytes
        The whole content.

    Returns
    -------
    None

    Raises
    ------
    OSError
        When it cannot be written: the folder is missing or read-only, the device is full, the path
        is a folder or a block device or a socket. Whatever was at ``path`` is then untouched, and no
        temporary file is left behind.
    """
    path = os.fspath(path)
    if path == STDOUT:
        _write_stdout(payload)
        return
    kind, target = destination(path)
    if kind == "file":
        write_bytes_atomic(target, payload)
    else:
        _write_stream(target, payload)


def destination(path):
    """What writing to ``path`` is.

    Parameters
    ----------
    path : str or os.PathLike

    Returns
    -------
    (kind, target) : (str, str)
        ``("file", target)`` for a regular file or a path where nothing is yet (``target``: a
        symbolic link's target, else ``path``), ``("stream", path)`` for a character device or a FIFO.

    Raises
    ------
    IsADirectoryError
        For a folder.
    OSError
        For anything else (a block device, a socket): never written.
    """
    path = os.fspath(path)
    target = os.path.realpath(path) if os.path.islink(path) else path
    try:
        status = os.stat(target)
    except FileNotFoundError:
        return "file", target
    if stat.S_ISREG(status.st_mode):
        return "file", target
    if stat.S_ISCHR(status.st_mode) or stat.S_ISFIFO(status.st_mode):
        return "stream", target
    if stat.S_ISDIR(status.st_mode):
        raise IsADirectoryError(errno.EISDIR, "is a folder", path)
    raise OSError(errno.EINVAL, "not a regular file, character device or FIFO (refused, left untouched)", path)


def write_text_atomic(path, text):
    """:func:`write_bytes_atomic` for UTF-8 text.

    Parameters
    ----------
    path : str or os.PathLike
        A regular file or a new path.
    text : str

    Returns
    -------
    None
    """
    write_bytes_atomic(path, text.encode("utf-8"))


def write_bytes_atomic(path, payload):
    """Write ``payload`` to the regular file (or new file) ``path`` through a temporary file in the
    same folder and a rename.

    Callers that do not know what ``path`` is use :func:`write_bytes`, which sends devices, FIFOs,
    symbolic links and ``-`` where they belong and only regular files here.

    Parameters
    ----------
    path : str or os.PathLike
        A regular file or a new path; an existing file keeps its mode.
    payload : bytes

    Returns
    -------
    None

    Raises
    ------
    OSError
        When the folder is missing or not writable; ``path`` is then untouched and no temporary
        file is left behind.
    """
    path = os.fspath(path)
    folder = os.path.dirname(os.path.abspath(path))
    name = os.path.basename(path)
    _remove_stale_temporaries(folder, name)
    try:
        mode = stat.S_IMODE(os.stat(path).st_mode)
    except FileNotFoundError:
        mode = 0o666 & ~_umask()
    temporary = os.path.join(folder, f".{name}.{os.getpid()}.{secrets.token_hex(4)}.tmp")
    handle = os.open(temporary, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
    try:
        with os.fdopen(handle, "wb") as stream:
            stream.write(payload)
            stream.flush()
            os.fsync(stream.fileno())
        os.chmod(temporary, mode)
        os.replace(temporary, path)
    except BaseException:
        try:
            os.unlink(temporary)
        except FileNotFoundError:
            pass
        raise
    _sync_folder(folder)


def _write_stdout(payload):
    stream = getattr(sys.stdout, "buffer", None)
    if stream is None:  # a text-only stdout (a test's capture)
        sys.stdout.write(payload.decode("utf-8"))
    else:
        sys.stdout.flush()
        stream.write(payload)
    sys.stdout.flush()


def _write_stream(path, payload):
    # No O_CREAT, no O_TRUNC: a device or FIFO is written as it is, never made or emptied.
    descriptor = os.open(path, os.O_WRONLY)
    try:
        data = memoryview(payload)
        while data:
            data = data[os.write(descriptor, data):]
    finally:
        os.close(descriptor)


def _remove_stale_temporaries(folder, name):
    """Remove the temporaries of ``name`` left by writers that were killed."""
    ours = re.compile(rf"\.{re.escape(name)}\.([0-9]+)\.[0-9a-f]+\.tmp")
    legacy = re.compile(rf"\.{re.escape(name)}\.[a-z0-9_]{{8}}\.tmp")
    try:
        entries = os.listdir(folder)
    except OSError:
        return
    for entry in entries:
        match = ours.fullmatch(entry)
        if match:
            stale = not _process_exists(int(match.group(1)))
        elif legacy.fullmatch(entry):
            try:
                stale = time.time() - os.lstat(os.path.join(folder, entry)).st_mtime > _LEGACY_TEMPORARY_AGE_S
            except OSError:
                stale = False
        else:
            continue
        if stale:
            try:
                os.unlink(os.path.join(folder, entry))
            except OSError:
                pass


def _process_exists(pid):
    if pid == os.getpid():
        return True  # another thread of this process may be writing it
    try:
        os.kill(pid, 0)
    except (ProcessLookupError, OverflowError):
        return False
    except PermissionError:  # someone else's process: it exists
        return True
    return True


def _sync_folder(folder):
    # The rename is durable only once the folder's entry is on disk.
    try:
        descriptor = os.open(folder, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(descriptor)
    except OSError:
        pass
    finally:
        os.close(descriptor)


def _umask():
    # The only portable way to read the umask is to set it and put it back.
    mask = os.umask(0o022)
    os.umask(mask)
    return mask
