"""Editing E57 files by hand for the tests: their XML, a count, an offset, with every page's CRC-32C
made valid again, so that the lie reaches the reader's checks and not libE57's checksum test.

An E57 file is 1024-byte pages, each 1020 bytes of data and their CRC-32C (big-endian). libE57
writes the XML section last, so an edited XML replaces the end of the logical data; the header's
XML length and file length are updated with it.
"""

import struct

from holecli.io.e57 import _crc32c

PAGE, PAGE_DATA = 1024, 1020
HEADER = struct.Struct("<8sIIQQQQ")  # signature, major, minor, length, XML offset, XML length, page size


def logical(data: bytes) -> bytearray:
    """The logical bytes of a file: its pages without their CRCs."""
    return bytearray(b"".join(data[i: i + PAGE_DATA] for i in range(0, len(data), PAGE)))


def physical(data: bytes) -> bytes:
    """Logical bytes (padded with zeros to whole pages) as a file, every page with its CRC."""
    data = bytes(data) + b"\0" * (-len(data) % PAGE_DATA)
    pages = []
    for start in range(0, len(data), PAGE_DATA):
        page = data[start: start + PAGE_DATA]
        pages.append(page + _crc32c(page).to_bytes(4, "big"))
    return b"".join(pages)


def to_logical(offset: int) -> int:
    page, within = divmod(offset, PAGE)
    return page * PAGE_DATA + within


def to_physical(offset: int) -> int:
    page, within = divmod(offset, PAGE_DATA)
    return page * PAGE + within


def xml_of(data: bytes) -> bytes:
    _, _, _, _, xml_offset, xml_length, _ = HEADER.unpack_from(data)
    start = to_logical(xml_offset)
    return bytes(logical(data)[start: start + xml_length])


def with_xml(data: bytes, edit) -> bytes:
    """The file with its XML section replaced by ``edit(xml)`` (bytes to bytes), CRCs valid."""
    signature, major, minor, _, xml_offset, xml_length, page_size = HEADER.unpack_from(data)
    body = logical(data)
    start = to_logical(xml_offset)
    new_xml = edit(bytes(body[start: start + xml_length]))
    body = body[:start] + new_xml
    body += b"\0" * (-len(body) % PAGE_DATA)
    length = len(body) // PAGE_DATA * PAGE
    body[: HEADER.size] = HEADER.pack(signature, major, minor, length, xml_offset, len(new_xml), page_size)
    return physical(body)


def with_logical(data: bytes, offset: int, value: bytes) -> bytes:
    """The file with ``value`` written at logical ``offset``, CRCs valid."""
    body = logical(data)
    body[offset: offset + len(value)] = value
    return physical(body)


def points_section(data: bytes, scan: int = 0) -> int:
    """The logical offset of the binary section of scan ``scan``'s points (its XML fileOffset)."""
    import re

    offsets = re.findall(rb'type="CompressedVector" fileOffset="(\d+)"', xml_of(data))
    return to_logical(int(offsets[scan]))


def first_packet(data: bytes, scan: int = 0) -> int:
    """The logical offset of the first data packet of scan ``scan``'s points."""
    section = points_section(data, scan)
    data_physical = struct.unpack_from("<Q", logical(data), section + 16)[0]
    return to_logical(data_physical)
