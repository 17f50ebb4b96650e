"""What a scan's record is checked against when the spec needs more than itself: a registration that
maps its nominal holes into the scan's frame (``--registration``), and scans tied to spec holes by
name (``--name SCAN=HOLE``, or a one-hole scan whose file stem is a hole's name, as ``holecli
register`` names them).

:class:`Inspection` holds them; :func:`check_record` checks one record with it (or with a plain
:class:`holecli.tolerance.Spec`). Pure: the registration was read by the command line.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from typing import Optional

from holecli import tolerance
from holecli.errors import HoleCliError

__all__ = ["Inspection", "InspectionError", "check_record", "scan_stem", "tied_hole_name"]


class InspectionError(HoleCliError, ValueError):
    """A record cannot be checked as asked (a scan tied to a hole holds several holes, units clash)."""


def scan_stem(path) -> str:
    """A scan's file name without its extension (``scans/A1.ply`` -> ``A1``): what names its PNG
    in a plot folder and, in ``holecli register``, the hole it shows.

    Parameters
    ----------
    path : str or os.PathLike

    Returns
    -------
    str
    """
    return os.path.splitext(os.path.basename(os.path.normpath(os.fspath(path))))[0]


def tied_hole_name(path, names, hole_names):
    """The spec hole ``path``'s scan is tied to, and how: ``(name, "--name")`` when ``names`` has a pair
    whose SCAN is ``path`` as given, its file name or its stem; else ``(stem, "file stem")`` when the
    file's stem is one of ``hole_names``; else ``(None, None)``.

    Parameters
    ----------
    path : str
    names : sequence of (str or None, str)
        ``--name`` pairs ``(SCAN, HOLE)``; SCAN None (detect's plain ``--name HOLE``) ties any scan.
    hole_names : collection of str
    """
    for scan, hole in names:
        if scan is None or scan in (path, os.path.basename(path), scan_stem(path)):
            return hole, "--name"
    stem = scan_stem(path)
    return (stem, "file stem") if stem in hole_names else (None, None)


@dataclass(frozen=True, eq=False)
class Inspection:
    """A spec with a registration and name ties.

    Attributes
    ----------
    spec : holecli.tolerance.Spec
        In the part frame (when ``registration`` is given), in the records' unit.
    registration : holecli.registration.apply.LoadedRegistration or None
    provenance : dict or None
        The record's ``options.tolerances.registration`` (``file``, ``sha256``, ...).
    names : tuple of (str or None, str)
        ``--name`` pairs (:func:`tied_hole_name`).
    """

    spec: tolerance.Spec
    registration: Optional[object] = None
    provenance: Optional[dict] = None
    names: tuple = field(default=())

    def spec_for(self, units):
        """The spec mapped into the measuring frame for a record in ``units``: the registration
        converted from its unit when both are known (:data:`holecli.units.UNITS`), else taken as
        the record's; the spec itself without a registration."""
        if self.registration is None:
            return self.spec
        from holecli.registration.apply import map_spec
        from holecli.units import UNITS, scale_factor

        registration = self.registration
        provenance = dict(self.provenance or {})
        if registration.units is not None and units in UNITS:
            if registration.units != units:
                registration = registration.scaled(scale_factor(registration.units, units))
            provenance["units"] = registration.units
        else:
            provenance["units"] = None  # not said: taken as the record's
        spec = self.spec
        if spec.units is not None and units in UNITS and spec.units != units:
            # the spec's own unit first, then the registration's transform (which is in the record's unit)
            from dataclasses import replace

            spec = replace(tolerance.spec_in_units(spec, units), units=units)
        return map_spec(spec, registration, provenance)

    def check(self, record, path):
        """:func:`holecli.tolerance.check` of ``record`` (of the scan ``path``) against the mapped spec,
        its hole tied by name when the scan is (:func:`tied_hole_name`).

        Raises
        ------
        InspectionError
            When ``--name`` ties a scan that holds more than one hole.
        """
        spec = self.spec_for(record.get("units"))
        name, how = tied_hole_name(path, self.names, [hole.name for hole in spec.holes])
        tied = None
        holes = record.get("holes") or []
        if name is not None and len(holes) > 1 and how == "--name":
            raise InspectionError(f"{path}: is hole {name!r} (--name) but holds {len(holes)} holes "
                                  "(give --max-holes 1)")
        if name is not None and len(holes) == 1:  # a stem names a one-hole scan only
            tied = {0: name}
        checked = tolerance.check(record, spec, tied)
        options = checked.get("options")
        if tied is not None and isinstance(options, dict) and isinstance(options.get("tolerances"), dict):
            options["tolerances"]["tied"] = {"hole": name, "by": how}
        return checked


def check_record(record, spec, path):
    """``record`` checked against ``spec``: an :class:`Inspection` or a plain spec
    (:func:`holecli.tolerance.check`)."""
    if isinstance(spec, Inspection):
        return spec.check(record, path)
    return tolerance.check(record, spec)
