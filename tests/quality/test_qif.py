"""holecli.quality.qif: QIF 3.0 Results of real records, each document validated against the official schemas."""

import copy
import json
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest
from lxml import etree

from holecli.quality.lot import lot_from_records
from holecli.quality.qif import CHARACTERISTIC_STATUS, QIF_NAMESPACE, qif_document
from holecli.tolerance import parse_spec

SCHEMA = Path(__file__).parent.parent / "data" / "qif3" / "QIFApplications" / "QIFDocument.xsd"
CREATED = "2026-01-02T03:04:05Z"
NS = {"q": QIF_NAMESPACE}
HOLECLI = [sys.executable, "-m", "holecli"]


@pytest.fixture(scope="module")
def schema():
    return etree.XMLSchema(etree.parse(str(SCHEMA)))


def assert_valid(schema, document):
    """Fails with lxml's error log when ``document`` does not validate against QIF 3.0."""
    valid = schema.validate(etree.fromstring(document))
    log = "\n".join(f"line {e.line}: {e.message}" for e in schema.error_log)
    assert valid, f"not a valid QIF 3.0 document:\n{log}"


def detect(*arguments):
    """The record of ``holecli detect`` (exit 0 in tolerance, 5 out or undecided)."""
    run = subprocess.run(HOLECLI + ["detect", *arguments], capture_output=True, text=True)
    assert run.returncode in (0, 5), run.stderr
    return json.loads(run.stdout)


@pytest.fixture(scope="module")
def records(tmp_path_factory):
    """Real records: the sample panel in tolerance; a simulated lot of 3 panels (part 2's C1 drilled
    0.1 mm large, part 3's L1 not drilled) with a file that is no scan (a batch error record); the
    panel checked under the guarded rule against tolerances tighter than its U, with a bore check a
    profiler cannot see and a tilt (undecided, not measured); the panel in metres; the panel without a
    spec."""
    folder = tmp_path_factory.mktemp("qif")
    spec = Path("sample_clouds/panel_tolerances.toml").read_text()
    out = {"pass": detect("sample_clouds/panel.ply", "--spec", "sample_clouds/panel_tolerances.toml")}
    subprocess.run(HOLECLI + ["simulate", "lot", str(folder / "lot"), "--parts", "3", "--panel",
                              "sample_clouds/panel.toml", "--spacing", "0.2", "--defect", "2/C1=diameter:+0.1",
                              "--defect", "3/L1=missing", "-q"], check=True)
    (folder / "lot" / "part_004.ply").write_text("not a point cloud\n")
    batch = subprocess.run(HOLECLI + ["batch", str(folder / "lot"), "--spec", "sample_clouds/panel_tolerances.toml",
                                      "-o", str(folder / "shift.jsonl"), "-q"], capture_output=True, text=True)
    assert batch.returncode != 0 and (folder / "shift.jsonl").exists(), batch.stderr
    lines = [json.loads(line) for line in (folder / "shift.jsonl").read_text().splitlines()]
    out["lot"] = sorted(lines, key=lambda record: record["file"])
    tight = folder / "tight.toml"
    tight.write_text(spec.replace("tolerance = 0.05\nposition_tolerance = 0.1",
                                  "tolerance = 0.03\nposition_tolerance = 0.1\nbore_diameter = 4.0\n"
                                  "bore_diameter_tolerance = 0.05\nnormal = [0.0, 0.0, 1.0]\nmax_tilt = 1", 1))
    out["guarded"] = detect("sample_clouds/panel.ply", "--spec", str(tight), "--decision-rule", "guarded")
    in_mm = folder / "mm.toml"
    in_mm.write_text('units = "mm"\n' + spec)
    out["metres"] = detect("sample_clouds/panel.ply", "--spec", str(in_mm), "--units", "mm", "--output-units", "m")
    out["unchecked"] = detect("sample_clouds/panel.ply")
    return out


