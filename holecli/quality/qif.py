"""A lot as a QIF 3.0 Results document (ISO 23952), the neutral format quality software reads.

:func:`qif_document` writes one ``QIFDocument`` (namespace :data:`QIF_NAMESPACE`, ``versionQIF``
3.0.0) with the standard library's ``xml.etree.ElementTree``; the tests validate every document it
writes against the official schemas (``tests/data/qif3``). Its parts:

``Header``, ``FileUnits``
    holecli and its version; the length unit of the lot (below) and degrees.
``Features``
    a ``CircleFeature`` per nominal hole (the spec's hole name): its definition (internal, the nominal
    diameter), its nominal (location and normal) and item. A record carries the nominal diameter (in
    the diameter check) but not the nominal center or normal: those come from ``spec`` when it is
    given, else from the first measurement that found the hole, and the nominal's ``Attributes`` say
    which (``nominal_location``). A hole no measurement found and no spec places has no feature; its
    characteristics stand alone.
``Characteristics``
    a definition (the tolerance), nominal (the target value) and item (named ``<hole> <check>``) per
    characteristic of the lot (:attr:`holecli.quality.lot.Characteristic.key`; a second one when a
    later record was checked against another nominal or band).
``Results``
    a ``MeasurementResults`` per :class:`~holecli.quality.lot.Measurement`, in order: the measured
    circles, the characteristics' measurements and the measurement's ``InspectionStatus``; an
    ``ActualComponent`` per measurement (its serial when the store knows one).

The checks as QIF characteristics
---------------------------------
diameter, countersink_diameter, bore_diameter, countersink_gauge
    ``DiameterCharacteristic``: target the nominal, tolerance the band.
countersink_depth
    ``DepthCharacteristic``.
countersink_angle (the included angle, degrees)
    ``AngleCharacteristic``.
position (the in-plane distance d of the center from the nominal <= T)
    ``PositionCharacteristic`` with a two-dimensional diametrical zone of diameter 2T, and the value
    2d: GD&T's diametral figure of the same check.
tilt, perpendicularity (an angle <= T degrees)
    ``AngleFromCharacteristic``: target 0, tolerance [0, T] degrees. (QIF's perpendicularity is a
    linear zone width, which a scan's angle is not.)
presence (a nominal hole the scan does not show)
    ``UserDefinedAttributeCharacteristic``: pass value ``present``, fail value ``missing``.

A size check's tolerance is written as its band of deviations from the target (``DefinedAsLimit``
false), as the record holds it.

Statuses
--------
A characteristic's ``Status``: ``pass`` PASS, ``fail`` FAIL, ``undecided`` INDETERMINATE (ISO
14253-1's undecided), ``missing`` FAIL (the presence characteristic, value ``missing``). A check the
scan did not measure (reason ``not_measured``) is FAIL, as holecli decides it, with no ``Value``
(the schema's way to say no value). A missing hole's other characteristics (checked in other
measurements of the lot) are NOT_ANALYZED in that measurement (QIF's characteristic status has no
"not measured"). Every characteristic measurement's ``Attributes`` hold the record's ``reason``,
its expanded uncertainty and coverage factor, and the hole's warnings.

A measurement's ``InspectionStatus`` from its verdict
(:func:`holecli.store.schema.verdict_word`): pass PASS, fail FAIL (a missing hole included),
undecided UNKNOWN, unchecked (no tolerances) NOT_CALCULATED, error (a batch error record) NOT_MEASURED
with the error message in its ``InspectionTraceability`` ``Errors``.

Uncertainty
-----------
QIF's ``combinedUncertainty`` attribute is the GUM's combined *standard* uncertainty (k = 1): the
writer puts there ``U / k``, the record's expanded uncertainty over its coverage factor
(``verdict.coverage_factor``), and the expanded U and k themselves in the measurement's
``Attributes``. Position's is doubled with its value. A measured circle's diameter carries the
hole's standard uncertainty of the diameter.

Units
-----
When every record of the lot declares the same length unit (``units``: mm, m or in) the document is
in it and the values are the records' own. Otherwise (records in several units, or records that
declare none, as a PLY's) the document is in millimetres: declared lengths are converted with
:func:`holecli.units.scale_factor`, and undeclared ones are taken to be millimetres, which the
document's ``Attributes`` say (``length_unit_assumed``). Angles are in degrees.
"""

