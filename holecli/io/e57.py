"""E57 reading (ASTM E2807, what FARO, Leica and Hexagon scanners export), through the optional ``pye57``.

An E57 file holds one or more scans (``data3D``), each with its points in its own frame and a pose
(a rotation quaternion and a translation) that puts them in the file's common frame. Coordinates are
in metres, by the standard. :func:`read_e57` reads every scan, each transformed by its pose, into one
array, or the one scan asked for.

The file's structure is read here first, before libE57 sees the file, and every number that says
where points are or how many there are is checked against the bytes that hold them:

- the physical header (``ASTM-E57``, version 1, page size 1024, the file's length, where the XML
  section is); every 1024-byte page read here is 1020 bytes of data and the CRC-32C of them, checked
  (libE57 checks the pages it reads the same way);
- the XML section, parsed with a depth and a size limit (:data:`_MAX_XML_DEPTH`,
  :data:`_MAX_XML_ELEMENTS`, :data:`_MAX_XML_BYTES`) and without a DOCTYPE: libE57's parser (xerces)
  recurses once per level and crashes on a document nested 200,000 deep;
- each scan's ``points``, which must be a CompressedVector: its binary section header and every
  data packet of it are walked, the bytes of each field's bytestream added up, and the stream must
  hold exactly ``recordCount`` records (:func:`_check_stream`): a float field 4 or 8 bytes a record,
  an integer field the bits of its range a record, bit-packed, with at most libE57's padding of its
  last register. A count larger than the data would make libE57 leave the rest of its buffer as it
  was (uninitialised memory, measured), a count of 10^8 would allocate gigabytes first, a smaller one
  drops the last points without a word;
- the pose, read by element name (``rotation`` ``w x y z``, ``translation`` ``x y z``; libE57 gives
  them by position, so ``<x/><y/><z/><w>`` read as a half turn) and applied here; it must be finite
  numbers (``NaN`` and ``INF``, which libE57 reads as 0, are refused), a unit quaternion;
- a ScaledInteger field's scale and offset: finite, the scale not 0.

Then libE57 reads the points (``transform`` off) in blocks of :data:`_READ_BLOCK` records, and the
number it gives back must be ``recordCount``. Also refused, never measured: a file without the
``ASTM-E57`` signature, any error of libE57, a file without scans, a scan index out of range, a scan
without cartesian or spherical coordinates, a pose or coordinate given as a String. Points flagged
invalid (``cartesianInvalidState`` or ``sphericalInvalidState`` not 0) are dropped and counted like
NaN rows.

``pye57`` is imported only here, and only when an E57 file is read: a missing extra gives the one
line ``reading .e57 needs the optional extra: pip install 'holecli[e57]'``.
"""

from __future__ import annotations

import math
import os
import re
import struct
import xml.parsers.expat
from dataclasses import dataclass, field
from typing import Optional

import numpy as np

from holecli.io._common import _BadFile, _need_extra

# The first bytes of every E57 file (its physical header: "ASTM-E57", then the version and sizes).
E57_SIGNATURE = b"ASTM-E57"

# E57 coordinates are in metres (ASTM E2807, section 8.4.2).
E57_UNITS = "m"

# How far a pose's quaternion may be from unit length (writers store it in single or double
# precision; a damaged one is far off).
_UNIT_QUATERNION_TOLERANCE = 1e-3

# The physical header: signature, major and minor version, the file's physical length, the XML
# section's physical offset and logical length, the page size (ASTM E2807, section 9.2).
_FILE_HEADER = struct.Struct("<8sIIQQQQ")
# Every page: 1020 bytes of data, then their CRC-32C (big-endian). The only page size E57 1.0 uses.
_PAGE = 1024
_PAGE_DATA = 1020

# The XML section: E57 documents nest fewer than 20 elements deep (root, data3D, a scan, points,
# prototype, a field: 6); xerces recurses once per level and crashes on 200,000.
_MAX_XML_DEPTH = 64
# A scan takes some 60 elements, an image a dozen: a million is far beyond any scanner's file.
_MAX_XML_ELEMENTS = 1_000_000
_MAX_XML_BYTES = 128 << 20