def lot_of(*records, meta=None):
    return lot_from_records({"record": record, "source": f"test:{n}", **({"meta": meta} if meta else {})}
                            for n, record in enumerate(records, 1))


def parse(document):
    return ET.fromstring(document)


def results(root):
    return root.findall("q:Results/q:MeasurementResultsSet/q:MeasurementResults", NS)


def item_names(root):
    """{characteristic item id: its name ("T1 diameter")}."""
    return {item.get("id"): item.findtext("q:Name", namespaces=NS)
            for item in root.find("q:Characteristics/q:CharacteristicItems", NS)}


def measured(root, measurement_results):
    """{item name: characteristic measurement element} of one MeasurementResults."""
    names = item_names(root)
    out = {}
    for element in measurement_results.findall("q:MeasuredCharacteristics/q:CharacteristicMeasurements/*", NS):
        out[names[element.findtext("q:CharacteristicItemId", namespaces=NS)]] = element
    return out


def status(element):
    return element.findtext("q:Status/q:CharacteristicStatusEnum", namespaces=NS)


def inspection_status(measurement_results):
    return measurement_results.findtext("q:InspectionStatus/q:InspectionStatusEnum", namespaces=NS)


def attribute(element, name):
    for entry in element.findall("q:Attributes/q:AttributeStr", NS):
        if entry.get("name") == name:
            return entry.get("value")
    return None


def hole(record, name):
    return next(h for h in record["holes"] if h.get("name") == name)


def test_the_validator_catches_an_invalid_document(schema, records):
    document = qif_document(lot_of(records["pass"]), created=CREATED)
    assert_valid(schema, document)
    root = parse(document)
    first = root.find(".//q:CharacteristicMeasurements/*", NS)
    first.find("q:Status/q:CharacteristicStatusEnum", NS).text = "NOT_MEASURED"  # not a characteristic status
    broken = ET.tostring(root)
    with pytest.raises(AssertionError, match="CharacteristicStatusEnum"):
        assert_valid(schema, broken)
    first.remove(first.find("q:Status", NS))  # a required element gone
    with pytest.raises(AssertionError, match="not a valid QIF"):
        assert_valid(schema, ET.tostring(root))


def test_a_part_in_tolerance_passes_with_the_record_s_values(schema, records):
    record = records["pass"]
    document = qif_document(lot_of(record), created=CREATED)
    assert_valid(schema, document)
    root = parse(document)
    assert root.get("versionQIF") == "3.0.0"
    assert root.findtext("q:Header/q:Application/q:Name", namespaces=NS).startswith("holecli ")
    (only,) = results(root)
    assert inspection_status(only) == "PASS"
    values = measured(root, only)
    assert {status(element) for element in values.values()} == {"PASS"}
    k = record["verdict"]["coverage_factor"]
    t1 = hole(record, "T1")
    diameter = values["T1 diameter"].find("q:Value", NS)
    assert float(diameter.text) == t1["diameter"]  # the record's value, every digit
    assert float(diameter.get("combinedUncertainty")) == pytest.approx(
        t1["conformance"]["diameter"]["expanded_uncertainty"] / k, rel=1e-12)  # standard uncertainty, k = 1
    assert attribute(values["T1 diameter"], "coverage_factor") == "2.0"
    # position: the in-plane distance d <= T as GD&T's diametrical zone, 2d against 2T
    position = values["T1 position"].find("q:Value", NS)
    assert float(position.text) == pytest.approx(2 * t1["conformance"]["position"]["value"], rel=1e-15)
    c1 = hole(record, "C1")
    assert float(values["C1 countersink_angle"].findtext("q:Value", namespaces=NS)) == c1["countersink"]["angle_deg"]
    assert float(values["C1 countersink_depth"].findtext("q:Value", namespaces=NS)) == c1["countersink"]["depth"]
    assert float(values["C1 perpendicularity"].findtext("q:Value", namespaces=NS)) == c1["perpendicularity_deg"]
    assert values["C1 countersink_angle"].tag == f"{{{QIF_NAMESPACE}}}AngleCharacteristicMeasurement"
    assert values["C1 perpendicularity"].tag == f"{{{QIF_NAMESPACE}}}AngleFromCharacteristicMeasurement"
    assert values["C1 countersink_depth"].tag == f"{{{QIF_NAMESPACE}}}DepthCharacteristicMeasurement"


