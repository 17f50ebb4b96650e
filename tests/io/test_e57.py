"""E57 files that lie with valid checksums (issue 23): counts and offsets the data does not bear out,
XML nested to crash libE57, poses written out of order or not finite, Strings and Vectors where
numbers and CompressedVectors belong; and pye57's own test files.

Every lie is made with :mod:`e57_edit`, which recomputes each page's CRC-32C: libE57's checksum test
passes, and only the reader's own checks stand between the lie and a measurement.
"""

import re
from pathlib import Path

import numpy as np
import pytest
from e57_edit import first_packet, logical, points_section, to_physical, with_logical, with_xml, xml_of

from holecli.errors import LoadError
from holecli.io import read_cloud
from holecli.io.e57 import _check_stream, _Field

pye57 = pytest.importorskip("pye57")
libe57 = pytest.importorskip("pye57.libe57")

DATA = Path(__file__).resolve().parents[1] / "data" / "e57"


def _points(n=300, seed=0):
    return np.random.default_rng(seed).uniform(-1.0, 1.0, size=(n, 3))


def _single(points):
    return points.astype(np.float32).astype(np.float64)


def write_e57(path, points, rotation=(1, 0, 0, 0), translation=(0, 0, 0), invalid=None):
    with pye57.E57(str(path), mode="w") as e57:
        data = {name: np.ascontiguousarray(points[:, axis]) for axis, name in enumerate(("cartesianX", "cartesianY", "cartesianZ"))}
        if invalid is not None:
            data["cartesianInvalidState"] = np.asarray(invalid, dtype=np.int8)
        e57.write_scan_raw(data, rotation=np.asarray(rotation, float), translation=np.asarray(translation, float))
    return path


def write_scaled_e57(path, points, scale=1e-4):
    """One scan of ScaledInteger coordinates (bit-packed, as scanners write them), through libE57."""
    raw = np.round(points / scale).astype(np.int64)
    names = ("cartesianX", "cartesianY", "cartesianZ")
    with pye57.E57(str(path), mode="w") as e57:
        imf = e57.image_file
        scan = libe57.StructureNode(imf)
        scan.set("guid", libe57.StringNode(imf, "{scaled}"))
        prototype = libe57.StructureNode(imf)
        for axis, name in enumerate(names):
            low, high = int(raw[:, axis].min()), int(raw[:, axis].max())
            prototype.set(name, libe57.ScaledIntegerNode(imf, low, low, high, scale, 0.0))
        node = libe57.CompressedVectorNode(imf, prototype, libe57.VectorNode(imf, True))
        scan.set("points", node)
        e57.data3d.append(scan)
        columns = [np.empty(len(raw), "q") for _ in names]  # "q": pye57 takes numpy's "l" for 32 bits
        buffers = libe57.VectorSourceDestBuffer()
        for axis, name in enumerate(names):
            columns[axis][:] = raw[:, axis]
            buffers.append(libe57.SourceDestBuffer(imf, name, columns[axis], len(raw), True, False))
        writer = node.writer(buffers)
        writer.write(len(raw))
        writer.close()
    return path


@pytest.fixture
def e57_file(tmp_path):
    points = _points()
    return write_e57(tmp_path / "good.e57", points), _single(points)


def _refused(path, pattern):
    with pytest.raises(LoadError) as error:
        read_cloud(path)
    message = str(error.value)
    assert message.startswith(f"{path}: ") and "\n" not in message
    assert re.search(pattern, message), message
    return message


def _set_count(data, count):
    return with_xml(data, lambda xml: re.sub(rb'recordCount="\d+"', b'recordCount="%d"' % count, xml, count=1))


def test_the_edit_helper_keeps_a_file_readable(e57_file, tmp_path):
    path, points = e57_file
    same = tmp_path / "same.e57"
    same.write_bytes(with_xml(path.read_bytes(), lambda xml: xml + b"\n  "))
    np.testing.assert_array_equal(read_cloud(same).points, points)


# --- item 1: counts and offsets the data does not hold --------------------------------------


@pytest.mark.parametrize("count, pattern", [
    (301, r"its 301 points announced, the data holds 300"),
    (100_000_000, r"its 100000000 points announced, the data holds 300"),
    (299, r"its data holds 300 points' worth, 299 announced"),
    (150, r"its data holds 300 points' worth, 150 announced"),
])
def test_a_record_count_the_data_does_not_hold_is_refused(e57_file, tmp_path, count, pattern):
    path, _ = e57_file
    lying = tmp_path / "count.e57"
    lying.write_bytes(_set_count(path.read_bytes(), count))
    assert pye57.E57(str(lying)).get_header(0).point_count == count  # libE57 takes the lie
    _refused(lying, r"damaged E57 file \(scan 0: " + pattern)


