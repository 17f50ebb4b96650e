"""Finding the files of a batch: files and folders turned into a sorted list of point clouds
(:func:`find_scans`), and how many workers to run (:func:`default_jobs`).
"""

from __future__ import annotations

import fnmatch
import os

from holecli.errors import LoadError
from holecli.io import SUPPORTED_EXTENSIONS

def find_scans(paths, recursive=False, pattern=None, exclude=(), input_format=None, exclude_folders=(),
               unlistable=None) -> list:
    """The point-cloud files to measure, sorted, each once.

    Parameters
    ----------
    paths : sequence of str
        Files and folders. A file is taken as it is (a file holecli cannot read gives an error record
        later). A folder contributes the files directly in it whose extension (any case) is one
        holecli reads (with ``input_format``: every file, whatever its extension); with ``recursive``
        also those in its subfolders. Hidden files and folders (a name starting with ``.``) are
        skipped, and symbolic links to folders are not followed.
    recursive : bool
        Also look in subfolders.
    pattern : str, optional
        A glob the files found in folders must also match, case-insensitively: against the file
        name, or against the path below the given folder when the pattern holds a ``/``.
    exclude : iterable of str
        Files to leave out (the batch's own output file).
    input_format : str, optional
        The format every file will be read in (``--input-format``): the extension then no longer
        selects the files of a folder, only ``pattern`` does.
    exclude_folders : iterable of str
        Folders none of whose files (at any depth, symbolic links resolved) are taken, even when
        given by name (the batch's plot folder: with ``input_format`` its PNGs would be).
    unlistable : list, optional
        Where to put each subfolder that cannot be listed (no permission, a name too long for the
        system), as ``(folder, message)``, its message one line (see :func:`unlistable_message`);
        the batch gives each an error record. Without it such a subfolder raises LoadError: a
        folder's files are never silently left out.

    Returns
    -------
    list of str
        Paths spelled from the given ones (``folder/name``), sorted; a file reached twice (given
        twice, or given and found in a folder) is listed once, under the first spelling in order.

    Raises
    ------
    LoadError
        When a path does not exist, or a folder given cannot be listed (or a subfolder, without
        ``unlistable``).
    """
    excluded = {os.path.realpath(path) for path in exclude}
    found, not_listed = [], []
    for path in paths:
        path = os.fspath(path)
        if os.path.isdir(path):
            found.extend(_scan_folder(path, recursive, pattern, any_extension=input_format is not None,
                                      unlistable=not_listed))
        elif os.path.exists(path):
            found.append(path)
        else:
            raise LoadError(path, "no such file or folder")
    folders = [os.path.realpath(folder) for folder in exclude_folders]
    unique, seen = [], set(excluded)
    for path in sorted(found):
        real = os.path.realpath(path)
        if any(os.path.commonpath([real, folder]) == folder for folder in folders):
            continue
        if real not in seen:
            seen.add(real)
            unique.append(path)
    if not_listed and unlistable is None:
        raise LoadError(not_listed[0][0], not_listed[0][1].split(": ", 1)[1])
    if unlistable is not None:
        unlistable.extend(sorted(not_listed))
    return unique


def unlistable_message(folder, error) -> str:
    """The one-line message of a subfolder that cannot be listed (its error record's).

    Parameters
    ----------
    folder : str
    error : OSError

    Returns
    -------
    str
    """
    return f"{folder}: cannot list this folder ({error.strerror or error}): its files are not measured"


def _scan_folder(folder, recursive, pattern, any_extension=False, unlistable=None):
    pattern = pattern.lower() if pattern else None

    def cannot_list(error):
        where = error.filename if error.filename is not None else folder
        if os.path.normpath(where) == os.path.normpath(folder):  # a folder given: an input error, as a missing one
            raise LoadError(folder, f"cannot list this folder: {error.strerror or error}")
        unlistable.append((where, unlistable_message(where, error)))

    for root, folders, names in os.walk(folder, onerror=cannot_list):
        folders[:] = sorted(name for name in folders if not name.startswith("."))
        for name in names:
            if name.startswith("."):
                continue
            if not any_extension and os.path.splitext(name)[1].lower() not in SUPPORTED_EXTENSIONS:
                continue
            path = os.path.join(root, name)
            if pattern:
                subject = os.path.relpath(path, folder).replace(os.sep, "/") if "/" in pattern else name
                if not fnmatch.fnmatchcase(subject.lower(), pattern):
                    continue
            if os.path.isfile(path):
                yield path
        if not recursive:
            break


def default_jobs() -> int:
    """The number of cores this process may run on.

    Returns
    -------
    int
        At least 1.
    """
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not on Linux
        return max(1, os.cpu_count() or 1)