def test_definitions_and_nominals_hold_the_tolerances_and_targets(records):
    root = parse(qif_document(lot_of(records["pass"]), created=CREATED))
    characteristics = root.find("q:Characteristics", NS)
    definitions = {d.get("id"): d for d in characteristics.find("q:CharacteristicDefinitions", NS)}
    nominals = {n.get("id"): n for n in characteristics.find("q:CharacteristicNominals", NS)}
    by_name = {}
    for item in characteristics.find("q:CharacteristicItems", NS):
        nominal = nominals[item.findtext("q:CharacteristicNominalId", namespaces=NS)]
        by_name[item.findtext("q:Name", namespaces=NS)] = (
            definitions[nominal.findtext("q:CharacteristicDefinitionId", namespaces=NS)], nominal)
    definition, nominal = by_name["C1 countersink_angle"]  # 100 +/- 1 degrees
    assert float(nominal.findtext("q:TargetValue", namespaces=NS)) == pytest.approx(100.0)
    assert float(definition.findtext("q:Tolerance/q:MaxValue", namespaces=NS)) == 1.0
    assert float(definition.findtext("q:Tolerance/q:MinValue", namespaces=NS)) == -1.0
    definition, nominal = by_name["T1 diameter"]  # 4 +/- 0.05
    assert float(nominal.findtext("q:TargetValue", namespaces=NS)) == 4.0
    assert float(definition.findtext("q:Tolerance/q:MaxValue", namespaces=NS)) == 0.05
    definition, _ = by_name["T1 position"]  # 0.1 in the plane: a diametrical zone of 0.2
    assert float(definition.findtext("q:ToleranceValue", namespaces=NS)) == pytest.approx(0.2)
    assert definition.find("q:ZoneShape/q:DiametricalZone", NS) is not None
    definition, nominal = by_name["B1 perpendicularity"]  # at most 0.5 degrees
    assert float(nominal.findtext("q:TargetValue", namespaces=NS)) == 0.0
    assert float(definition.findtext("q:Tolerance/q:MaxValue", namespaces=NS)) == 0.5
    # a feature per hole: the nominal diameter; the location the record's first measurement's, said so
    features = root.find("q:Features", NS)
    assert [i.findtext("q:FeatureName", namespaces=NS) for i in features.find("q:FeatureItems", NS)] == \
        ["T1", "C1", "B1", "L1"]
    diameters = [float(d.findtext("q:Diameter", namespaces=NS)) for d in features.find("q:FeatureDefinitions", NS)]
    assert diameters == [4.0, 7.0, 7.0, 4.0]
    first = features.find("q:FeatureNominals/q:CircleFeatureNominal", NS)
    assert attribute(first, "nominal_location").startswith("measured in panel")


def test_a_spec_places_the_features_at_their_nominal_centers(schema, records):
    spec = parse_spec(Path("sample_clouds/panel_tolerances.toml").read_text())
    document = qif_document(lot_of(records["pass"]), created=CREATED, spec=spec)
    assert_valid(schema, document)
    nominals = parse(document).findall("q:Features/q:FeatureNominals/q:CircleFeatureNominal", NS)
    assert [n.findtext("q:Location", namespaces=NS) for n in nominals] == \
        ["-20.0 8.0 0.0", "-6.0 8.0 0.0", "8.0 8.0 0.0", "20.0 8.0 0.0"]
    assert {attribute(n, "nominal_location") for n in nominals} == {"spec"}