@pytest.mark.parametrize("change", [+1, -1])
def test_a_lying_count_of_bit_packed_coordinates_is_refused(tmp_path, change):
    points = _points(1001)
    path = write_scaled_e57(tmp_path / "scaled.e57", points)
    np.testing.assert_allclose(read_cloud(path).points, points, rtol=0, atol=0.5e-4)
    lying = tmp_path / "lying.e57"
    lying.write_bytes(_set_count(path.read_bytes(), 1001 + change))
    _refused(lying, r"damaged E57 file \(scan 0: .*cartesianX: \d+ bytes, 15 bits a point")


@pytest.mark.parametrize("records, held, refused", [
    # 24-bit values in a 32-bit register: 1000 records are 3000 bytes exactly
    (1000, 3000, False), (1000, 2999, True), (1000, 3001, True),
    # 1001 records are 3003 bytes, padded to 3004 (one register)
    (1001, 3003, False), (1001, 3004, False), (1001, 3002, True), (1001, 3005, True),
])
def test_bit_packed_streams_may_hold_libe57s_last_register_of_padding_only(records, held, refused):
    field = _Field("cartesianX", "ScaledInteger", 24, 4)
    if refused:
        with pytest.raises(Exception, match="damaged E57 file"):
            _check_stream(field, held, records, "scan 0")
    else:
        _check_stream(field, held, records, "scan 0")


def test_floats_must_hold_the_records_exactly():
    field = _Field("cartesianX", "Float", 32)
    _check_stream(field, 400, 100, "scan 0")
    for held in (396, 404):
        with pytest.raises(Exception, match="damaged E57 file"):
            _check_stream(field, held, 100, "scan 0")


def test_a_constant_field_with_bytes_is_refused(e57_file, tmp_path):
    # cartesianInvalidState written constant (minimum = maximum = 0): now said to take 2 bits
    path = write_e57(tmp_path / "flags.e57", _points(), invalid=np.zeros(300))
    lying = tmp_path / "range.e57"
    lying.write_bytes(with_xml(path.read_bytes(), lambda xml: xml.replace(
        b'<cartesianInvalidState type="Integer" minimum="0" maximum="0"/>',
        b'<cartesianInvalidState type="Integer" minimum="0" maximum="2"/>')))
    _refused(lying, r"its 300 points announced, the data holds 0 \(cartesianInvalidState")


def test_a_scan_whose_fields_are_all_constant_is_refused(tmp_path, e57_file):
    path, _ = e57_file
    lying = tmp_path / "constant.e57"

    def constant(xml):
        for axis in (b"X", b"Y", b"Z"):
            xml = re.sub(rb'<cartesian' + axis + rb' type="Float"[^>]*>[^<]*</cartesian' + axis + rb'>',
                         b'<cartesian' + axis + b' type="Integer" minimum="0" maximum="0"/>', xml)
        return re.sub(rb'recordCount="\d+"', b'recordCount="100000000"', xml)

    lying.write_bytes(with_xml(path.read_bytes(), constant))
    _refused(lying, r"scan 0: its points carry no data \(every field is constant\)")


def test_a_file_offset_elsewhere_is_refused(e57_file, tmp_path):
    path, _ = e57_file
    data = path.read_bytes()
    for offset, pattern in ((1020, r"is not a data byte"), (1024, r"is not a CompressedVector section"),
                            (10 ** 9, r"is not a data byte")):
        lying = tmp_path / "offset.e57"
        lying.write_bytes(with_xml(data, lambda xml: re.sub(rb'fileOffset="\d+"', b'fileOffset="%d"' % offset, xml)))
        _refused(lying, pattern)


def test_a_data_packet_offset_or_stream_length_that_lies_is_refused(e57_file, tmp_path):
    path, _ = e57_file
    data = path.read_bytes()
    section, packet = points_section(data), first_packet(data)
    lying = tmp_path / "packet.e57"
    # the section's first data packet moved on by 4 bytes: inside the packet, not a packet
    lying.write_bytes(with_logical(data, section + 16, (to_physical(packet) + 4).to_bytes(8, "little")))
    _refused(lying, r"damaged E57 file \(scan 0: ")
    # cartesianX's buffer 4 bytes shorter, cartesianY's 4 longer: the packet adds up, the streams do not
    body = logical(data)
    x_length, y_length = int.from_bytes(body[packet + 6: packet + 8], "little"), int.from_bytes(body[packet + 8: packet + 10], "little")
    edited = with_logical(data, packet + 6, (x_length - 4).to_bytes(2, "little") + (y_length + 4).to_bytes(2, "little"))
    lying.write_bytes(edited)
    _refused(lying, r"its 300 points announced, the data holds 299 \(cartesianX")


