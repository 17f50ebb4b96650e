"""The small files a command reads besides its scans, and the rule that keeps its outputs off its inputs:
:func:`read_spec` (a spec file, size-limited and hashed), :func:`read_registration`,
:func:`read_small_text` and :func:`read_small_bytes`, and :func:`refuse_same_files`.
"""

from __future__ import annotations

import os

from holecli.cli.exits import EXIT_INPUT, EXIT_USAGE, Failure
from holecli.errors import SpecError


# A spec file lists a part's holes, a panel spec a part's features: a few kB. Anything much larger is
# not one of them.
MAX_SPEC_BYTES = 16 << 20


def read_spec(path):
    """The :class:`holecli.tolerance.Spec` of a spec file.

    Parameters
    ----------
    path : str
        The ``--spec`` TOML file.

    Returns
    -------
    holecli.tolerance.Spec
        With ``sha256``, the SHA-256 of the file's bytes as read.

    Raises
    ------
    Failure
        With the input-error code, when the file cannot be read (see :func:`read_small_text`) or is
        not a valid spec.
    """
    import dataclasses
    import hashlib

    from holecli.tolerance import parse_spec

    data = read_small_bytes(path, "a spec")
    text = _utf8(path, data)
    try:
        spec = parse_spec(text, source=path)
    except SpecError as error:
        raise Failure(f"{path}: {error}", EXIT_INPUT) from None
    # the provenance of the record: the SHA-256 of the very bytes that were parsed
    return dataclasses.replace(spec, sha256=hashlib.sha256(data).hexdigest())


def read_small_text(path, what):
    """The UTF-8 text of ``path``, a small TOML file (:func:`read_small_bytes`, decoded).

    Parameters
    ----------
    path : str
        The file.
    what : str
        What it should be, for messages: ``"a spec"``, ``"a panel spec"``.

    Returns
    -------
    str

    Raises
    ------
    Failure
        With the input-error code, when the file is not a regular file, is too large, cannot be
        read or is not UTF-8.
    """
    return _utf8(path, read_small_bytes(path, what))


def _utf8(path, data):
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError:
        raise Failure(f"{path}: not a UTF-8 text file", EXIT_INPUT) from None


def read_small_bytes(path, what):
    """The bytes of ``path``, a small TOML file.

    Only a regular file of at most :data:`MAX_SPEC_BYTES` is read (never a device such as
    ``/dev/zero``, a FIFO, which would block, or a folder).

    Parameters
    ----------
    path : str
        The file.
    what : str
        What it should be, for messages: ``"a spec"``, ``"a panel spec"``.

    Returns
    -------
    bytes

    Raises
    ------
    Failure
        With the input-error code, when the file is not a regular file, is too large or cannot be
        read.
    """
    import stat

    from holecli.io import file_kind

    try:
        status = os.stat(path)
        if not stat.S_ISREG(status.st_mode):
            raise Failure(f"{path}: not a regular file ({file_kind(status.st_mode)}): {what} must be a TOML file",
                          EXIT_INPUT)
        if status.st_size > MAX_SPEC_BYTES:
            raise Failure(f"{path}: {status.st_size} bytes is too large for {what} file "
                          f"(at most {MAX_SPEC_BYTES} bytes)", EXIT_INPUT)
        with open(path, "rb") as stream:
            data = stream.read(MAX_SPEC_BYTES + 1)
    except OSError as error:
        raise Failure(f"{path}: cannot read: {error.strerror or error}", EXIT_INPUT) from None
    if len(data) > MAX_SPEC_BYTES:
        raise Failure(f"{path}: too large for {what} file (more than {MAX_SPEC_BYTES} bytes)", EXIT_INPUT)
    return data


def refuse_same_files(inputs, outputs):
    """Refuse a run whose output is the same file as one of its inputs or as another output.

    Writing it would replace the input the run is reading (``--targets-output`` over ``--targets``,
    ``-o`` over ``--spec``, ``--plot`` over the scan), or write two outputs into one file, the second
    over the first. Same file means the same resolved path (symbolic links followed, also one that
    does not exist yet), or, when both exist, the same device and inode (hard links). A character
    device (``/dev/null``) is no file that can be replaced: it may take any number of outputs.

    Parameters
    ----------
    inputs : iterable of (str, str or None)
        ``(what, path)`` of the files the run reads, ``what`` as the user named it (``"SCAN"``,
        ``"--spec"``); None and ``-`` (stdin) are skipped.
    outputs : iterable of (str, str or None)
        ``(what, path)`` of the files it writes (``"-o/--output"``, ``"--plot"``); None and ``-``
        (stdout) are skipped.

    Returns
    -------
    None

    Raises
    ------
    Failure
        With the usage code (2), naming both: ``--plot scan.ply is the same file as SCAN scan.ply
        (an output never replaces an input)``.
    """
    inputs = [(what, path) for what, path in inputs if path not in (None, "-")]
    outputs = [(what, path) for what, path in outputs if path not in (None, "-") and not _is_device(path)]
    for index, (what, path) in enumerate(outputs):
        for input_what, input_path in inputs:
            if _same_file(path, input_path):
                raise Failure(f"{what} {path} is the same file as {input_what} {input_path} "
                              "(an output never replaces an input)", EXIT_USAGE)
        for other_what, other_path in outputs[:index]:
            if _same_file(path, other_path):
                raise Failure(f"{other_what} {other_path} and {what} {path} are the same file "
                              "(each output needs a file of its own)", EXIT_USAGE)


def _same_file(first, second):
    """Whether two paths name one file: the same device and inode when both exist, else the same
    resolved path."""
    try:
        return os.path.samestat(os.stat(first), os.stat(second))
    except (OSError, ValueError):
        pass
    try:
        return os.path.realpath(first) == os.path.realpath(second)
    except (OSError, ValueError):
        return False


def _is_device(path):
    import stat

    try:
        return stat.S_ISCHR(os.stat(path).st_mode)
    except (OSError, ValueError):
        return False


def read_registration(path):
    """The registration of ``holecli register``'s JSON result, and the record's provenance of it.

    Returns
    -------
    registration : holecli.registration.apply.LoadedRegistration
    provenance : dict
        ``file``, ``sha256`` (of its bytes), ``spec_file``, ``spec_sha256`` (the spec it was fitted
        to), ``verdict``, ``free_dofs``.

    Raises
    ------
    Failure
        With the input-error code, ``FILE: ...``, when it cannot be read, is not JSON or not a
        registration.
    """
    import hashlib
    import json

    from holecli.registration import RegistrationError
    from holecli.registration.apply import parse_registration

    data = read_small_bytes(path, "a registration")
    try:
        registration = parse_registration(json.loads(_utf8(path, data)))
    except json.JSONDecodeError as error:
        raise Failure(f"{path}: not a registration (holecli register's JSON): {error}", EXIT_INPUT) from None
    except RegistrationError as error:
        raise Failure(f"{path}: {error}", EXIT_INPUT) from None
    provenance = {"file": path, "sha256": hashlib.sha256(data).hexdigest(), "spec_file": registration.spec_file,
                  "spec_sha256": registration.spec_sha256, "verdict": registration.verdict,
                  "free_dofs": list(registration.free_dofs)}
    return registration, provenance