def test_a_lot_with_a_failed_hole_a_missing_hole_and_an_error_record(schema, records):
    lot = lot_of(*records["lot"])
    assert [m.verdict for m in lot.measurements] == ["pass", "fail", "fail", "error"]
    document = qif_document(lot, created=CREATED)
    assert_valid(schema, document)
    root = parse(document)
    part1, part2, part3, broken = results(root)
    assert [inspection_status(r) for r in results(root)] == ["PASS", "FAIL", "FAIL", "NOT_MEASURED"]
    # part 2: C1 drilled 0.1 mm large
    c1 = measured(root, part2)["C1 diameter"]
    assert status(c1) == "FAIL" and attribute(c1, "reason") == "outside"
    assert float(c1.findtext("q:Value", namespaces=NS)) == hole(records["lot"][1], "C1")["diameter"]
    assert status(measured(root, part2)["T1 diameter"]) == "PASS"
    # part 3: L1 not drilled: its presence fails, its other characteristics are not analysed
    part3_values = measured(root, part3)
    presence = part3_values["L1 presence"]
    assert status(presence) == "FAIL" and presence.findtext("q:Value", namespaces=NS) == "missing"
    for name in ("L1 diameter", "L1 position"):
        assert status(part3_values[name]) == "NOT_ANALYZED" and part3_values[name].find("q:Value", NS) is None
    assert "L1 presence" not in measured(root, part1)
    circles = part3.findall("q:MeasuredFeatures/q:CircleFeatureMeasurement", NS)
    assert len(circles) == 3  # T1, C1, B1
    # the file that is no scan: no feature, no characteristic, its error said
    assert broken.find("q:MeasuredCharacteristics", NS) is None
    assert "part_004" in broken.findtext("q:InspectionTraceability/q:Errors/q:Error", namespaces=NS)
    components = root.findall("q:Results/q:ActualComponentSets/q:ActualComponentSet/q:ActualComponent", NS)
    assert [attribute(c, "label") for c in components] == ["part_001", "part_002", "part_003", "part_004"]


def test_undecided_is_indeterminate_and_not_measured_has_no_value(schema, records):
    record = records["guarded"]
    document = qif_document(lot_of(record), created=CREATED)
    assert_valid(schema, document)
    root = parse(document)
    (only,) = results(root)
    values = measured(root, only)
    t1 = hole(record, "T1")["conformance"]["diameter"]
    assert (t1["decision"], t1["reason"]) == ("undecided", "straddles_both")  # -0.01 +- U 0.046 crosses both of +-0.03
    assert status(values["T1 diameter"]) == "INDETERMINATE"
    assert attribute(values["T1 diameter"], "reason") == "straddles_both"
    bore = values["T1 bore_diameter"]  # a profiler looking down never sees the bore's wall
    assert status(bore) == "FAIL" and attribute(bore, "reason") == "not_measured"
    assert bore.find("q:Value", NS) is None
    assert inspection_status(only) == "FAIL"  # a check not measured fails the part
    tilt = values["T1 tilt"]  # the angle between the measured and the nominal normal, degrees
    assert tilt.tag == f"{{{QIF_NAMESPACE}}}AngleFromCharacteristicMeasurement"
    assert float(tilt.findtext("q:Value", namespaces=NS)) == hole(record, "T1")["tilt_deg"]


def test_an_undecided_part_is_unknown(schema, records):
    record = copy.deepcopy(records["guarded"])
    for h in record["holes"]:  # drop the not-measured bore: the part is then undecided only
        h["conformance"].pop("bore_diameter", None)
    record["verdict"].update(out_of_tolerance=0, missing=[])
    document = qif_document(lot_of(record), created=CREATED)
    assert_valid(schema, document)
    (only,) = results(parse(document))
    assert inspection_status(only) == "UNKNOWN"


def test_an_empty_lot_is_a_valid_document_without_results(schema):
    document = qif_document(lot_of(), created=CREATED)
    assert_valid(schema, document)
    root = parse(document)
    assert root.find("q:Results", NS) is None and root.find("q:Characteristics", NS) is None


