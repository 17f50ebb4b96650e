"""A panel spec from a TOML file (:func:`parse_panel_toml`), lengths in the file's units."""

from __future__ import annotations

from holecli.errors import SpecError
from holecli.simulation.panel.spec import CURVATURES, FeatureSpec, KINDS, PanelSpec, _number, _validate
from holecli.simulation.panel.bend import _Bend
from holecli.simulation.panel.loops import _checked_loops

__all__ = ["parse_panel_toml"]


_PANEL_KEYS = ("width", "height", "thickness", "curvature", "radius", "chord_error", "segments",
               "grid_spacing")
_TILT_KEYS = ("tilt_deg", "tilt_direction_deg")
_FEATURE_KEYS = {
    "through": ("diameter",) + _TILT_KEYS,
    "countersunk": ("diameter", "countersink_diameter", "countersink_angle_deg") + _TILT_KEYS,
    "counterbored": ("diameter", "counterbore_diameter", "counterbore_depth") + _TILT_KEYS,
    "blind": ("diameter", "depth") + _TILT_KEYS,
    "slot": ("width", "length", "direction_deg"),
    "cutout": ("width", "length", "direction_deg", "corner_radius"),
    "boss": ("diameter", "height"),
    "pocket": ("diameter", "depth"),
}
_OPTIONAL_FEATURE_KEYS = {"countersink_angle_deg", "direction_deg"} | set(_TILT_KEYS)


def parse_panel_toml(text) -> PanelSpec:
    """A panel spec from the text of a TOML file.

    The file may declare the unit of its lengths at its top, ``units = "in"`` (``"mm"``, ``"m"``): they
    are converted into millimetres, the simulator's unit (without it they are millimetres). It holds
    one ``[panel]`` table (``width``, ``height``, ``thickness``; optional
    ``curvature`` = "flat" | "convex" | "concave", ``radius`` (required when curved),
    ``chord_error``, ``segments``, ``grid_spacing``) and any number of ``[[feature]]`` tables
    (``kind``, ``center = [u, v]``, optional ``name``, and the keys of that kind: ``diameter``;
    ``countersink_diameter``, ``countersink_angle_deg`` (default 100); ``counterbore_diameter``,
    ``counterbore_depth``; ``depth``; ``height`` (boss); for a slot ``width``, ``length``, ``direction_deg``
    (default 0), for a cut-out those and ``corner_radius``; for a hole (not a slot, a cut-out or a boss) ``tilt_deg`` and ``tilt_direction_deg`` (default
    0: drilled along the normal)).

    Parameters
    ----------
    text : str
        The TOML text.

    Returns
    -------
    PanelSpec
        The panel and its features, in the file's order.

    Raises
    ------
    SpecError
        Invalid TOML, an unknown or missing key, a value of the wrong type or out of range. The
        message names the table (``panel`` or ``feature[k]``, counting from 0) and the key.
    """
    from holecli.tolerance import load_toml  # a BOM skipped, integers no float holds refused

    from holecli.units import declared_units

    data = load_toml(text, "panel", first_index=0)
    try:
        units = declared_units(data, "panel")
    except ValueError as error:
        raise SpecError(str(error)) from None
    unknown = sorted(set(data) - {"panel", "feature"})
    if unknown:
        raise SpecError(f"unknown top-level key {unknown[0]!r} (expected units, [panel] and [[feature]] tables)")
    if units is not None:
        _in_millimetres(data, units)
    panel = data.get("panel")
    if not isinstance(panel, dict):
        raise SpecError("expected a [panel] table")
    unknown = sorted(set(panel) - set(_PANEL_KEYS))
    if unknown:
        raise SpecError(f"panel: unknown key {unknown[0]!r} (expected {', '.join(_PANEL_KEYS)})")
    for key in ("width", "height", "thickness"):
        if key not in panel:
            raise SpecError(f"panel: missing key {key!r}")
    for key in ("width", "height", "thickness", "radius", "chord_error", "grid_spacing"):
        if key in panel and not _number(panel[key]):
            raise SpecError(f"panel.{key} must be a number, got {panel[key]!r}")
    if "segments" in panel and (isinstance(panel["segments"], bool) or not isinstance(panel["segments"], int)):
        raise SpecError(f"panel.segments must be an integer, got {panel['segments']!r}")
    curvature = panel.get("curvature", "flat")
    if curvature not in CURVATURES:
        raise SpecError(f"panel.curvature must be one of {', '.join(CURVATURES)}, got {curvature!r}")
    if curvature != "flat" and "radius" not in panel:
        raise SpecError(f"panel: missing key 'radius' (needed by curvature = {curvature!r})")
    tables = data.get("feature", [])
    if not isinstance(tables, list) or not all(isinstance(tb, dict) for tb in tables):
        raise SpecError("expected [[feature]] tables (an array of tables)")
    features = []
    for k, table in enumerate(tables):
        where = f"feature[{k}]"
        kind = table.get("kind")
        if kind not in _FEATURE_KEYS:
            raise SpecError(f"{where}.kind must be one of {', '.join(KINDS)}, got {kind!r}")
        allowed = ("kind", "center", "name") + _FEATURE_KEYS[kind]
        unknown = sorted(set(table) - set(allowed))
        if unknown:
            raise SpecError(f"{where}: unknown key {unknown[0]!r} for a {kind} feature "
                            f"(expected {', '.join(allowed)})")
        required = ("center",) + tuple(key for key in _FEATURE_KEYS[kind] if key not in _OPTIONAL_FEATURE_KEYS)
        missing = [key for key in required if key not in table]
        if missing:
            raise SpecError(f"{where}: missing key {missing[0]!r}")
        center = table["center"]
        if not (isinstance(center, list) and len(center) == 2 and all(_number(v) for v in center)):
            raise SpecError(f"{where}.center must be 2 finite numbers [u, v], got {center!r}")
        values = {}
        for key in _FEATURE_KEYS[kind]:
            if key in table:
                if not _number(table[key]):
                    raise SpecError(f"{where}.{key} must be a number, got {table[key]!r}")
                values[key] = float(table[key])
        features.append(FeatureSpec(kind=kind, center=(float(center[0]), float(center[1])),
                                    name=table.get("name"), **values))
    values = {key: (float(panel[key]) if key != "segments" else panel[key])
              for key in _PANEL_KEYS if key in panel and key != "curvature"}
    spec = PanelSpec(curvature=curvature, features=tuple(features), **values)
    _validate(spec, label="feature")
    # The gap and depth checks that need the exact loops run here too, so that a file is refused on reading.
    _checked_loops(spec, _Bend(spec.curvature, spec.radius), "feature")
    return spec


# The keys of a panel file that are not lengths: the shape's word, a count, and the angles (``..._deg``).
_NOT_LENGTHS = ("curvature", "segments", "kind", "name")


def _in_millimetres(data, units):
    """Multiply every length of a panel file's data (``[panel]`` and ``[[feature]]``: every number but
    ``segments`` and the angles, ``..._deg``; both coordinates of ``center``) from ``units`` into mm, the
    unit the simulator works in, in place. A value that is not a number is left for the checks to refuse."""
    from holecli.units import scale_factor

    factor = scale_factor(units, "mm")
    tables = [data.get("panel")] + list(data.get("feature") or [])
    for table in tables:
        if not isinstance(table, dict):
            continue
        for key, value in table.items():
            if key in _NOT_LENGTHS or key.endswith("_deg"):
                continue
            if _number(value):
                table[key] = float(value) * factor
            elif key == "center" and isinstance(value, list) and all(_number(v) for v in value):
                table[key] = [float(v) * factor for v in value]