from __future__ import annotations

import datetime
import re
import uuid
import xml.etree.ElementTree as ET
from decimal import Decimal

from holecli import __version__
from holecli.quality.lot import PRESENCE
from holecli.units import UNITS, scale_factor

__all__ = ["QIF_NAMESPACE", "QIF_VERSION", "CHARACTERISTIC_TYPES", "CHARACTERISTIC_STATUS", "INSPECTION_STATUS",
           "qif_document"]

QIF_NAMESPACE = "http://qifstandards.org/xsd/qif3"
QIF_VERSION = "3.0.0"

CHARACTERISTIC_TYPES = {
    "diameter": "Diameter", "countersink_diameter": "Diameter", "bore_diameter": "Diameter",
    "countersink_gauge": "Diameter", "countersink_depth": "Depth", "countersink_angle": "Angle",
    "position": "Position", "tilt": "AngleFrom", "perpendicularity": "AngleFrom", PRESENCE: "UserDefinedAttribute",
}
"""The QIF characteristic (``<type>CharacteristicDefinition`` ...) of each holecli check. A check not
named here is a ``UserDefinedAngular`` (degrees) or ``UserDefinedLinear`` characteristic."""

CHARACTERISTIC_STATUS = {"pass": "PASS", "fail": "FAIL", "undecided": "INDETERMINATE", "missing": "FAIL"}
"""A characteristic's decision as QIF's ``CharacteristicStatusEnum`` (:func:`holecli.quality.lot.lot_from_records`
refuses a record with another decision)."""

INSPECTION_STATUS = {"pass": "PASS", "fail": "FAIL", "undecided": "UNKNOWN", "unchecked": "NOT_CALCULATED",
                     "error": "NOT_MEASURED"}
"""A measurement's verdict word as QIF's ``InspectionStatusEnum``."""

# The SI factor of each length unit (QIF's UnitConversion: metres per unit) and its QIF name.
_SI_METRES = {unit: mm_per_unit / 1000.0 for unit, mm_per_unit in UNITS.items()}
_UNIT_NAMES = {"mm": "mm", "m": "m", "in": "inch"}
_DEGREE_IN_RADIANS = "0.0174532925199433"

# holecli's uuid namespace for the QPIds of its documents (a name-based UUID: the same lot and time
# give the same document).
_QPID_NAMESPACE = uuid.uuid5(uuid.NAMESPACE_URL, "https://holecli/qif")


def qif_document(lot, *, created=None, spec=None, part_number=None) -> bytes:
    """A QIF 3.0 Results document of a lot.

    Parameters
    ----------
    lot : holecli.quality.lot.Lot
        The measurements, in order.
    created : datetime.datetime or str, optional
        When the document is made (its ``Version`` and the results' preparation date); a naive
        datetime is taken as UTC. Default: now. The document is a function of ``lot`` and
        ``created``: its ids and QPIds (name-based UUIDs) come out the same each time.
    spec : holecli.tolerance.Spec, optional
        The spec the lot was checked against: its named holes' nominal centers and normals (in its
        unit, or the records' when it declares none) place the features, which a record does not
        carry.
    part_number : str, optional
        The part number of the measurements whose metadata names no part (a store's ``part``).

    Returns
    -------
    bytes
        The document, UTF-8, with its XML declaration.

    Examples
    --------
    >>> from holecli.quality.lot import lot_from_records
    >>> record = {"file": "part_001.ply", "units": "mm", "holes": [{
    ...     "index": 0, "name": "T1", "center": [0, 0, 0], "normal": [0, 0, 1], "diameter": 4.02,
    ...     "warnings": [], "conformance": {"diameter": {"value": 0.02, "lower": -0.05, "upper": 0.05,
    ...     "expanded_uncertainty": 0.01, "decision": "pass", "reason": "inside"}}}],
    ...     "verdict": {"in_tolerance": True, "missing": [], "coverage_factor": 2.0}}
    >>> lot = lot_from_records([{"record": record, "source": "shift.jsonl:1"}])
    >>> document = qif_document(lot, created="2026-01-02T03:04:05Z")
    >>> b"<CharacteristicStatusEnum>PASS</CharacteristicStatusEnum>" in document
    True
    >>> b'<Value combinedUncertainty="0.005">4.02</Value>' in document
    True
    """
    return _Writer(lot, _timestamp(created), spec, part_number).document()