# A CompressedVector's binary section: its header (section id 1, 7 reserved bytes, the section's
# logical length, the physical offsets of its first data and index packet).
_SECTION_HEADER = struct.Struct("<B7sQQQ")
_COMPRESSED_VECTOR_SECTION = 1
# A packet: type, flags, logical length - 1; a data packet then the number of bytestreams and the
# length of each stream's buffer in it (uint16 each).
_PACKET_HEADER = struct.Struct("<BBH")
_DATA_PACKET_HEADER = struct.Struct("<BBHH")
_INDEX_PACKET, _DATA_PACKET, _EMPTY_PACKET = 0, 1, 2

# libE57 reads the points into buffers of this many records, copied into the arrays of the scan.
_READ_BLOCK = 1 << 16

_INT64_MIN, _INT64_MAX = -(1 << 63), (1 << 63) - 1
_INTEGER_TEXT = re.compile(r"[+-]?[0-9]+")
_CARTESIAN = ("cartesianX", "cartesianY", "cartesianZ")
_SPHERICAL = ("sphericalRange", "sphericalAzimuth", "sphericalElevation")


def read_e57(name: str, data_head: bytes, scan=None):
    """The points of an E57 file: every scan transformed by its pose, or the one scan asked for.

    Parameters
    ----------
    name : str
        The file (libE57 reads it itself, after the checks here).
    data_head : bytes
        Its first bytes (at least 8, when the file is that long), to check the signature before
        anything else reads the file.
    scan : int or None
        The index of the scan to read, from 0; None for every scan, merged.

    Returns
    -------
    points : (n, 3) float64 ndarray
        The points that are not flagged invalid, in the file's common frame (metres), scan after
        scan; NaN coordinates are left in for the caller to drop and count.
    flagged : int
        Points left out because their scan flags them invalid.

    Raises
    ------
    _BadFile
        For a file that is not E57, a damaged one, one whose counts or offsets the data does not
        bear out, a bad pose, no scans, ``scan`` out of range, or pye57 missing.
    """
    if not data_head.startswith(E57_SIGNATURE):
        raise _BadFile("not an E57 file (it does not start with the signature 'ASTM-E57')")
    try:
        import pye57
        from pye57 import libe57
    except ImportError:
        raise _need_extra(".e57") from None
    count, chosen = _check_structure(name, scan)
    try:
        with pye57.E57(name) as e57:
            if e57.scan_count != count:  # libE57 read another document than the one checked
                raise _BadFile(f"damaged or unreadable E57 file (libE57 finds {e57.scan_count} scans, "
                               f"its XML {count})")
            parts, flagged = [], 0
            for layout in chosen:
                points, invalid = _read_scan(e57, libe57, layout)
                parts.append(points)
                flagged += invalid
    except libe57.E57Exception as exc:
        raise _BadFile(f"damaged or unreadable E57 file ({_e57_problem(exc)})") from None
    points = np.concatenate(parts) if parts else np.empty((0, 3))
    return np.ascontiguousarray(points, dtype=np.float64), flagged


# --- the file's structure --------------------------------------------------------------------


@dataclass
class _Field:
    """A terminal field of a points prototype, in bytestream order."""

    name: str  # its path below the prototype ("cartesianX", "nor:normalX")
    kind: str  # "Float", "Integer", "ScaledInteger" or "String"
    bits: Optional[int]  # bits per record; None for a String (variable)
    register: int = 0  # bytes of the bit-packing register (Integer, ScaledInteger with bits > 0)


@dataclass
class _Scan:
    """What the XML says of one scan, checked: where its points are and how to place them."""

    index: int
    record_count: int
    fields: list
    coordinates: tuple  # _CARTESIAN or _SPHERICAL
    invalid_state: Optional[str]  # the invalid-state field read with the coordinates, if present
    rotation: Optional[np.ndarray] = None  # w, x, y, z (unit); None: no pose
    translation: Optional[np.ndarray] = None


@dataclass
class _Element:
    """An element of the XML section: its name, attributes, text and children, in document order."""

    name: str
    attributes: dict
    text: list = field(default_factory=list)
    children: list = field(default_factory=list)

    @property
    def type(self) -> str:
        return self.attributes.get("type", "")

    def child(self, name: str):
        return next((child for child in self.children if child.name == name), None)

    def value(self) -> str:
        return "".join(self.text).strip()