def test_an_unchecked_record_is_not_calculated(schema, records):
    document = qif_document(lot_of(records["unchecked"]), created=CREATED)
    assert_valid(schema, document)
    (only,) = results(parse(document))
    assert inspection_status(only) == "NOT_CALCULATED"


def test_a_lot_in_metres_is_written_in_metres(schema, records):
    record = records["metres"]
    assert record["units"] == "m"
    document = qif_document(lot_of(record), created=CREATED)
    assert_valid(schema, document)
    root = parse(document)
    assert root.findtext("q:FileUnits/q:PrimaryUnits/q:LinearUnit/q:UnitName", namespaces=NS) == "m"
    assert root.findtext("q:FileUnits/q:PrimaryUnits/q:LinearUnit/q:UnitConversion/q:Factor",
                         namespaces=NS) == "1.0"
    (only,) = results(root)
    value = float(measured(root, only)["T1 diameter"].findtext("q:Value", namespaces=NS))
    assert value == hole(record, "T1")["diameter"] == pytest.approx(0.004, abs=1e-4)
    assert attribute(root, "length_unit_assumed") is None


def test_undeclared_and_mixed_units_are_written_in_mm_and_said(schema, records):
    document = qif_document(lot_of(records["metres"], records["pass"]), created=CREATED)
    assert_valid(schema, document)
    root = parse(document)
    assert root.findtext("q:FileUnits/q:PrimaryUnits/q:LinearUnit/q:UnitName", namespaces=NS) == "mm"
    assert attribute(root, "length_unit_assumed").startswith("1 record(s) declare no length unit")
    assert "taken to be mm" in root.findtext("q:Header/q:Description", namespaces=NS)
    in_metres, undeclared = results(root)
    converted = float(measured(root, in_metres)["T1 diameter"].findtext("q:Value", namespaces=NS))
    assert converted == pytest.approx(hole(records["metres"], "T1")["diameter"] * 1000.0, rel=1e-12)
    as_is = float(measured(root, undeclared)["T1 diameter"].findtext("q:Value", namespaces=NS))
    assert as_is == hole(records["pass"], "T1")["diameter"]
    # the angles are degrees whatever the length unit
    angle = float(measured(root, in_metres)["C1 countersink_angle"].findtext("q:Value", namespaces=NS))
    assert angle == hole(records["metres"], "C1")["countersink"]["angle_deg"]


def test_the_store_s_serial_and_time_are_written(schema, records):
    lot = lot_from_records([{"record": records["pass"], "source": "store", "id": "m-1",
                             "received": "2026-03-04T05:06:07.123Z", "meta": {"serial": "SN-7", "part": "P-1"}}])
    document = qif_document(lot, created=CREATED)
    assert_valid(schema, document)
    root = parse(document)
    (only,) = results(root)
    assert only.findtext("q:InspectionTraceability/q:InspectionStart", namespaces=NS) == "2026-03-04T05:06:07.123Z"
    assert {e.findtext("q:TimeStamp", namespaces=NS) for e in measured(root, only).values()} == \
        {"2026-03-04T05:06:07.123Z"}
    component = root.find(".//q:ActualComponent", NS)
    assert component.findtext("q:SerialNumber", namespaces=NS) == "SN-7"
    assert attribute(component, "part") == "P-1"


def test_the_document_is_the_same_for_the_same_lot_and_time(records):
    lot = lot_of(*records["lot"])
    first = qif_document(lot, created=CREATED)
    assert qif_document(lot, created="2026-01-02T03:04:05+00:00") == first
    assert qif_document(lot, created="2026-01-02T03:04:06Z") != first
    root = parse(first)
    ids = [int(e.get("id")) for e in root.iter() if e.get("id") is not None]
    assert len(ids) == len(set(ids)) and max(ids) == int(root.get("idMax"))
    # every list says how many it holds (the schema cannot check it; readers rely on it)
    counted = [(e.tag, int(e.get("n")), len(e)) for e in root.iter() if e.get("n") is not None]
    assert counted and all(n == children for _, n, children in counted)


