"""Writing result files without ever destroying anything.

A result goes where its path says, by the kind of thing that is there:

* a regular file, or a path where nothing is yet: written atomically, through a temporary file in
  the same folder and a rename, so the path holds either the old file or the complete new one (an
  existing file keeps its permissions);
* a symbolic link: its target is what gets written (atomically, when it is a regular file or does
  not exist yet); the link itself stays;
* a character device (``/dev/null``, a terminal) or a FIFO: opened and written directly, never
  replaced. A FIFO is opened without waiting (``O_NONBLOCK``): one that no process reads is refused
  with an :class:`OSError` (``ENXIO``) instead of blocking the run forever;
* ``-``: standard output;
* anything else (a folder, a block device, a socket): refused with an :class:`OSError`, untouched.

The outputs of one run are written all or none by :class:`Outputs`, a small transaction: every
output is first *staged* (a file's complete content written and synced into its temporary, a
device or FIFO opened), then *committed*: the streams (standard output, devices, FIFOs) are
written, and only then the temporaries renamed over their files, one after the other; should one
rename fail, the files already renamed get their earlier content back (kept as a hard link until
the commit is over). A failure anywhere before the renames (a file that cannot be written, a FIFO
without a reader, a full stdout) removes every temporary and replaces no file. What went to a
stream cannot be taken back: streams are written after every file was staged, so a run whose file
cannot be written prints nothing. :func:`write_bytes` is that transaction with one output.

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

from holecli import interrupts

__all__ = ["STDOUT", "Outputs", "destination", "open_stream", "remove_stale", "write_bytes", "write_bytes_atomic", "write_text", "write_text_atomic"]

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
        is a folder or a block device or a socket, a FIFO has no reader. Whatever was at ``path`` is
        then untouched, and no temporary file is left behind. Its ``filename`` is ``path``.
    """
    with Outputs() as outputs:
        outputs.add(path, payload)
        outputs.commit()


class Outputs:
    """The outputs of one run, written all or none (see the module's docstring).

    Use it as a context manager: leaving the ``with`` block without :meth:`commit` (an exception, a
    signal) discards what was staged.

    Parameters
    ----------
    write_stdout : callable, optional
        Writes the payload of ``-`` (bytes) to standard output at the commit (default: the bytes to
        ``sys.stdout``).

    Examples
    --------
    >>> import os, tempfile
    >>> folder = tempfile.mkdtemp()
    >>> with Outputs() as outputs:
    ...     outputs.add(os.path.join(folder, "result.json"), b"{}\\n")
    ...     outputs.add(os.path.join(folder, "targets.csv"), b"name,x,y,z\\n")
    ...     outputs.commit()
    >>> sorted(os.listdir(folder))
    ['result.json', 'targets.csv']
    """

    def __init__(self, write_stdout=None):
        self._write_stdout = write_stdout or _write_stdout
        self._files = []  # (path as given, temporary, target)
        self._streams = []  # (path as given, descriptor or None for stdout, payload)

    def __enter__(self):
        return self

    def __exit__(self, *exc_info):
        self.discard()
        return False

    def add(self, path, payload):
        """Stage ``payload`` for ``path``: a file's temporary written and synced, a device or FIFO opened.

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
            With ``filename`` ``path``, when it cannot be written (see :func:`write_bytes`); nothing
            of it is left behind (what was staged before stays staged: :meth:`discard` drops it).
        """
        path = os.fspath(path)
        if path == STDOUT:
            self._streams.append((path, None, payload))
            return
        try:
            kind, target = destination(path)
            if kind == "file":
                self._files.append((path, _stage(target, payload), target))
            else:
                self._streams.append((path, open_stream(target), payload))
        except OSError as error:
            raise _named(error, path) from None

    def commit(self):
        """Write the streams, then rename every staged file into place.

        Returns
        -------
        None

        Raises
        ------
        OSError
            With ``filename`` the output's path (stdout's as raised), when a stream cannot be written (no file is then
            replaced) or a rename fails (the files renamed before it get their earlier content
            back). The temporaries are removed either way. A BrokenPipeError (a FIFO or stdout
            whose reader went away) stays one.
        """
        try:
            interrupts.check()  # a signal whose KeyboardInterrupt was swallowed: commit nothing
            for path, descriptor, payload in self._streams:
                if descriptor is None:
                    self._write_stdout(payload)  # its errors as they are: stdout has no path
                    continue
                try:
                    _write_all(descriptor, payload)
                except OSError as error:
                    raise _named(error, path) from None
            _rename_all(self._files)
        finally:
            self.discard()

    def discard(self):
        """Drop what is staged: remove the temporaries, close the streams (nothing is written).

        Returns
        -------
        None
        """
        files, streams = self._files, self._streams
        self._files, self._streams = [], []
        for _path, temporary, _target in files:
            _unlink_quietly(temporary)
        for _path, descriptor, _payload in streams:
            if descriptor is not None:
                try:
                    os.close(descriptor)
                except OSError:
                    pass


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
    temporary = _stage(path, payload)
    try:
        interrupts.check()  # a signal whose KeyboardInterrupt was swallowed: replace nothing
        os.replace(temporary, path)
    except BaseException:
        _unlink_quietly(temporary)
        raise
    _sync_folder(os.path.dirname(os.path.abspath(path)))


