"""The named specs and registrations of a cell (``--spec-dir``): ``NAME.toml`` is the spec ``NAME``,
``NAME.json`` the registration ``NAME`` (``holecli register``'s result).

Read at each request that names them (a few small files), so that a spec edited on disk is used by
the next measurement without a restart; the record's provenance carries the file and its SHA-256.
"""

from __future__ import annotations

import os
import re

__all__ = ["NAME", "SpecLibrary", "SpecLookupError"]

#: What a name may be: letters, digits, ``_``, ``-`` and ``.`` (not first), at most 100 characters.
NAME = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_.-]{0,99}")


class SpecLookupError(Exception):
    """A spec or registration that cannot be had; ``status`` 400 (bad name), 404 (unknown) or 422 (a
    file that is not a valid spec or registration)."""

    def __init__(self, message, status):
        super().__init__(message)
        self.status = status


class SpecLibrary:
    """The specs and registrations in ``folder`` (None: none).

    Parameters
    ----------
    folder : str or None
    """

    def __init__(self, folder=None):
        self.folder = None if folder is None else os.path.realpath(folder)

    def names(self):
        """``{"specs": [...], "registrations": [...]}``: the names the folder holds."""
        found = {"specs": [], "registrations": []}
        if self.folder is None:
            return found
        for entry in sorted(os.listdir(self.folder)):
            stem, extension = os.path.splitext(entry)
            if NAME.fullmatch(stem) and extension in (".toml", ".json"):
                found["specs" if extension == ".toml" else "registrations"].append(stem)
        return found

    def _file(self, name, extension, what):
        if not isinstance(name, str) or not NAME.fullmatch(name):
            raise SpecLookupError(f"{name!r}: not a {what} name (letters, digits, '_', '-', '.')", 400)
        if self.folder is None:
            raise SpecLookupError(f"{what} {name!r}: this service has no spec folder (--spec-dir)", 404)
        path = os.path.join(self.folder, name + extension)
        if not os.path.isfile(path):
            raise SpecLookupError(f"{what} {name!r}: not in the spec folder ({name}{extension})", 404)
        return path

    def inspection(self, spec=None, registration=None):
        """The :class:`holecli.inspection.Inspection` of the spec named ``spec`` mapped by the
        registration named ``registration``; None when neither is named.

        Raises
        ------
        SpecLookupError
        """
        if spec is None and registration is None:
            return None
        if spec is None:
            raise SpecLookupError("a registration is given without a spec", 400)
        from holecli.cli.exits import Failure
        from holecli.cli.files import read_registration, read_spec
        from holecli.inspection import Inspection

        try:
            loaded = read_spec(self._file(spec, ".toml", "spec"))
            mapping = provenance = None
            if registration is not None:
                mapping, provenance = read_registration(self._file(registration, ".json", "registration"))
        except Failure as failure:
            raise SpecLookupError(str(failure), 422) from None
        return Inspection(loaded, mapping, provenance)