def test_every_decision_a_lot_can_hold_has_its_status():
    from holecli.quality.lot import DECISIONS

    assert set(CHARACTERISTIC_STATUS) == {*DECISIONS, "missing"}


def test_a_decision_no_record_holds_is_refused_before_writing(records):
    record = copy.deepcopy(records["pass"])
    hole(record, "T1")["conformance"]["diameter"]["decision"] = "maybe"
    with pytest.raises(ValueError, match="not a conformance entry"):
        lot_of(record)


def test_a_created_time_that_is_no_time_is_refused():
    with pytest.raises(ValueError, match="ISO-8601"):
        qif_document(lot_of(), created="yesterday")


def test_a_hole_no_measurement_found_has_a_feature_only_where_a_spec_places_it(schema, records):
    missing_l1 = records["lot"][2]
    assert missing_l1["verdict"]["missing"] == ["L1"]
    alone = qif_document(lot_of(missing_l1), created=CREATED)
    assert_valid(schema, alone)
    root = parse(alone)
    assert [i.findtext("q:FeatureName", namespaces=NS) for i in root.find("q:Features/q:FeatureItems", NS)] == \
        ["T1", "C1", "B1"]
    presence = next(i for i in root.find("q:Characteristics/q:CharacteristicItems", NS)
                    if i.findtext("q:Name", namespaces=NS) == "L1 presence")
    assert presence.find("q:FeatureItemIds", NS) is None
    spec = parse_spec(Path("sample_clouds/panel_tolerances.toml").read_text())
    placed = qif_document(lot_of(missing_l1), created=CREATED, spec=spec)
    assert_valid(schema, placed)
    root = parse(placed)
    nominal = root.findall("q:Features/q:FeatureNominals/q:CircleFeatureNominal", NS)[-1]
    assert nominal.findtext("q:Location", namespaces=NS) == "20.0 8.0 0.0"
    assert attribute(nominal, "nominal_location") == "spec"
    assert attribute(nominal, "nominal_diameter") == "spec"


def test_every_check_the_tolerances_make_has_its_qif_type():
    from holecli.quality.lot import SIZE_CHECKS, ZONE_CHECKS
    from holecli.quality.qif import CHARACTERISTIC_TYPES
    assert set(SIZE_CHECKS) | set(ZONE_CHECKS) <= set(CHARACTERISTIC_TYPES)


@pytest.mark.parametrize("unit", ["deg", "mm"])
def test_a_check_unknown_to_the_writer_is_a_user_defined_characteristic(schema, records, unit, monkeypatch):
    import holecli.quality.lot as lot_module
    record = copy.deepcopy(records["pass"])
    entry = dict(hole(record, "T1")["conformance"]["diameter"], value=0.25)
    hole(record, "T1")["conformance"]["new_check"] = entry
    if unit == "deg":
        monkeypatch.setattr(lot_module, "ANGLE_CHECKS", lot_module.ANGLE_CHECKS + ("new_check",))
    document = qif_document(lot_of(record), created=CREATED)
    assert_valid(schema, document)
    root = parse(document)
    (only,) = results(root)
    element = measured(root, only)["T1 new_check"]
    kind = "UserDefinedAngular" if unit == "deg" else "UserDefinedLinear"
    assert element.tag == f"{{{QIF_NAMESPACE}}}{kind}CharacteristicMeasurement"
    assert status(element) == "PASS"