def _timestamp(created) -> str:
    """``created`` (a datetime, an ISO-8601 text or None for now) as an xs:dateTime in UTC."""
    if created is None:
        created = datetime.datetime.now(datetime.timezone.utc).replace(microsecond=0)
    if isinstance(created, str):
        try:
            created = datetime.datetime.fromisoformat(created.strip().replace("Z", "+00:00"))
        except ValueError:
            raise ValueError(f"created: an ISO-8601 time is expected, got {created!r}") from None
    if created.tzinfo is None:
        created = created.replace(tzinfo=datetime.timezone.utc)
    return created.astimezone(datetime.timezone.utc).isoformat(timespec="milliseconds").replace("+00:00", "Z")


def _datetime(text):
    """A store's ``received`` (ISO-8601) as an xs:dateTime in UTC, or None when not given or not a time."""
    if not text:
        return None
    try:
        moment = datetime.datetime.fromisoformat(str(text).strip().replace("Z", "+00:00"))
    except ValueError:
        return None
    return _timestamp(moment)


def _decimal(value) -> str:
    """A float as an xs:decimal: its shortest round-trip digits without an exponent (xs:decimal has
    none)."""
    text = format(Decimal(repr(float(value))), "f")
    return "0" if text in ("-0", "-0.0") else text


def _vector(values) -> str:
    """A point or vector as QIF's list of doubles."""
    return " ".join(_decimal(v) for v in values)


def _document_unit(lot):
    """The document's length unit and the units assumed: (unit, number of records without a unit).

    One declared unit throughout: that unit. Else millimetres."""
    declared = {m.units for m in lot.measurements if "error" not in m.record}
    undeclared = sum(1 for m in lot.measurements if "error" not in m.record and not m.units)
    known = declared - {""}
    if len(known) == 1 and not undeclared:
        return known.pop(), 0
    return "mm", undeclared