def test_points_with_another_codec_are_refused(e57_file, tmp_path):
    path, _ = e57_file
    lying = tmp_path / "codec.e57"
    lying.write_bytes(with_xml(path.read_bytes(), lambda xml: re.sub(
        rb'(<codecs type="Vector"[^>]*>)', rb'\1<codec type="Structure"><inputs type="Vector"/></codec>', xml)))
    _refused(lying, r"scan 0: its points use a codec other than bit-packing$")


# --- item 2: XML that crashes libE57 ----------------------------------------------------------


def test_deeply_nested_xml_is_refused_before_libe57_parses_it(e57_file, tmp_path):
    path, _ = e57_file
    depth = 200_000
    nested = b'<a type="Structure">' * depth + b"</a>" * depth
    lying = tmp_path / "deep.e57"
    lying.write_bytes(with_xml(path.read_bytes(), lambda xml: xml.replace(b"</e57Root>", b"<deep type=\"Structure\">" + nested + b"</deep></e57Root>")))
    _refused(lying, r"unsupported E57 file \(its XML nests deeper than 64 elements\)$")


def test_xml_with_a_doctype_is_refused(e57_file, tmp_path):
    path, _ = e57_file
    lying = tmp_path / "doctype.e57"
    lying.write_bytes(with_xml(path.read_bytes(), lambda xml: xml.replace(b"<e57Root", b"<!DOCTYPE e57Root [<!ENTITY a \"b\">]>\n<e57Root", 1)))
    _refused(lying, r"its XML has a DOCTYPE")


def test_xml_that_is_not_well_formed_is_refused(e57_file, tmp_path):
    path, _ = e57_file
    lying = tmp_path / "broken.e57"
    lying.write_bytes(with_xml(path.read_bytes(), lambda xml: xml.replace(b"</e57Root>", b"</e57Rot>")))
    _refused(lying, r"damaged E57 file \(its XML is not well-formed: mismatched tag")


# --- item 3: the pose read by name --------------------------------------------------------------


def _pose_xml(rotation, translation):
    return (b'<pose type="Structure"><rotation type="Structure">' + rotation + b'</rotation>'
            b'<translation type="Structure">' + translation + b'</translation></pose>')


def _with_pose(data, pose):
    return with_xml(data, lambda xml: re.sub(rb"<pose type=\"Structure\">.*?</pose>", pose, xml, count=1, flags=re.S))


def test_a_pose_is_read_by_name_not_position(e57_file, tmp_path):
    path, points = e57_file
    data = path.read_bytes()
    moved = tmp_path / "pose.e57"
    # the identity written x, y, z, w: libE57 gives (0, 0, 0, 1) by position, a half turn about z
    identity = b'<x type="Float"/><y type="Float"/><z type="Float"/><w type="Float">1</w>'
    translation = b'<z type="Float">3</z><y type="Float">2</y><x type="Float">1</x>'
    moved.write_bytes(_with_pose(data, _pose_xml(identity, translation)))
    np.testing.assert_allclose(read_cloud(moved).points, points + [1.0, 2.0, 3.0], rtol=0, atol=1e-12)
    # a quarter turn about z, written z, w, y, x
    half = np.sqrt(0.5)
    turn = b'<z type="Float">%r</z><w type="Float">%r</w><y type="Float"/><x type="Float"/>' % (float(half), float(half))
    moved.write_bytes(_with_pose(data, _pose_xml(turn, b'<x type="Float"/><y type="Float"/><z type="Float"/>')))
    expected = np.column_stack([-points[:, 1], points[:, 0], points[:, 2]])
    np.testing.assert_allclose(read_cloud(moved).points, expected, rtol=0, atol=1e-12)


