"""The manifest of a cluster batch (``holecli batch --cluster -o OUT``): ``OUT.manifest``, what is done,
by path and content, so that ``--resume`` measures again a file changed since its record was written.

One JSON Lines entry per record written, appended after the record (one write of one whole line):
``{"path": <the file's resolved path>, "size": <bytes>, "sha256": <hex digest of its bytes>}``
(``size`` and ``sha256`` null when the file could not be read). A file measured again has a later
entry, which counts.
"""

from __future__ import annotations

import hashlib
import json
import os

from holecli.measure import resolved_path

#: What is appended to the ``--output`` file's name to name its manifest.
MANIFEST_SUFFIX = ".manifest"

_CHUNK = 1 << 20


def manifest_path(output) -> str:
    """The manifest of the output file ``output``: ``output + ".manifest"``."""
    return str(output) + MANIFEST_SUFFIX


def file_fingerprint(path) -> dict:
    """A file's size and the SHA-256 of its bytes (both None when it cannot be read).

    Parameters
    ----------
    path : str or os.PathLike

    Returns
    -------
    dict
        ``{"size": int or None, "sha256": str or None}``.
    """
    digest, size = hashlib.sha256(), 0
    try:
        with open(path, "rb") as stream:
            while chunk := stream.read(_CHUNK):
                digest.update(chunk)
                size += len(chunk)
    except OSError:
        return {"size": None, "sha256": None}
    return {"size": size, "sha256": digest.hexdigest()}


class Manifest:
    """The manifest file of a batch output, open for appending for the whole run.

    Parameters
    ----------
    path : str
        The manifest file (:func:`manifest_path`).
    resume : bool
        Keep its entries (:attr:`entries`; a last line without its newline is cut off) and append;
        without it the file is emptied.

    Attributes
    ----------
    entries : dict
        ``{resolved path: {"size", "sha256"}}`` of the entries kept, the last of each path.

    Raises
    ------
    OSError
        When the file cannot be opened, read or cut.
    """

    def __init__(self, path, resume=False):
        self.path = path
        self.entries = {}
        descriptor = os.open(path, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC, 0o666)
        try:
            if resume:
                with open(path, "rb") as stream:
                    data = stream.read()
                complete = data[: data.rfind(b"\n") + 1]
                for line in complete.decode("utf-8", "replace").splitlines():
                    try:
                        entry = json.loads(line)
                    except ValueError:
                        continue  # a damaged line: its file counts as done by its path only
                    if isinstance(entry, dict) and isinstance(entry.get("path"), str):
                        self.entries[entry["path"]] = {"size": entry.get("size"), "sha256": entry.get("sha256")}
                os.ftruncate(descriptor, len(complete))
            else:
                os.ftruncate(descriptor, 0)
            os.lseek(descriptor, 0, os.SEEK_END)
        except BaseException:
            os.close(descriptor)
            raise
        self._descriptor = descriptor

    def add(self, path, fingerprint):
        """Append the entry of the file ``path`` (its :func:`file_fingerprint`) in one write."""
        line = json.dumps({"path": resolved_path(path), **fingerprint}, separators=(",", ":")) + "\n"
        data = memoryview(line.encode("utf-8", "surrogateescape"))
        while data:
            data = data[os.write(self._descriptor, data):]

    def changed(self, paths) -> set:
        """The resolved paths of those ``paths`` whose entry differs from the file now (its size, then
        its SHA-256); a path without an entry is not changed (done by its path, as a local batch's).

        Parameters
        ----------
        paths : iterable of str

        Returns
        -------
        set of str
        """
        changed = set()
        for path in paths:
            resolved = resolved_path(path)
            entry = self.entries.get(resolved)
            if entry is None:
                continue
            try:
                size = os.stat(path).st_size
            except OSError:
                size = None
            if size != entry["size"] or file_fingerprint(path) != entry:
                changed.add(resolved)
        return changed

    def close(self):
        """Close the file."""
        if self._descriptor is not None:
            os.close(self._descriptor)
            self._descriptor = None

    def __enter__(self):
        return self

    def __exit__(self, *exc_info):
        self.close()
        return False