class _Writer:
    """The document of one lot: ids handed out in writing order."""

    def __init__(self, lot, created, spec, part_number=None):
        self.lot = lot
        self.created = created
        self.spec = spec
        self.part_number = part_number
        self.unit, self.assumed = _document_unit(lot)
        self.next_id = 0
        sources = "\n".join(f"{m.id or m.source}\t{m.record.get('file', '')}" for m in lot.measurements)
        self.qpid = uuid.uuid5(_QPID_NAMESPACE, f"{created}\n{sources}")

    # -- small helpers ---------------------------------------------------------------------------
    def new_id(self) -> str:
        self.next_id += 1
        return str(self.next_id)

    def factor(self, units) -> float:
        """The factor a length of a record in ``units`` is multiplied by to be in the document's unit."""
        return scale_factor(units, self.unit) if units else 1.0

    def length(self, value, units) -> float:
        """A characteristic's value in the document's unit (angles as they are)."""
        if value is None or units == "deg":
            return value
        return value * self.factor(units)

    # -- the document ----------------------------------------------------------------------------
    def document(self) -> bytes:
        # Every element is in the QIF namespace: declared once as the default, the tags stay plain
        # (ElementTree's own namespace handling would need a global prefix registry).
        root = ET.Element("QIFDocument", {"xmlns": QIF_NAMESPACE, "versionQIF": QIF_VERSION, "idMax": "0"})
        _sub(root, "QPId", str(self.qpid))
        self.attributes(root, self.document_attributes())
        version = _sub(root, "Version")
        _sub(version, "TimeCreated", self.created)
        header = _sub(root, "Header")
        _sub(_sub(header, "Application"), "Name", f"holecli {__version__}")
        _sub(header, "Description", self.description())
        standard_id = self.standards(root) if self.lot.characteristics else None
        self.file_units(root)
        paths = self.product(root)
        features = self.feature_table()
        items = self.characteristic_table()
        if features:
            self.features(root, features)
        if items:
            self.characteristics(root, items, features, standard_id)
        if self.lot.measurements:
            self.results(root, features, items, paths)
        root.set("idMax", str(max(self.next_id, 1)))
        ET.indent(root)
        # Serialized to text and then encoded: ElementTree's own UTF-8 writer is several times slower.
        text = ET.tostring(root, encoding="unicode")
        return ('<?xml version="1.0" encoding="UTF-8"?>\n' + text + "\n").encode("utf-8")

    def description(self) -> str:
        """The header's words: what the document holds and in which units."""
        count = len(self.lot.measurements)
        words = (f"QIF results of {count} holecli measurement{'s' if count != 1 else ''}; "
                 f"lengths in {self.unit}, angles in degrees")
        if self.assumed:
            words += f" ({self.assumed} record(s) declare no length unit: taken to be mm)"
        return words

    def document_attributes(self) -> list:
        out = [("length_unit", self.unit)]
        if self.assumed:
            out.append(("length_unit_assumed",
                        f"{self.assumed} record(s) declare no length unit: their lengths are taken to be mm"))
        return out

    def attributes(self, parent, pairs):
        """An ``Attributes`` element of (name, text) pairs (none when empty)."""
        pairs = [(name, str(value)) for name, value in pairs if value is not None and value != ""]
        if not pairs:
            return
        element = _sub(parent, "Attributes", n=str(len(pairs)))
        for name, value in pairs:
            _sub(element, "AttributeStr", name=name, value=value)

    def standards(self, root) -> str:
        """The standards the characteristics are defined by (holecli's checks, decided by ISO
        14253-1's rules); returns the id of holecli's."""
        element = _sub(root, "StandardsDefinitions", n="2")
        iso_id = self.new_id()
        iso = _sub(element, "Standard", id=iso_id)
        _sub(_sub(iso, "Organization"), "StandardsOrganizationEnum", "ISO")
        _sub(iso, "Designator", "14253-1")
        _sub(iso, "Year", "2017")
        _sub(iso, "Title", "Decision rules for verifying conformity or nonconformity with specifications")
        holecli_id = self.new_id()
        own = _sub(element, "Standard", id=holecli_id)
        _sub(_sub(own, "Organization"), "OtherStandardsOrganization", "holecli")
        _sub(own, "Designator", "holecli.tolerance")
        _sub(own, "Description", "the checks of holecli.tolerance (see each definition's Description), decided "
                                 "by ISO 14253-1's simple or guarded acceptance rule")
        _sub(_sub(own, "ReferencedStandardIds", n="1"), "Id", iso_id)
        return holecli_id

    def file_units(self, root):
        primary = _sub(_sub(root, "FileUnits"), "PrimaryUnits")
        angular = _sub(primary, "AngularUnit")
        _sub(angular, "SIUnitName", "radian")
        _sub(angular, "UnitName", "degree")
        _sub(_sub(angular, "UnitConversion"), "Factor", _DEGREE_IN_RADIANS)
        linear = _sub(primary, "LinearUnit")
        _sub(linear, "SIUnitName", "meter")
        _sub(linear, "UnitName", _UNIT_NAMES[self.unit])
        _sub(_sub(linear, "UnitConversion"), "Factor", _decimal(_SI_METRES[self.unit]))

    # -- the product: the part numbers -----------------------------------------------------------
    def part_of(self, m):
        """The part number of measurement ``m``: its metadata's, else the one given, else None."""
        return m.part or self.part_number

    def product(self, root) -> dict:
        """A ``Part`` per part number of the lot, each its own component and assembly path (which an
        ``ActualComponent`` names); returns {part number: assembly path id}."""
        numbers = list(dict.fromkeys(n for n in map(self.part_of, self.lot.measurements) if n is not None))
        if not numbers:
            return {}
        element = _sub(root, "Product")
        part_set = _sub(element, "PartSet", n=str(len(numbers)))
        component_set = _sub(element, "ComponentSet", n=str(len(numbers)))
        path_set = _sub(element, "AsmPaths", n=str(len(numbers)))
        paths = {}
        for number in numbers:
            part = _sub(part_set, "Part", id=self.new_id())
            _sub(part, "ModelNumber", number)
            component = _sub(component_set, "Component", id=self.new_id())
            _sub(_sub(component, "Part"), "Id", part.get("id"))
            paths[number] = path_id = self.new_id()
            _sub(_sub(_sub(path_set, "AsmPath", id=path_id), "ComponentIds", n="1"), "Id", component.get("id"))
        return paths

    # -- features --------------------------------------------------------------------------------
    def feature_table(self) -> dict:
        """{hole name: feature} for every hole with a known location, in the order first seen."""
        nominals = self.spec_nominals()
        holes = {}
        for c in self.lot.characteristics:
            holes.setdefault(c.hole, []).append(c)
        features = {}
        for hole, characteristics in holes.items():
            found = [(self.lot.measurements[c.measurement], c.hole_index) for c in characteristics
                     if c.hole_index is not None]
            first = next(((m, _record_hole(m.record, index)) for m, index in found
                          if _record_hole(m.record, index) is not None), None)
            spec_hole = nominals.get(hole)
            measured_in = None if first is None else f"measured in {first[0].label}"
            if spec_hole is not None and spec_hole.get("center") is not None:
                location, source = spec_hole["center"], "spec"
            elif first is not None:
                location = [v * self.factor(first[0].units) for v in first[1]["center"]]
                source = f"{measured_in}: a record does not carry the nominal center"
            else:
                continue
            if spec_hole is not None and spec_hole.get("normal") is not None:
                normal, normal_source = spec_hole["normal"], "spec"
            elif first is not None:
                normal, normal_source = first[1]["normal"], f"{measured_in}: a record does not carry the nominal normal"
            else:
                normal, normal_source = (0.0, 0.0, 1.0), "not known (+z written): the spec gives none"
            diameter = next((c.nominal * self.factor(c.unit) for c in characteristics
                             if c.name == "diameter" and c.nominal is not None), None)
            diameter_source = "the diameter check's nominal"
            if diameter is None and spec_hole is not None and spec_hole.get("diameter") is not None:
                diameter, diameter_source = spec_hole["diameter"], "spec"
            if diameter is None and first is not None:
                m, record_hole = first
                diameter = record_hole["diameter"] * self.factor(m.units)
                diameter_source = f"{measured_in}: no nominal diameter"
            if diameter is None:  # a circle needs one: the hole's characteristics stand alone
                continue
            features[hole] = {"location": location, "normal": _unit_vector(normal), "diameter": diameter,
                              "sources": [("nominal_location", source), ("nominal_normal", normal_source),
                                          ("nominal_diameter", diameter_source)]}
        return features

    def spec_nominals(self) -> dict:
        """{hole name: {center, normal, diameter}} of the spec's named holes, in the document's unit."""
        if self.spec is None:
            return {}
        factor = scale_factor(self.spec.units, self.unit) if getattr(self.spec, "units", None) else 1.0
        out = {}
        for hole in self.spec.holes:
            if hole.name is None:
                continue
            out[str(hole.name)] = {
                "center": None if hole.center is None else [v * factor for v in hole.center],
                "normal": hole.normal,
                "diameter": None if hole.diameter is None else hole.diameter * factor}
        return out

    def features(self, root, features):
        element = _sub(root, "Features")
        definitions = _sub(element, "FeatureDefinitions", n=str(len(features)))
        nominals = _sub(element, "FeatureNominals", n=str(len(features)))
        items = _sub(element, "FeatureItems", n=str(len(features)))
        for hole, feature in features.items():
            feature["definition"] = definition_id = self.new_id()
            definition = _sub(definitions, "CircleFeatureDefinition", id=definition_id)
            _sub(definition, "InternalExternal", "INTERNAL")
            _sub(definition, "Diameter", _decimal(feature["diameter"]))
            feature["nominal"] = nominal_id = self.new_id()
            nominal = _sub(nominals, "CircleFeatureNominal", id=nominal_id)
            self.attributes(nominal, feature["sources"])
            _sub(nominal, "FeatureDefinitionId", definition_id)
            _sub(nominal, "Location", _vector(feature["location"]))
            _sub(nominal, "Normal", _vector(feature["normal"]))
            feature["item"] = item_id = self.new_id()
            item = _sub(items, "CircleFeatureItem", id=item_id)
            _sub(item, "FeatureNominalId", nominal_id)
            _sub(item, "FeatureName", hole)
            _sub(_sub(_sub(_sub(item, "DeterminationMode"), "Checked"), "CheckDetails"), "Measured")

    # -- characteristics -------------------------------------------------------------------------
    def characteristic_table(self) -> dict:
        """{identity: item} of every characteristic item; each characteristic's item is found by
        :meth:`item_of`."""
        self.items = {}
        for c in self.lot.characteristics:
            self.item_of(c, create=True)
        return self.items

    def item_of(self, c, create=False):
        """The item of characteristic ``c``: its key, unit, band and (rounded) nominal. A not-measured
        size (nominal unknown) joins an item of the same key and band."""
        unit = "deg" if c.unit == "deg" else "length"
        tolerances = (self.length(c.lower_tolerance, c.unit), self.length(c.upper_tolerance, c.unit))
        nominal = self.length(c.nominal, c.unit)
        nominal = None if nominal is None else float(f"{nominal:.10g}")
        identity = (c.hole, c.name, unit, tolerances, nominal)
        if identity in self.items:
            return self.items[identity]
        if nominal is None:
            for (hole, name, u, band, _), item in self.items.items():
                if (hole, name, u, band) == identity[:4]:
                    return item
        if not create:
            return None
        self.items[identity] = item = {"characteristic": c, "hole": c.hole, "name": c.name, "nominal": nominal,
                                       "lower_tolerance": tolerances[0], "upper_tolerance": tolerances[1]}
        return item

    def characteristics(self, root, items, features, standard_id):
        items = list(items.values())
        element = _sub(root, "Characteristics")
        _sub(element, "FormalStandardId", standard_id)
        definitions = _sub(element, "CharacteristicDefinitions", n=str(len(items)))
        nominals = _sub(element, "CharacteristicNominals", n=str(len(items)))
        elements = _sub(element, "CharacteristicItems", n=str(len(items)))
        for item in items:
            kind = _kind(item["name"], item["characteristic"].unit)
            item["kind"] = kind
            definition_id = self.new_id()
            definition = _sub(definitions, f"{kind}CharacteristicDefinition", id=definition_id)
            _sub(definition, "Description", _describe(item["name"]))
            self.tolerance(definition, kind, item)
            nominal_id = self.new_id()
            nominal = _sub(nominals, f"{kind}CharacteristicNominal", id=nominal_id)
            _sub(nominal, "CharacteristicDefinitionId", definition_id)
            self.target(nominal, kind, item)
            item["id"] = item_id = self.new_id()
            element_item = _sub(elements, f"{kind}CharacteristicItem", id=item_id)
            _sub(element_item, "Name", f"{item['hole']} {item['name']}")
            feature = features.get(item["hole"])
            if feature is not None:
                ids = _sub(element_item, "FeatureItemIds", n="1")
                _sub(ids, "Id", feature["item"])
            _sub(element_item, "CharacteristicNominalId", nominal_id)

    def tolerance(self, definition, kind, item):
        """The definition's tolerance: a band of deviations, a zone, or the presence's question."""
        lower, upper = item["lower_tolerance"], item["upper_tolerance"]
        if kind == "UserDefinedAttribute":
            _sub(definition, "WhatToMeasure", "presence of the nominal hole in the scan")
        elif kind == "Position":
            _sub(definition, "ToleranceValue", _decimal(2.0 * upper))
            _sub(definition, "MaterialCondition", "REGARDLESS")
            zone = _sub(_sub(definition, "ZoneShape"), "DiametricalZone")
            _sub(zone, "Dimensionality", "TWODIMENSIONAL")
        else:
            band = _sub(definition, "Tolerance")
            _sub(band, "MaxValue", _decimal(upper))
            if lower is not None or kind == "AngleFrom":  # an angle from its reference is >= 0
                _sub(band, "MinValue", _decimal(0.0 if lower is None else lower))
            _sub(band, "DefinedAsLimit", "false")
            if kind.startswith("UserDefined"):
                _sub(definition, "WhatToMeasure", f"holecli's check {item['name']}")

    def target(self, nominal, kind, item):
        if kind == "UserDefinedAttribute":
            _sub(_sub(nominal, "PassValues", n="1"), "StringValue", "present")
            _sub(_sub(nominal, "FailValues", n="1"), "StringValue", "missing")
        elif kind == "AngleFrom":
            _sub(nominal, "TargetValue", "0")
            _sub(nominal, "AnalysisMode", "THREEDIMENSIONAL")
        elif kind != "Position" and item["nominal"] is not None:
            _sub(nominal, "TargetValue", _decimal(item["nominal"]))

    # -- results ---------------------------------------------------------------------------------
    def results(self, root, features, items, paths):
        results = _sub(root, "Results")
        measurements = self.lot.measurements
        results_set = _sub(results, "MeasurementResultsSet", n=str(len(measurements)))
        components = []
        for m in measurements:
            components.append(self.measurement_results(results_set, m, features, items))
        component_set = _sub(_sub(results, "ActualComponentSets", n="1"), "ActualComponentSet",
                             n=str(len(measurements)))
        for m, component_id in zip(measurements, components):
            component = _sub(component_set, "ActualComponent", id=component_id)
            self.attributes(component, [("part", m.part), ("label", m.label)])
            if m.serial is not None:
                _sub(component, "SerialNumber", m.serial)
            _sub(_sub(component, "Status"), "InspectionStatusEnum", INSPECTION_STATUS[m.verdict])
            if self.part_of(m) is not None:
                _sub(component, "AsmPathId", paths[self.part_of(m)])
        traceability = _sub(results, "InspectionTraceability")
        _sub(traceability, "ReportPreparationDate", self.created)

    def measurement_results(self, parent, m, features, items) -> str:
        """One measurement's results; returns the id its actual component will take."""
        element = _sub(parent, "MeasurementResults", id=self.new_id())
        component_id = self.new_id()
        received = _datetime(m.received)
        self.attributes(element, [("label", m.label), ("source", m.source), ("file", m.record.get("file")),
                                  ("store_id", m.id), ("verdict", m.verdict)])
        if received is not None or "error" in m.record:
            traceability = _sub(element, "InspectionTraceability")
            if received is not None:
                _sub(traceability, "InspectionStart", received)
            if "error" in m.record:
                _sub(_sub(traceability, "Errors", n="1"), "Error", str(m.record["error"]))
        _sub(element, "ThisResultsInstanceQPId", str(uuid.uuid5(self.qpid, f"results {m.order}")))
        measured = self.measured_features(element, m, features, received)
        self.measured_characteristics(element, m, measured, items, received)
        _sub(_sub(element, "InspectionStatus"), "InspectionStatusEnum", INSPECTION_STATUS[m.verdict])
        _sub(_sub(element, "ActualComponentIds", n="1"), "Id", component_id)
        return component_id

    def measured_features(self, parent, m, features, received) -> dict:
        """The measured circles of ``m``'s nominal holes: {hole name: feature measurement id}."""
        found = {}
        for c in m.characteristics:
            if c.hole_index is not None and c.hole in features and c.hole not in found:
                hole = _record_hole(m.record, c.hole_index)
                if hole is not None:
                    found[c.hole] = hole
        if not found:
            return {}
        element = _sub(parent, "MeasuredFeatures", n=str(len(found)))
        ids = {}
        factor = self.factor(m.units)
        for name, hole in found.items():
            ids[name] = measurement_id = self.new_id()
            circle = _sub(element, "CircleFeatureMeasurement", id=measurement_id)
            _sub(circle, "FeatureItemId", features[name]["item"])
            if received is not None:
                _sub(circle, "TimeStamp", received)
            _sub(circle, "Location", _vector(v * factor for v in hole["center"]))
            _sub(circle, "Normal", _vector(_unit_vector(hole["normal"])))
            u = ((hole.get("uncertainty") or {}).get("diameter"))
            attrs = {} if u is None else {"combinedUncertainty": _decimal(u * factor)}
            _sub(circle, "Diameter", _decimal(hole["diameter"] * factor), **attrs)
        return ids

    def measured_characteristics(self, parent, m, measured, items, received):
        entries = [(c, self.item_of(c)) for c in m.characteristics]
        # A missing hole's characteristics measured in other records of the lot: not analysed here.
        missing = {c.hole for c in m.characteristics if c.name == PRESENCE}
        have = {id(item) for _, item in entries}
        for item in items.values():
            if item["hole"] in missing and item["name"] != PRESENCE and id(item) not in have:
                entries.append((None, item))
                have.add(id(item))
        if not entries:
            return
        element = _sub(_sub(parent, "MeasuredCharacteristics"), "CharacteristicMeasurements", n=str(len(entries)))
        k = (m.record.get("verdict") or {}).get("coverage_factor")
        for c, item in entries:
            kind = item["kind"]
            measurement = _sub(element, f"{kind}CharacteristicMeasurement", id=self.new_id())
            if c is None:
                self.attributes(measurement, [("reason", "missing")])
                _sub(_sub(measurement, "Status"), "CharacteristicStatusEnum", "NOT_ANALYZED")
                _sub(measurement, "CharacteristicItemId", item["id"])
                continue
            expanded = self.length(c.expanded_uncertainty, c.unit)
            if kind == "Position" and expanded is not None:
                expanded *= 2.0
            self.attributes(measurement, [
                ("reason", c.reason), ("expanded_uncertainty", None if expanded is None else _decimal(expanded)),
                ("coverage_factor", None if expanded is None or not k else _decimal(k)),
                ("warnings", " ".join(c.warnings))])
            _sub(_sub(measurement, "Status"), "CharacteristicStatusEnum",
                 CHARACTERISTIC_STATUS[c.decision])
            _sub(measurement, "CharacteristicItemId", item["id"])
            if received is not None:
                _sub(measurement, "TimeStamp", received)
            if c.hole in measured:
                ids = _sub(measurement, "FeatureMeasurementIds", n="1")
                _sub(ids, "Id", measured[c.hole])
            if kind == "UserDefinedAttribute":
                _sub(measurement, "Value", "missing")
                continue
            value = self.length(c.measured, c.unit)
            if value is None:
                continue
            attrs = {}
            if expanded is not None and k:
                attrs["combinedUncertainty"] = _decimal(expanded / k)
            _sub(measurement, "Value", _decimal(2.0 * value if kind == "Position" else value), **attrs)