def test_a_lot_in_inches_is_written_in_inches(schema, records):
    from holecli.units import convert_record
    record = convert_record(records["pass"], "mm", "in")  # the project's conversion, as --output-units in
    document = qif_document(lot_of(record, record), created=CREATED)
    assert_valid(schema, document)
    root = parse(document)
    assert root.findtext("q:FileUnits/q:PrimaryUnits/q:LinearUnit/q:UnitName", namespaces=NS) == "inch"
    assert float(root.findtext("q:FileUnits/q:PrimaryUnits/q:LinearUnit/q:UnitConversion/q:Factor",
                               namespaces=NS)) == pytest.approx(0.0254)
    first, _ = results(root)
    value = float(measured(root, first)["T1 diameter"].findtext("q:Value", namespaces=NS))
    assert value == hole(record, "T1")["diameter"] == pytest.approx(3.99 / 25.4, rel=1e-3)
    # one item per characteristic over the lot: the second part's values share the first's items
    assert len(item_names(root)) == len(lot_of(record).measurements[0].characteristics)


def test_a_record_checked_against_another_band_gets_its_own_item(schema, records):
    document = qif_document(lot_of(records["pass"], records["guarded"]), created=CREATED)
    assert_valid(schema, document)
    root = parse(document)
    characteristics = root.find("q:Characteristics", NS)
    nominals = {n.get("id"): n.findtext("q:CharacteristicDefinitionId", namespaces=NS)
                for n in characteristics.find("q:CharacteristicNominals", NS)}
    definitions = {d.get("id"): d for d in characteristics.find("q:CharacteristicDefinitions", NS)}
    items = [i for i in characteristics.find("q:CharacteristicItems", NS)
             if i.findtext("q:Name", namespaces=NS) == "T1 diameter"]
    bands = [float(definitions[nominals[i.findtext("q:CharacteristicNominalId", namespaces=NS)]].findtext(
        "q:Tolerance/q:MaxValue", namespaces=NS)) for i in items]
    assert bands == [0.05, 0.03]  # panel_tolerances.toml's, then the tight spec's
    tolerant, tight = results(root)
    assert status(measured(root, tolerant)["T1 diameter"]) == "PASS"


def test_the_part_number_names_the_measured_parts(schema, records):
    lot = lot_from_records([
        {"record": records["pass"], "source": "store:1", "meta": {"serial": "SN-1", "part": "PN-7"}},
        {"record": records["pass"], "source": "store:2", "meta": {"serial": "SN-2"}},
        {"record": records["pass"], "source": "store:3", "meta": {"serial": "SN-3", "part": "PN-7"}}])
    document = qif_document(lot, created=CREATED, part_number="PN-9")
    assert_valid(schema, document)
    root = parse(document)
    product = root.find("q:Product", NS)
    parts = {p.get("id"): p.findtext("q:ModelNumber", namespaces=NS) for p in product.find("q:PartSet", NS)}
    assert sorted(parts.values()) == ["PN-7", "PN-9"]
    component_part = {c.get("id"): parts[c.findtext("q:Part/q:Id", namespaces=NS)]
                      for c in product.find("q:ComponentSet", NS)}
    path_part = {p.get("id"): component_part[p.findtext("q:ComponentIds/q:Id", namespaces=NS)]
                 for p in product.find("q:AsmPaths", NS)}
    actual = root.findall("q:Results/q:ActualComponentSets/q:ActualComponentSet/q:ActualComponent", NS)
    assert [(a.findtext("q:SerialNumber", namespaces=NS), path_part[a.findtext("q:AsmPathId", namespaces=NS)])
            for a in actual] == [("SN-1", "PN-7"), ("SN-2", "PN-9"), ("SN-3", "PN-7")]
    # no part number anywhere: no product
    assert parse(qif_document(lot_of(records["pass"]), created=CREATED)).find("q:Product", NS) is None


def test_a_character_xml_does_not_allow_is_replaced_not_written(schema, records):
    record = copy.deepcopy(records["pass"])
    record["file"] = "scans/part\x01\x1f.ply"
    document = qif_document(lot_of(record), created=CREATED)
    assert_valid(schema, document)
    assert "part\ufffd\ufffd" in document.decode("utf-8")