class _Pages:
    """Logical reads of an E57 file: 1020 data bytes of every 1024-byte page, each page's CRC checked."""

    def __init__(self, stream, physical_length: int):
        self.stream = stream
        self.pages = physical_length // _PAGE
        self.logical_length = self.pages * _PAGE_DATA
        self.checked = set()

    def read(self, offset: int, count: int, what: str) -> bytes:
        """``count`` logical bytes from ``offset``; refused when they are not in the file."""
        if offset < 0 or count < 0 or offset + count > self.logical_length:
            raise _BadFile(f"damaged E57 file ({what} lies beyond the end of the file)")
        if count == 0:
            return b""
        first, last = offset // _PAGE_DATA, (offset + count - 1) // _PAGE_DATA
        self.stream.seek(first * _PAGE)
        raw = self.stream.read((last - first + 1) * _PAGE)
        if len(raw) != (last - first + 1) * _PAGE:
            raise _BadFile("damaged E57 file (shorter than its header says)")
        pages = [raw[i * _PAGE: i * _PAGE + _PAGE_DATA] for i in range(last - first + 1)]
        for i, page in enumerate(pages):
            number = first + i
            if number not in self.checked:
                stored = int.from_bytes(raw[i * _PAGE + _PAGE_DATA: (i + 1) * _PAGE], "big")
                if _crc32c(page) != stored:
                    raise _BadFile(f"damaged E57 file (checksum mismatch in page {number})")
                self.checked.add(number)
        data = b"".join(pages)
        start = offset - first * _PAGE_DATA
        return data[start: start + count]

    def logical(self, physical: int, what: str) -> int:
        """The logical offset of a physical one; refused inside a page's CRC or beyond the file."""
        page, within = divmod(physical, _PAGE)
        if within >= _PAGE_DATA or page >= self.pages:
            raise _BadFile(f"damaged E57 file ({what} {physical} is not a data byte of the file)")
        return page * _PAGE_DATA + within


def _check_structure(name: str, scan):
    """The number of scans of the file, and the scans to read (``scan``, or all) as its XML describes
    them, every count and offset checked against the sections that hold the data (the module
    docstring lists the checks)."""
    try:
        with open(name, "rb") as stream:
            size = os.fstat(stream.fileno()).st_size
            head = stream.read(_FILE_HEADER.size)
            if len(head) < _FILE_HEADER.size:
                raise _BadFile("damaged E57 file (shorter than its 48-byte header)")
            _, major, _, physical_length, xml_offset, xml_length, page_size = _FILE_HEADER.unpack(head)
            if page_size != _PAGE:
                raise _BadFile(f"unsupported E57 file (page size {page_size}, not {_PAGE})")
            if major != 1:
                raise _BadFile(f"unsupported E57 file (version {major}, not 1)")
            if physical_length != size or size % _PAGE:
                raise _BadFile(f"damaged E57 file (its header gives {physical_length} bytes, "
                               f"the file has {size})")
            pages = _Pages(stream, size)
            if xml_length > _MAX_XML_BYTES:
                raise _BadFile(f"unsupported E57 file (its XML section is {xml_length} bytes, "
                               f"more than {_MAX_XML_BYTES >> 20} MiB)")
            xml_start = pages.logical(xml_offset, "the XML section's offset")
            nodes = _scan_nodes(_parse_xml(pages.read(xml_start, xml_length, "the XML section")))
            if not nodes:
                raise _BadFile("no scans in the E57 file (its data3D is empty)")
            if scan is not None and not 0 <= scan < len(nodes):
                raise _BadFile(out_of_range(scan, len(nodes)))
            indices = range(len(nodes)) if scan is None else [scan]
            return len(nodes), [_scan(index, nodes[index], pages) for index in indices]
    except OSError as exc:
        raise _BadFile(f"cannot read the E57 file ({exc.strerror or exc})") from None