def _sub(parent, tag, text=None, **attributes):
    """A child element ``tag`` of ``parent`` with ``text`` and ``attributes`` (each made a legal XML 1.0 string)."""
    element = ET.SubElement(parent, tag, {name: _xml(value) for name, value in attributes.items()})
    if text is not None:
        element.text = _xml(text)
    return element


# The characters XML 1.0 does not allow in a document (a record's file name may hold them).
_NOT_XML = re.compile("[\x00-\x08\x0b\x0c\x0e-\x1f\ud800-\udfff\ufffe\uffff]")


def _xml(text) -> str:
    """``text`` with every character XML 1.0 does not allow replaced by U+FFFD.

    Examples
    --------
    >>> _xml("scan\x01.ply")
    'scan\ufffd.ply'
    """
    return _NOT_XML.sub("\ufffd", str(text))


def _kind(name, unit) -> str:
    """The QIF characteristic type of a check."""
    if name in CHARACTERISTIC_TYPES:
        return CHARACTERISTIC_TYPES[name]
    return "UserDefinedAngular" if unit == "deg" else "UserDefinedLinear"


_DESCRIPTIONS = {
    "diameter": "holecli diameter: the hole's edge diameter on the surface",
    "countersink_diameter": "holecli countersink_diameter: the countersink's diameter on the surface",
    "bore_diameter": "holecli bore_diameter: the bore's diameter (cylinder fit to its wall)",
    "countersink_gauge": "holecli countersink_gauge: the countersink's diameter at the gauge depth",
    "countersink_depth": "holecli countersink_depth: the countersink's depth",
    "countersink_angle": "holecli countersink_angle: the countersink's included angle, degrees",
    "position": "holecli position: the in-plane distance d of the center from the nominal center <= T, "
                "written as a diametrical zone: tolerance 2T, value 2d",
    "tilt": "holecli tilt: the angle of the measured normal from the nominal normal, degrees",
    "perpendicularity": "holecli perpendicularity: the angle of the hole's axis from its surface normal, degrees",
    PRESENCE: "holecli presence: a nominal hole of the spec that the scan does not show",
}


def _describe(name) -> str:
    return _DESCRIPTIONS.get(name, f"holecli {name}")


def _record_hole(record, index):
    """The hole of ``record`` whose ``index`` is ``index`` (its place in ``holes`` when it has none)."""
    holes = record.get("holes") or []
    for position, hole in enumerate(holes):
        if isinstance(hole, dict) and hole.get("index", position) == index:
            return hole
    return None


def _unit_vector(values) -> list:
    values = [float(v) for v in values]
    norm = sum(v * v for v in values) ** 0.5
    return [v / norm for v in values] if norm > 0 else [0.0, 0.0, 1.0]