@pytest.mark.parametrize("value", [b"NaN", b"INF", b"-INF", b"1e400", b"nan"])
@pytest.mark.parametrize("where", ["rotation", "translation"])
def test_a_pose_that_is_not_finite_is_refused(e57_file, tmp_path, value, where):
    path, _ = e57_file
    rotation = b'<w type="Float">1</w><x type="Float"/><y type="Float"/><z type="Float"/>'
    translation = b'<x type="Float"/><y type="Float"/><z type="Float"/>'
    if where == "rotation":
        rotation = rotation.replace(b'<x type="Float"/>', b'<x type="Float">' + value + b"</x>")
    else:
        translation = translation.replace(b'<y type="Float"/>', b'<y type="Float">' + value + b"</y>")
    lying = tmp_path / "nan.e57"
    lying.write_bytes(_with_pose(path.read_bytes(), _pose_xml(rotation, translation)))
    axis = "x" if where == "rotation" else "y"
    _refused(lying, rf"scan 0: the pose's {where} {axis} is '{value.decode()}', not a finite number$")


@pytest.mark.parametrize("attribute", [b'scale="NaN"', b'scale="INF"', b'offset="-INF"', b'scale="0"'])
def test_a_scaled_integer_whose_scale_or_offset_is_not_finite_is_refused(tmp_path, attribute):
    path = write_scaled_e57(tmp_path / "scaled.e57", _points(200))
    name = attribute.split(b"=")[0]
    lying = tmp_path / "scale.e57"
    # (libE57 leaves out an offset of 0: the edit sets the attribute of cartesianX, first of the fields)
    def edit(xml):
        tag = re.search(rb'<cartesianX type="ScaledInteger"[^>]*>', xml).group(0)
        changed = re.sub(rb" " + name + rb'="[^"]*"', b"", tag).replace(b' type="ScaledInteger"', b' type="ScaledInteger" ' + attribute)
        return xml.replace(tag, changed, 1)

    lying.write_bytes(with_xml(path.read_bytes(), edit))
    _refused(lying, rf"scan 0: field cartesianX has {name.decode()} .*, not a finite")


def test_a_string_pose_is_refused_in_one_line(e57_file, tmp_path):
    path, _ = e57_file
    rotation = b'<w type="Float">1</w><x type="Float"/><y type="Float"/><z type="Float"/>'
    translation = b'<x type="String"><![CDATA[1]]></x><y type="Float"/><z type="Float"/>'
    lying = tmp_path / "string.e57"
    lying.write_bytes(_with_pose(path.read_bytes(), _pose_xml(rotation, translation)))
    _refused(lying, r"scan 0: the pose's translation x is a String, not a number$")
    lying.write_bytes(_with_pose(path.read_bytes(), b'<pose type="Structure"><rotation type="String"/></pose>'))
    _refused(lying, r"scan 0: the pose's rotation is a String, not a Structure$")


def test_points_stored_as_a_vector_are_refused_in_one_line(e57_file, tmp_path):
    path, _ = e57_file
    lying = tmp_path / "vector.e57"
    lying.write_bytes(with_xml(path.read_bytes(), lambda xml: re.sub(
        rb'<points type="CompressedVector".*?</points>',
        b'<points type="Vector" allowHeterogeneousChildren="0"><vectorChild type="Structure">'
        b'<cartesianX type="Float">1</cartesianX><cartesianY type="Float">2</cartesianY>'
        b'<cartesianZ type="Float">3</cartesianZ></vectorChild></points>', xml, flags=re.S)))
    _refused(lying, r"scan 0: its points are a Vector, not a CompressedVector$")


# --- item 5: pye57's own test files -------------------------------------------------------------


@pytest.mark.parametrize("name, count", [("pye57_testWithNormals.e57", 2),
                                         ("pye57_translationWithoutRotation.e57", 4)])
def test_pye57_test_files_read_as_pye57_reads_them(name, count):
    path = DATA / name
    cloud = read_cloud(path)
    with pye57.E57(str(path)) as e57:
        parts = []
        for index in range(e57.scan_count):
            scan = e57.read_scan(index, transform=True, ignore_missing_fields=True)
            parts.append(np.column_stack([scan["cartesianX"], scan["cartesianY"], scan["cartesianZ"]]))
    expected = np.concatenate(parts)
    assert len(cloud.points) == count and cloud.dropped == 0
    np.testing.assert_allclose(cloud.points, expected, rtol=0, atol=1e-12)


def test_pye57_translation_without_rotation_is_moved():
    path = DATA / "pye57_translationWithoutRotation.e57"
    xml = xml_of(path.read_bytes())
    assert b"<rotation" not in xml and b"<translation" in xml
    with pye57.E57(str(path)) as e57:
        raw = e57.read_scan(0, transform=False, ignore_missing_fields=True)
    raw = np.column_stack([raw["cartesianX"], raw["cartesianY"], raw["cartesianZ"]])
    np.testing.assert_allclose(read_cloud(path).points, raw + [4.0, 5.0, 6.0], rtol=0, atol=1e-12)