def _parse_xml(text: bytes) -> _Element:
    """The XML section as a tree of :class:`_Element`; refused nested deeper than
    :data:`_MAX_XML_DEPTH`, with more than :data:`_MAX_XML_ELEMENTS` elements, with a DOCTYPE, or
    not well-formed."""
    parser = xml.parsers.expat.ParserCreate()
    stack, count = [], [0]
    root = []

    def start(tag, attributes):
        if len(stack) >= _MAX_XML_DEPTH:
            raise _BadFile(f"unsupported E57 file (its XML nests deeper than {_MAX_XML_DEPTH} elements)")
        count[0] += 1
        if count[0] > _MAX_XML_ELEMENTS:
            raise _BadFile(f"unsupported E57 file (its XML has more than {_MAX_XML_ELEMENTS:,} elements)")
        element = _Element(tag, attributes)
        (stack[-1].children if stack else root).append(element)
        stack.append(element)

    def end(tag):
        stack.pop()

    def characters(data):
        if stack:
            stack[-1].text.append(data)

    def doctype(*args):
        raise _BadFile("unsupported E57 file (its XML has a DOCTYPE)")

    parser.StartElementHandler, parser.EndElementHandler = start, end
    parser.CharacterDataHandler, parser.StartDoctypeDeclHandler = characters, doctype
    try:
        parser.Parse(text, True)
    except xml.parsers.expat.ExpatError as exc:
        raise _BadFile(f"damaged E57 file (its XML is not well-formed: "
                       f"{xml.parsers.expat.ErrorString(exc.code)}, line {exc.lineno})") from None
    return root[0]


def _scan_nodes(root: _Element) -> list:
    """The scans (children of ``data3D``) of the XML."""
    data3d = root.child("data3D")
    if data3d is None:
        return []
    if data3d.type != "Vector":
        raise _BadFile(f"damaged E57 file (its data3D is a {data3d.type or 'untyped element'}, not a Vector)")
    return data3d.children


def _scan(index: int, node: _Element, pages: _Pages) -> _Scan:
    where = f"scan {index}"
    points = node.child("points")
    if points is None:
        raise _BadFile(f"{where}: no points in the E57 scan")
    if points.type != "CompressedVector":
        raise _BadFile(f"{where}: its points are a {points.type or 'untyped element'}, not a CompressedVector")
    record_count = _count_attribute(points, "recordCount", where)
    prototype = points.child("prototype")
    if prototype is None or prototype.type != "Structure":
        raise _BadFile(f"{where}: its points have no prototype Structure")
    codecs = points.child("codecs")
    if codecs is not None and codecs.children:
        raise _BadFile(f"{where}: its points use a codec other than bit-packing")
    fields = []
    _terminals(prototype, "", fields, where)
    names = {child.name for child in prototype.children}
    if all(axis in names for axis in _CARTESIAN):
        coordinates, state = _CARTESIAN, "cartesianInvalidState"
    elif all(axis in names for axis in _SPHERICAL):
        coordinates, state = _SPHERICAL, "sphericalInvalidState"
    else:
        raise _BadFile(f"{where}: no cartesian or spherical coordinates in its points")
    kinds = {item.name: item.kind for item in fields}
    for axis in coordinates:
        if kinds.get(axis) not in ("Float", "Integer", "ScaledInteger"):
            raise _BadFile(f"{where}: its {axis} is a {kinds.get(axis) or 'Structure'}, not a number")
    if state in kinds and kinds[state] not in ("Integer", "ScaledInteger"):
        raise _BadFile(f"{where}: its {state} is a {kinds[state]}, not an Integer")
    layout = _Scan(index, record_count, fields, coordinates, state if state in kinds else None)
    pose = node.child("pose")
    if pose is not None:
        layout.rotation, layout.translation = _pose(pose, where)
    offset = _count_attribute(points, "fileOffset", where)
    if record_count or offset:  # (libE57 writes no section, offset 0, for a scan without points)
        _check_binary_section(pages, offset, layout, where)
    return layout


def _count_attribute(node: _Element, name: str, where: str) -> int:
    text = node.attributes.get(name, "").strip()
    if not _INTEGER_TEXT.fullmatch(text) or not 0 <= int(text) <= _INT64_MAX:
        raise _BadFile(f"{where}: its points' {name} is not a count ({text[:40]!r})")
    return int(text)