def _stage(path, payload):
    """Write ``payload`` into a new temporary next to ``path`` (synced, with the mode ``path`` has or
    a new file gets) and return its name; on failure nothing is left."""
    folder = os.path.dirname(os.path.abspath(path))
    name = os.path.basename(path)
    _remove_stale_temporaries(folder, name)
    try:
        mode = stat.S_IMODE(os.stat(path).st_mode)
    except FileNotFoundError:
        mode = 0o666 & ~_umask()
    temporary = _temporary_name(folder, name)
    handle = os.open(temporary, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
    try:
        with os.fdopen(handle, "wb") as stream:
            stream.write(payload)
            stream.flush()
            os.fsync(stream.fileno())
        os.chmod(temporary, mode)
    except BaseException:
        _unlink_quietly(temporary)
        raise
    return temporary


def _temporary_name(folder, name):
    # The pid in the name lets a later run tell a temporary of a killed process (_remove_stale_temporaries).
    return os.path.join(folder, f".{name}.{os.getpid()}.{secrets.token_hex(4)}.tmp")


def _rename_all(files):
    """Rename each staged ``(path, temporary, target)`` over its target; when one fails, put the
    targets renamed before it back as they were, and raise."""
    done = []  # (target, its earlier content kept as a hard link, or None when it was new)
    try:
        for path, temporary, target in files:
            backup = _keep_earlier(target) if len(files) > 1 else None
            try:
                os.replace(temporary, target)
            except OSError as error:
                if backup is not None:
                    _unlink_quietly(backup)
                raise _named(error, path) from None
            done.append((target, backup))
    except BaseException:
        for target, backup in reversed(done):
            try:
                if backup is None:
                    os.unlink(target)
                elif backup is not _NO_BACKUP:
                    os.replace(backup, target)
            except OSError:
                pass
        raise
    finally:
        for _target, backup in done:
            if backup is not None and backup is not _NO_BACKUP:
                _unlink_quietly(backup)
    for folder in dict.fromkeys(os.path.dirname(os.path.abspath(target)) for _path, _temporary, target in files):
        _sync_folder(folder)


# _keep_earlier's answer for an existing file that could not be kept (a file system without hard
# links): the commit goes on, but that file cannot be put back.
_NO_BACKUP = object()


def _keep_earlier(target):
    """A hard link to the file at ``target`` (its earlier content, to put back), None when there is none."""
    if not os.path.lexists(target):
        return None
    backup = _temporary_name(os.path.dirname(os.path.abspath(target)), os.path.basename(target))
    try:
        os.link(target, backup)
    except OSError:
        return _NO_BACKUP
    return backup


def _unlink_quietly(path):
    try:
        os.unlink(path)
    except OSError:
        pass


def _named(error, path):
    """``error`` as raised for ``path`` (its subclass kept: a BrokenPipeError stays one)."""
    if error.errno is None or error.filename == path:
        return error
    return OSError(error.errno, error.strerror, path)


def _write_stdout(payload):
    stream = getattr(sys.stdout, "buffer", None)
    if stream is None:  # a text-only stdout (a test's capture)
        sys.stdout.write(payload.decode("utf-8"))
    else:
        sys.stdout.flush()
        stream.write(payload)
    sys.stdout.flush()


def open_stream(path):
    """Open a character device or FIFO for writing, as it is (no O_CREAT, no O_TRUNC: never made or
    emptied) and without waiting: a FIFO that no process reads is refused (ENXIO)."""
    try:
        descriptor = os.open(path, os.O_WRONLY | os.O_NONBLOCK)
    except OSError as error:
        if error.errno == errno.ENXIO and _is_fifo(path):
            raise OSError(errno.ENXIO, "a FIFO that no process reads (refused rather than waiting for a reader)",
                          path) from None
        raise
    try:
        os.set_blocking(descriptor, True)  # a slow reader is waited for, as by any writer
    except BaseException:
        os.close(descriptor)
        raise
    return descriptor


def _is_fifo(path):
    try:
        return stat.S_ISFIFO(os.stat(path).st_mode)
    except OSError:
        return False


def _write_all(descriptor, payload):
    data = memoryview(payload)
    while data:
        data = data[os.write(descriptor, data):]


def _remove_stale_temporaries(folder, name):
    """Remove the temporaries of ``name`` left by writers that were killed."""
    remove_stale(folder, re.compile(rf"\.{re.escape(name)}\.([0-9]+)\.[0-9a-f]+\.tmp"),
                 re.compile(rf"\.{re.escape(name)}\.[a-z0-9_]{{8}}\.tmp"), _LEGACY_TEMPORARY_AGE_S)


def remove_stale(folder, ours, legacy, legacy_age_s):
    """Remove the files of ``folder`` that killed holecli processes left behind.

    Parameters
    ----------
    folder : str
        Where to look (a folder that cannot be listed is left alone).
    ours : re.Pattern
        The names with the writer's process id as group 1: stale once that process is gone.
    legacy : re.Pattern
        The names of older releases, without a process id: stale once ``legacy_age_s`` old.
    legacy_age_s : float
        Seconds.

    Returns
    -------
    None
    """
    try:
        entries = os.listdir(folder)
    except OSError:
        return
    for entry in entries:
        path = os.path.join(folder, entry)
        match = ours.fullmatch(entry)
        if match:
            stale = not _process_exists(int(match.group(1)))
        elif legacy.fullmatch(entry):
            try:
                stale = time.time() - os.lstat(path).st_mtime > legacy_age_s
            except OSError:
                stale = False
        else:
            continue
        if stale:
            try:
                os.unlink(path)
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
