"""A lot of drilled panels: the same panel spec drilled N times with a drilling cell's scatter, some
parts with chosen defects, and the truth of every part (``holecli simulate --lot``).

Pure: a :class:`holecli.simulation.panel.PanelSpec`, defects and a seed in, the panel spec of each
part and its truth out; building, scanning and writing the parts is the command line's job.

Scatter
-------
Every hole of every part is drilled off its drawing by a random draw (normal, independent): its
centre by :data:`POSITION_SIGMA` along u and v, its bore diameter by :data:`DIAMETER_SIGMA` and its
countersink or counterbore diameter by :data:`DIAMETER_SIGMA` too; a good drilling cell's spread,
far inside the tolerances of a drawing (0.02 mm on a diameter, 0.1 mm on a position).

Defects
-------
``[PART/]HOLE=KIND[:SIZE]``, a defect of hole ``HOLE`` (the panel's feature ``name``) in part
``PART`` (1 to N; without it, in every part), sizes in mm:

``diameter:SIZE``
    the diameter of the hole's edge on the surface off by SIZE (signed, e.g. ``+0.1``): the bore of a
    through or blind hole, the countersink of a countersunk one, the counterbore of a counterbored one.
``position:SIZE``
    the hole drilled SIZE (>= 0) from its place, in a random direction of the sheet.
``countersink:SIZE``
    the countersink cut SIZE deeper along its axis (signed; negative: shallower), so its diameter at
    the surface grows by ``2 SIZE tan(angle / 2)``; countersunk holes only.
``missing``
    the hole not drilled at all.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, replace
from typing import Optional

import numpy as np

__all__ = ["DEFECT_KINDS", "DIAMETER_SIGMA", "POSITION_SIGMA", "Defect", "lot_parts", "parse_defect"]

# The scatter of a good drilling cell (standard deviations, mm).
POSITION_SIGMA = 0.005
DIAMETER_SIGMA = 0.002

DEFECT_KINDS = ("diameter", "position", "countersink", "missing")
# The kinds of panel feature that are drilled holes.
_HOLE_KINDS = ("through", "countersunk", "counterbored", "blind")

_DEFECT = re.compile(r"^(?:(?P<part>[0-9]+)/)?(?P<hole>[^=/]+)=(?P<kind>[a-z]+)(?::(?P<size>.+))?$")


@dataclass(frozen=True)
class Defect:
    """One defect asked for.

    Attributes
    ----------
    hole : str
        The feature's name in the panel spec.
    kind : {"diameter", "position", "countersink", "missing"}
    size : float or None
        mm; None for ``missing``.
    part : int or None
        The part (1 to N) it is in; None: every part.
    text : str
        As given, for messages and the manifest.
    """

    hole: str
    kind: str
    size: Optional[float]
    part: Optional[int]
    text: str


def parse_defect(text) -> Defect:
    """A :class:`Defect` from its text ``[PART/]HOLE=KIND[:SIZE]`` (see the module's docstring).

    Parameters
    ----------
    text : str

    Returns
    -------
    Defect

    Raises
    ------
    ValueError
        For text not of that form, an unknown kind, a size missing, not a finite number, negative for
        ``position``, or given to ``missing``, a part 0.

    Examples
    --------
    >>> parse_defect("3/C1=diameter:+0.1")
    Defect(hole='C1', kind='diameter', size=0.1, part=3, text='3/C1=diameter:+0.1')
    >>> parse_defect("L1=missing").part is None
    True
    """
    match = _DEFECT.match(text.strip())
    if match is None:
        raise ValueError(f"{text!r} is not [PART/]HOLE=KIND[:SIZE] (e.g. C1=diameter:+0.1, 2/L1=missing)")
    kind, size_text = match["kind"], match["size"]
    if kind not in DEFECT_KINDS:
        raise ValueError(f"{text!r}: unknown defect {kind!r} (known: {', '.join(DEFECT_KINDS)})")
    part = None if match["part"] is None else int(match["part"])
    if part == 0:
        raise ValueError(f"{text!r}: parts are counted from 1")
    if kind == "missing":
        if size_text is not None:
            raise ValueError(f"{text!r}: missing takes no size")
        return Defect(match["hole"].strip(), kind, None, part, text)
    if size_text is None:
        raise ValueError(f"{text!r}: {kind} needs a size in mm, e.g. {kind}:{'0.3' if kind == 'position' else '+0.1'}")
    try:
        size = float(size_text)
    except ValueError:
        size = math.nan
    if not math.isfinite(size) or (kind == "position" and size < 0):
        expected = "a number >= 0" if kind == "position" else "a signed number"
        raise ValueError(f"{text!r}: the size must be {expected} (mm), got {size_text!r}")
    return Defect(match["hole"].strip(), kind, size, part, text)


def lot_parts(panel, parts, defects=(), seed=0):
    """The panel spec and truth of each part of a lot.

    Parameters
    ----------
    panel : holecli.simulation.panel.PanelSpec
        The drawing.
    parts : int
        How many parts (>= 1).
    defects : sequence of Defect
        The defects asked for.
    seed : int
        The lot's seed: the scatter of feature ``k`` of part ``i`` draws from
        ``numpy.random.default_rng([seed, i, k])``, the seed of part ``i``'s scan from
        ``default_rng([seed, i])``.

    Returns
    -------
    list of (PanelSpec, dict)
        Per part, in order: the panel spec as drilled, and its truth: ``part`` (from 1), ``scan_seed``
        (the seed of its scan), ``defective``, ``defects`` (``{"defect", "hole", "kind", "size"}``
        as given) and ``holes``: per hole of the drawing ``{"name", "kind", "center", "diameter",
        "countersink_diameter", "counterbore_diameter", "drilled"}`` as drilled (``drilled`` false:
        missing; ``center`` ``[u, v]`` in the sheet frame).

    Raises
    ------
    ValueError
        For a defect of a hole the panel does not name, a ``countersink`` defect of a hole that is
        not countersunk, a part beyond ``parts``, or a defect that leaves a diameter not > 0.
    """
    holes = {feature.name: feature for feature in panel.features if feature.kind in _HOLE_KINDS and feature.name}
    for defect in defects:
        if defect.hole not in holes:
            raise ValueError(f"{defect.text!r}: the panel has no hole named {defect.hole!r} (its holes: "
                             f"{', '.join(holes) or 'none with a name'})")
        if defect.kind == "countersink" and holes[defect.hole].kind != "countersunk":
            raise ValueError(f"{defect.text!r}: {defect.hole} is {holes[defect.hole].kind}, not countersunk")
        if defect.part is not None and defect.part > parts:
            raise ValueError(f"{defect.text!r}: there are only {parts} parts")
    out = []
    for part in range(1, parts + 1):
        mine = [defect for defect in defects if defect.part in (None, part)]
        features, truth_holes = [], []
        for number, feature in enumerate(panel.features):
            if feature.kind not in _HOLE_KINDS:
                features.append(feature)
                continue
            rng = np.random.default_rng([seed, part, number])  # a hole's own draws: a defect changes no other
            drilled = _scattered(feature, rng)
            for defect in mine:
                if defect.hole == feature.name:
                    drilled = _with_defect(drilled, defect, rng)
            truth_holes.append(_hole_truth(drilled, feature.name))
            if drilled is not None:
                features.append(drilled)
        scan_seed = int(np.random.default_rng([seed, part]).integers(2**31))
        truth = {"part": part, "scan_seed": scan_seed, "defective": bool(mine),
                 "defects": [{"defect": d.text, "hole": d.hole, "kind": d.kind, "size": d.size} for d in mine],
                 "holes": truth_holes}
        out.append((replace(panel, features=tuple(features)), truth))
    return out


def _scattered(feature, rng):
    """``feature`` drilled with the cell's scatter (four draws of the hole's own ``rng``, whatever its kind)."""
    du, dv, dd, douter = rng.normal(0.0, 1.0, 4)
    changes = {"center": (feature.center[0] + POSITION_SIGMA * du, feature.center[1] + POSITION_SIGMA * dv),
               "diameter": feature.diameter + DIAMETER_SIGMA * dd}
    if feature.kind == "countersunk":
        changes["countersink_diameter"] = feature.countersink_diameter + DIAMETER_SIGMA * douter
    if feature.kind == "counterbored":
        changes["counterbore_diameter"] = feature.counterbore_diameter + DIAMETER_SIGMA * douter
    return replace(feature, **changes)


def _with_defect(feature, defect, rng):
    if feature is None or defect.kind == "missing":
        return None
    if defect.kind == "position":
        angle = rng.uniform(0.0, 2.0 * math.pi)
        return replace(feature, center=(feature.center[0] + defect.size * math.cos(angle),
                                        feature.center[1] + defect.size * math.sin(angle)))
    if defect.kind == "countersink":
        grow = 2.0 * defect.size * math.tan(math.radians(feature.countersink_angle_deg) / 2.0)
        return _resized(feature, "countersink_diameter", grow, defect)
    key = {"countersunk": "countersink_diameter", "counterbored": "counterbore_diameter"}.get(feature.kind, "diameter")
    return _resized(feature, key, defect.size, defect)


def _resized(feature, key, change, defect):
    value = getattr(feature, key) + change
    if value <= 0:
        raise ValueError(f"{defect.text!r}: leaves {defect.hole}'s {key.replace('_', ' ')} at {value:g} mm")
    return replace(feature, **{key: value})


def _hole_truth(feature, name):
    if feature is None:
        return {"name": name, "drilled": False}
    def length(value):
        return None if value is None else float(value)

    return {"name": name, "kind": feature.kind, "drilled": True, "center": [float(c) for c in feature.center],
            "diameter": float(feature.diameter), "countersink_diameter": length(feature.countersink_diameter),
            "counterbore_diameter": length(feature.counterbore_diameter)}