def _terminals(node: _Element, prefix: str, fields: list, where: str):
    """The terminal fields below ``node`` in depth-first document order, the order of the
    bytestreams in every data packet (libE57 ``findTerminalPosition``)."""
    for child in node.children:
        path = prefix + child.name
        kind = child.type
        if kind in ("Structure", "Vector"):
            _terminals(child, path + "/", fields, where)
        elif kind == "Float":
            precision = child.attributes.get("precision", "double")
            if precision not in ("single", "double"):
                raise _BadFile(f"{where}: field {path} has precision {precision[:20]!r}")
            fields.append(_Field(path, kind, 32 if precision == "single" else 64))
        elif kind in ("Integer", "ScaledInteger"):
            low = _int64_attribute(child, "minimum", _INT64_MIN, path, where)
            high = _int64_attribute(child, "maximum", _INT64_MAX, path, where)
            if low > high:
                raise _BadFile(f"{where}: field {path} has minimum {low} above its maximum {high}")
            if kind == "ScaledInteger":
                for name, default in (("scale", 1.0), ("offset", 0.0)):
                    value = _float_text(child.attributes.get(name), default)
                    if value is None or not math.isfinite(value) or (name == "scale" and value == 0):
                        shown = child.attributes.get(name, "")[:20]
                        raise _BadFile(f"{where}: field {path} has {name} {shown!r}, not a finite "
                                       f"{'non-zero ' if name == 'scale' else ''}number")
            bits = (high - low).bit_length()
            register = next(size for size in (1, 2, 4, 8) if bits <= 8 * size)
            fields.append(_Field(path, kind, bits, register))
        elif kind == "String":
            fields.append(_Field(path, kind, None))
        else:
            raise _BadFile(f"{where}: field {path} of its points is a {kind or 'untyped element'}")


def _int64_attribute(node: _Element, name: str, default: int, path: str, where: str) -> int:
    text = node.attributes.get(name)
    if text is None:
        return default
    if not _INTEGER_TEXT.fullmatch(text.strip()) or not _INT64_MIN <= int(text) <= _INT64_MAX:
        raise _BadFile(f"{where}: field {path} has {name} {text[:20]!r}, not a 64-bit integer")
    return int(text)


def _float_text(text: Optional[str], default: float) -> Optional[float]:
    """A number of the XML (empty: ``default``, as E57 says); None when it is not a number."""
    if text is None or not text.strip():
        return default
    try:
        return float(text)
    except ValueError:
        return None


def _pose(pose: _Element, where: str):
    """The pose's rotation (w, x, y, z, normalised) and translation (x, y, z), read by name."""
    if pose.type != "Structure":
        raise _BadFile(f"{where}: the pose is a {pose.type or 'untyped element'}, not a Structure")
    values = {}
    for part, names, default in (("rotation", "wxyz", (1.0, 0.0, 0.0, 0.0)), ("translation", "xyz", (0.0,) * 3)):
        node = pose.child(part)
        if node is None:
            values[part] = np.array(default)  # as pye57: no rotation is none, no translation is 0
            continue
        if node.type != "Structure":
            raise _BadFile(f"{where}: the pose's {part} is a {node.type or 'untyped element'}, not a Structure")
        numbers = []
        for axis in names:
            child = node.child(axis)
            if child is None:
                raise _BadFile(f"{where}: the pose's {part} has no {axis}")
            if child.type not in ("Float", "Integer", "ScaledInteger"):
                raise _BadFile(f"{where}: the pose's {part} {axis} is a {child.type or 'untyped element'}, "
                               f"not a number")
            value = _float_text(child.value(), 0.0)
            if child.type == "ScaledInteger" and value is not None:
                scale = _float_text(child.attributes.get("scale"), 1.0)
                offset = _float_text(child.attributes.get("offset"), 0.0)
                value = None if scale is None or offset is None else value * scale + offset
            if value is None or not math.isfinite(value):
                raise _BadFile(f"{where}: the pose's {part} {axis} is {child.value()[:20]!r}, "
                               f"not a finite number")
            numbers.append(value)
        values[part] = np.array(numbers, dtype=np.float64)
    rotation = values["rotation"]
    norm = float(np.sqrt(np.sum(rotation * rotation)))
    if not abs(norm - 1.0) <= _UNIT_QUATERNION_TOLERANCE:
        raise _BadFile(f"{where}: the pose's rotation is not a unit quaternion "
                       f"({', '.join(f'{value:g}' for value in rotation)})")
    return rotation / norm, values["translation"]


def _check_binary_section(pages: _Pages, physical: int, layout: _Scan, where: str):
    """Walk the points' binary section and check that each bytestream holds exactly the records."""
    start = pages.logical(physical, f"{where}: its points' fileOffset")
    head = pages.read(start, _SECTION_HEADER.size, f"{where}: its points' section header")
    section_id, reserved, length, data_physical, _ = _SECTION_HEADER.unpack(head)
    if section_id != _COMPRESSED_VECTOR_SECTION or reserved.strip(b"\0") or length % 4:
        raise _BadFile(f"damaged E57 file ({where}: its points' fileOffset {physical} is not a "
                       f"CompressedVector section)")
    end = start + length
    if length < _SECTION_HEADER.size or end > pages.logical_length:
        raise _BadFile(f"damaged E57 file ({where}: its points' section of {length} bytes runs past the file)")
    offset = pages.logical(data_physical, f"{where}: its data packets' offset")
    if not start + _SECTION_HEADER.size <= offset < end:
        raise _BadFile(f"damaged E57 file ({where}: its data packets' offset is outside its section)")
    streams = len(layout.fields)
    stream_bytes = [0] * streams
    first = offset
    while offset < end:
        kind, _, length_minus_1 = _PACKET_HEADER.unpack(pages.read(offset, 4, f"{where}: a packet"))
        size = length_minus_1 + 1
        if offset + size > end:
            raise _BadFile(f"damaged E57 file ({where}: a packet of {size} bytes runs past its section)")
        if kind == _DATA_PACKET:
            if size < _DATA_PACKET_HEADER.size or size % 4:
                raise _BadFile(f"damaged E57 file ({where}: a data packet of {size} bytes)")
            count = _DATA_PACKET_HEADER.unpack(pages.read(offset, 6, f"{where}: a packet"))[3]
            if count not in (0, streams):
                raise _BadFile(f"damaged E57 file ({where}: a data packet holds {count} bytestreams, "
                               f"its prototype {streams} fields)")
            lengths = struct.unpack(f"<{count}H", pages.read(offset + 6, 2 * count, f"{where}: a packet"))
            needed = 6 + 2 * count + sum(lengths)
            if not needed <= size <= needed + 3:
                raise _BadFile(f"damaged E57 file ({where}: a data packet of {size} bytes holds "
                               f"{needed} bytes)")
            for number, value in enumerate(lengths):
                stream_bytes[number] += value
        elif kind in (_INDEX_PACKET, _EMPTY_PACKET):
            if size < 4:
                raise _BadFile(f"damaged E57 file ({where}: a packet of {size} bytes)")
        else:
            raise _BadFile(f"damaged E57 file ({where}: a packet of unknown type {kind})")
        if offset == first and kind != _DATA_PACKET:
            raise _BadFile(f"damaged E57 file ({where}: its first packet is not a data packet)")
        offset += size
    if layout.record_count and not any(item.bits for item in layout.fields):
        raise _BadFile(f"{where}: its points carry no data (every field is constant), "
                       f"so their count {layout.record_count} cannot be checked")
    for item, held in zip(layout.fields, stream_bytes):
        _check_stream(item, held, layout.record_count, where)


def _check_stream(item: _Field, held: int, records: int, where: str):
    """Refuse a bytestream that does not hold exactly ``records`` records of ``item``.

    A float field takes 4 or 8 bytes a record, exactly. An integer field takes ``bits`` bits a
    record, packed without gaps across the packets (libE57's BitpackEncoder and decoder); the writer
    pads the stream once, at its end, to a whole register of 1, 2, 4 or 8 bytes (the smallest that
    holds ``bits``): so at least ceil(records * bits / 8) bytes and at most that rounded up to the
    register. A constant field (``bits`` 0) has no bytes; a String field is not checked.
    """
    if item.bits is None:
        return
    if item.kind == "Float":
        low = high = records * item.bits // 8
    elif item.bits == 0:
        low = high = 0
    else:
        total_bits = records * item.bits
        low = -(-total_bits // 8)
        register_bits = 8 * item.register
        high = -(-total_bits // register_bits) * item.register
    if low <= held <= high:
        return
    fit = held * 8 // item.bits if item.bits else 0
    if held < low:
        problem = f"its {records} points announced, the data holds {fit}"
    else:
        problem = f"its data holds {fit if item.bits else held} points' worth, {records} announced"
    raise _BadFile(f"damaged E57 file ({where}: {problem} ({item.name}: {held} bytes, "
                   f"{item.bits} bits a point))")


# --- reading the points ----------------------------------------------------------------------


def _read_scan(e57, libe57, layout: _Scan):
    """The points of one scan in the file's frame, and how many were flagged invalid."""
    total = layout.record_count
    if total == 0:
        return np.empty((0, 3)), 0
    names = list(layout.coordinates) + ([layout.invalid_state] if layout.invalid_state else [])
    node = e57.data3d[layout.index]["points"]
    if node.childCount() != total:  # libE57 read another count than the one checked
        raise _BadFile(f"scan {layout.index}: libE57 reads {node.childCount()} points, its XML {total}")
    # The invalid state as "q" (long long): pye57 takes numpy's "l" for 32 bits and fills an int64
    # array of that code every other half (the 2 of record 0 lands in record 1's high word).
    columns = {name: np.empty(total, dtype=np.dtype("q") if name == layout.invalid_state else np.float64)
               for name in names}
    block = min(_READ_BLOCK, total)
    buffers_of = {name: np.empty(block, dtype=columns[name].dtype) for name in names}
    buffers = libe57.VectorSourceDestBuffer()
    for name in names:
        buffers.append(libe57.SourceDestBuffer(e57.image_file, name, buffers_of[name], block, True, True))
    reader = node.reader(buffers)
    done = 0
    try:
        while True:
            count = reader.read()
            if count == 0:
                break
            if done + count > total:
                raise _BadFile(f"scan {layout.index}: libE57 reads more than its {total} points")
            for name in names:
                columns[name][done: done + count] = buffers_of[name][:count]
            done += count
    finally:
        reader.close()
    if done != total:
        raise _BadFile(f"scan {layout.index}: libE57 reads {done} of its {total} points")
    xyz = np.column_stack([columns[name] for name in layout.coordinates])
    if layout.coordinates is _SPHERICAL:
        xyz = _cartesian(xyz)
    if layout.rotation is not None:
        xyz = xyz @ _rotation_matrix(layout.rotation).T + layout.translation
    if layout.invalid_state:
        keep = columns[layout.invalid_state] == 0
        return xyz[keep], int(total - np.count_nonzero(keep))
    return xyz, 0


def _cartesian(rae):
    """Range, azimuth, elevation (radians) to x, y, z (ASTM E2807, section 8.4.7)."""
    distance, azimuth, elevation = rae[:, 0], rae[:, 1], rae[:, 2]
    flat = distance * np.cos(elevation)
    return np.column_stack([flat * np.cos(azimuth), flat * np.sin(azimuth), distance * np.sin(elevation)])


def _rotation_matrix(quaternion):
    """The rotation of a unit quaternion w, x, y, z."""
    w, x, y, z = quaternion
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ])


# --- CRC-32C (Castagnoli), the checksum of every E57 page --------------------------------------


def _crc_table():
    table = []
    for byte in range(256):
        crc = byte
        for _ in range(8):
            crc = (crc >> 1) ^ 0x82F63B78 if crc & 1 else crc >> 1
        table.append(crc)
    return tuple(table)


_CRC_TABLE = _crc_table()


def _crc32c(data: bytes) -> int:
    """The CRC-32C of ``data`` (as E57 stores it for each page, read big-endian)."""
    crc, table = 0xFFFFFFFF, _CRC_TABLE
    for byte in data:
        crc = table[(crc ^ byte) & 0xFF] ^ (crc >> 8)
    return crc ^ 0xFFFFFFFF


# --- messages ----------------------------------------------------------------------------------


def out_of_range(scan, count):
    """The message for scan ``scan`` of a file of ``count`` scans (``count`` >= 1)."""
    scans = "1 scan (scan 0)" if count == 1 else f"{count} scans (0 to {count - 1})"
    return f"scan {scan} is out of range: the file has {scans}"


def _e57_problem(exc) -> str:
    """libE57's message without its debug lines: ``checksum mismatch, file is corrupted``."""
    first = (str(exc).strip().splitlines() or [type(exc).__name__])[0]
    # "size in file header not same as actual (ErrorBadFileLength)": the code adds nothing for a user
    if first.endswith(")") and " (Error" in first:
        first = first[: first.rindex(" (Error")]
    return first.strip().rstrip(".") or type(exc).__name__
