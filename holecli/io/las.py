"""LAS and LAZ reading (ASPRS LAS 1.0 to 1.4; LAZ is LAS compressed), through the optional ``laspy``.

A LAS point stores x, y, z as 32-bit integers; the header's scales and offsets make them
coordinates (``x = X * x_scale + x_offset``), which laspy applies. LAZ needs a decompression backend
(``lazrs``, which the ``las`` extra installs, or ``laszip``).

laspy believes the header: it allocates what the counts ask for, reads the variable-length records
(VLRs) the header announces wherever they fall, and reads as points whatever bytes lie at the
point-data offset. So before laspy sees a file, this module parses the public header block itself
(:func:`_read_layout`) and checks every count and offset against the sections that hold the data:

- ``header_size``: at least the version's header (227 bytes up to LAS 1.2, 235 for 1.3, 375 for
  1.4), at most the point-data offset; the version is 1.0 to 1.4;
- the VLRs: ``number of VLRs`` records of 54 bytes each plus their lengths must fit between the
  header and the point data (a garbage count made laspy loop for ever, memory growing);
- the point counts: a LAS 1.4 file's legacy count, when not 0, must equal its 64-bit count, and the
  points by return, when given, must add up to the count;
- the extended VLRs (LAS 1.4) and the waveform data (1.3, 1.4) lie after the point data, inside the
  file;
- uncompressed points: ``offset + count * record length`` must be exactly where the next section
  starts (the first extended VLR, internal waveform data, or the end of the file): a count one too
  high would read an EVLR's bytes as a point, one too low or an offset moved by a byte would measure
  points that are not the file's;
- compressed points (LAZ): the ``laszip encoded`` VLR must name a chunked compressor (2 or 3; the
  pointwise compressor of LASzip 1.x made lazrs panic) whose items fill the record; the chunk table
  must lie inside the file after the points, with one chunk per ``chunk size`` points (fixed
  chunks) or chunk point counts adding up to the count (variable chunks), its byte counts filling
  the compressed data exactly; each chunk of the layered compressor (point formats 6 to 10) stores
  its own point count, which must add up to the header's (a flipped byte of the table offset made
  lazrs allocate 55 GB and abort the process; a lowered count returned a prefix of the points).

After reading, every point must lie within the header's bounds (min and max x, y, z; one scale step
of slack), unless those are all 0 (not filled in). That catches a header whose count or offset lies
in a way the sections above cannot show, and points that were damaged. A panic of the LAZ backend
is refused in one line, not passed on.

Also refused: a file without the ``LASF`` signature, a header laspy cannot read, scales that are 0
or not finite and offsets that are not finite. A damaged byte inside an uncompressed point that
stays within the bounds cannot be seen (LAS has no checksum), as in a binary PLY; nor can a LAZ
count of point formats 0 to 5 lowered (or raised) by less than a chunk together with its points by
return and bounds.

``laspy`` is imported only here, when a LAS or LAZ file is read: a missing extra, or LAZ without a
backend, gives the one line ``reading .las needs the optional extra: pip install 'holecli[las]'``.
"""

from __future__ import annotations

import contextlib
import io
import logging
import os
import struct
from dataclasses import dataclass
from typing import Optional

import numpy as np

from holecli.io._common import _BadFile, _describe, _need_extra

LAS_SIGNATURE = b"LASF"

# The public header block's size by version (the header may be longer: extra header bytes).
_HEADER_SIZES = {0: 227, 1: 227, 2: 227, 3: 235, 4: 375}
_VLR_HEADER = 54  # reserved u16, user id 16 bytes, record id u16, length u16, description 32 bytes
_EVLR_HEADER = 60  # the same with a u64 length
_LASZIP_USER_ID = b"laszip encoded"
_LASZIP_RECORD_ID = 22204
_LASZIP_FIXED_PART = 34  # the laszip VLR before its item list (6 bytes an item)
_VARIABLE_CHUNKS = 0xFFFFFFFF  # the chunk size that means "each chunk says its own point count"
_CHUNK_TABLE_HEADER = 8  # version u32 (0), number of chunks u32
# The compressors of the laszip VLR; lazrs reads the chunked ones only.
_COMPRESSORS = {0: "none", 1: "pointwise, written by LASzip 1.x", 2: "pointwise chunked", 3: "layered chunked"}
_CHUNKED = (2, 3)
_LAYERED = 3
# The layers of each item type of the layered compressor (POINT14, RGB14, RGBNIR14, WAVEPACKET14), and
# BYTE14, which has one layer per byte.
_LAYERS = {10: 9, 11: 1, 12: 2, 13: 1}
_BYTE14 = 14
# The smallest record of each point format 0 to 10 (laspy refuses a shorter one).
_RECORD_SIZES = (20, 28, 26, 34, 57, 63, 30, 36, 38, 59, 67)


@dataclass
class _Layout:
    """What the public header block and the VLRs say about where the data is."""

    version: int  # the minor version, 0 to 4
    header_size: int
    point_offset: int
    vlr_count: int
    compressed: bool
    point_format: int
    record_length: int
    count: int
    scales: tuple
    offsets: tuple
    mins: tuple
    maxs: tuple
    waveform_start: int
    evlr_start: int
    evlr_count: int
    file_size: int
    laszip: Optional[bytes] = None  # the laszip VLR's record

    @property
    def next_section(self) -> int:
        """Where the point data must end: the first EVLR, internal waveform data, or the file's end."""
        ends = [self.file_size]
        if self.evlr_count:
            ends.append(self.evlr_start)
        if self.waveform_start:
            ends.append(self.waveform_start)
        return min(ends)


def read_las(name: str, data_head: bytes) -> np.ndarray:
    """The points of a LAS or LAZ file, scaled and offset into coordinates.

    Parameters
    ----------
    name : str
        The file.
    data_head : bytes
        Its first bytes (at least 4, when the file is that long), to check the signature.

    Returns
    -------
    points : (n, 3) float64 ndarray
        x, y, z of every point, in file order.

    Raises
    ------
    _BadFile
        For a file that is not LAS, a damaged, truncated or inconsistent one, or laspy (or a LAZ
        backend) missing.
    """
    extension = os.path.splitext(name)[1].lower()
    if not data_head.startswith(LAS_SIGNATURE):
        raise _BadFile("not a LAS file (it does not start with the signature 'LASF')")
    try:
        import laspy
    except ImportError:
        raise _need_extra(extension) from None
    with _quiet(), open(name, "rb") as stream:
        layout = _read_layout(stream, os.fstat(stream.fileno()).st_size)
        _check_scales(layout)
        backend = None
        if layout.compressed:
            backends = laspy.LazBackend.detect_available()
            if not backends:
                raise _need_extra(extension)
            # lazrs's parallel decompressor allocates a buffer of a chunk's points first: one flipped byte of the
            # chunk size asked for 64 GB and aborted the process. The sequential one decompresses point by point.
            backend = laspy.LazBackend.Lazrs if laspy.LazBackend.Lazrs in backends else backends[0]
            _check_compressed_points(stream, layout)
        else:
            _check_uncompressed_points(layout)
        stream.seek(0)
        try:
            reader = laspy.LasReader(stream, closefd=False, laz_backend=backend)
        except laspy.errors.LaspyException as exc:
            raise _BadFile(f"malformed LAS header ({_describe(exc)})") from None
        except BaseException as exc:  # noqa: BLE001 - a panic of lazrs is a BaseException
            raise _backend_error(exc) from None
        count = int(reader.header.point_count)
        if count != layout.count:  # laspy read the same header: cannot happen, but never measure on
            raise _BadFile(f"malformed LAS header: laspy reads {count} points, the header {layout.count}")
        if count == 0:
            return np.empty((0, 3))
        try:
            points = reader.read_points(-1)
        except (laspy.errors.LaspyException, ValueError, OSError) as exc:
            raise _BadFile(f"damaged LAS point data ({_describe(exc)})") from None
        except BaseException as exc:  # noqa: BLE001 - lazrs and laszip raise errors (and panics) of their own
            raise _backend_error(exc) from None
        if len(points) != count:
            raise _BadFile(f"truncated LAS: the header announces {count} points but only {len(points)} are there")
        xyz = np.column_stack([np.asarray(points.x, dtype=np.float64), np.asarray(points.y, dtype=np.float64),
                               np.asarray(points.z, dtype=np.float64)])
    _check_bounds(xyz, layout)
    return xyz


def _backend_error(exc: BaseException) -> BaseException:
    """The one-line refusal for an error (or a Rust panic) of the LAZ backend; other exceptions as they are."""
    module = type(exc).__module__.split(".")[0]
    if type(exc).__name__ == "PanicException" or module in ("lazrs", "laszip", "pyo3_runtime"):
        return _BadFile(f"damaged LAZ point data (the LAZ backend failed: {_describe(exc)})")
    return exc


# --- the header and the VLRs -----------------------------------------------------------------------


def _read_layout(stream, size: int) -> _Layout:
    """Parse the public header block and walk the VLRs (and EVLRs), checking each against the file."""
    head = stream.read(_HEADER_SIZES[4])
    if len(head) < _HEADER_SIZES[0]:
        raise _BadFile(f"truncated LAS: {size} bytes, shorter than a LAS header ({_HEADER_SIZES[0]} bytes)")
    major, minor = head[24], head[25]
    if major != 1 or minor not in _HEADER_SIZES:
        raise _BadFile(f"unsupported LAS version {major}.{minor} (holecli reads 1.0 to 1.4)")
    header_size, point_offset, vlr_count = struct.unpack_from("<HII", head, 94)
    format_id, record_length, legacy_count = struct.unpack_from("<BHI", head, 104)
    legacy_by_return = struct.unpack_from("<5I", head, 111)
    scales = struct.unpack_from("<3d", head, 131)
    offsets = struct.unpack_from("<3d", head, 155)
    max_x, min_x, max_y, min_y, max_z, min_z = struct.unpack_from("<6d", head, 179)
    minimum = _HEADER_SIZES[minor]
    if not minimum <= header_size <= point_offset:
        raise _BadFile(f"malformed LAS header: header size {header_size} (a LAS 1.{minor} header holds "
                       f"{minimum} bytes at least, and ends before the point data at {point_offset})")
    if point_offset > size:
        raise _BadFile(f"truncated LAS: the point data starts at byte {point_offset} of a {size}-byte file")
    if len(head) < minimum:
        raise _BadFile(f"truncated LAS: {size} bytes, shorter than a LAS 1.{minor} header ({minimum} bytes)")
    compressed = bool(format_id & 0xC0)  # LASzip sets bit 7 (bit 6 in its first releases)
    point_format = format_id & 0x3F
    if point_format >= len(_RECORD_SIZES) or record_length < _RECORD_SIZES[point_format]:
        raise _BadFile(f"malformed LAS header: point format {point_format} with {record_length}-byte records")
    waveform_start = struct.unpack_from("<Q", head, 227)[0] if minor >= 3 else 0
    evlr_start, evlr_count, count = struct.unpack_from("<QIQ", head, 235) if minor >= 4 else (0, 0, legacy_count)
    if minor >= 4 and legacy_count not in (0, count):
        raise _BadFile(f"malformed LAS header: the legacy point count {legacy_count} is not the point count {count}")
    _check_by_return(legacy_by_return, legacy_count, "legacy ")
    if minor >= 4:
        _check_by_return(struct.unpack_from("<15Q", head, 255), count, "")
    layout = _Layout(minor, header_size, point_offset, vlr_count, compressed, point_format, record_length, count,
                     scales, offsets, (min_x, min_y, min_z), (max_x, max_y, max_z), waveform_start, evlr_start,
                     evlr_count, size)
    stream.seek(header_size)
    layout.laszip = _walk_vlrs(stream.read(point_offset - header_size), vlr_count)
    _check_trailing_sections(stream, layout)
    return layout


def _check_by_return(by_return, count: int, which: str) -> None:
    """The points by return, when given (not all 0), add up to the point count."""
    total = sum(by_return)
    if total and total != count:
        raise _BadFile(f"malformed LAS header: the {which}points by return add up to {total}, not to the "
                       f"{which}point count {count}")


def _walk_vlrs(block: bytes, vlr_count: int) -> Optional[bytes]:
    """Walk the VLRs between the header and the point data; return the laszip VLR's record, if any."""
    if vlr_count > len(block) // _VLR_HEADER:
        raise _BadFile(f"malformed LAS header: {vlr_count} VLRs announced, but the {len(block)} bytes between the "
                       f"header and the point data hold {len(block) // _VLR_HEADER} at most")
    position, laszip = 0, None
    for number in range(vlr_count):
        if position + _VLR_HEADER > len(block):
            raise _BadFile(f"malformed LAS header: VLR {number + 1} of {vlr_count} runs into the point data")
        user_id = block[position + 2 : position + 18].split(b"\0", 1)[0]
        record_id, length = struct.unpack_from("<HH", block, position + 18)
        start = position + _VLR_HEADER
        position = start + length
        if position > len(block):
            raise _BadFile(f"malformed LAS header: VLR {number + 1} of {vlr_count} ({length} bytes) runs into the "
                           "point data")
        if user_id == _LASZIP_USER_ID and record_id == _LASZIP_RECORD_ID:
            laszip = block[start:position]
    return laszip


def _check_trailing_sections(stream, layout: _Layout) -> None:
    """The EVLRs and the waveform data start after the point data and lie inside the file."""
    if layout.waveform_start and not layout.point_offset <= layout.waveform_start <= layout.file_size:
        raise _BadFile(f"malformed LAS header: the waveform data starts at byte {layout.waveform_start}, outside the "
                       f"{layout.point_offset} to {layout.file_size} of the point data and after")
    if not layout.evlr_count:
        return
    position = layout.evlr_start
    if not layout.point_offset <= position <= layout.file_size:
        raise _BadFile(f"malformed LAS header: the extended VLRs start at byte {position}, outside the "
                       f"{layout.point_offset} to {layout.file_size} of the point data and after")
    if layout.evlr_count > (layout.file_size - position) // _EVLR_HEADER:
        raise _BadFile(f"malformed LAS header: {layout.evlr_count} extended VLRs announced, but the "
                       f"{layout.file_size - position} bytes after byte {position} hold "
                       f"{(layout.file_size - position) // _EVLR_HEADER} at most")
    for number in range(layout.evlr_count):
        stream.seek(position)
        head = stream.read(_EVLR_HEADER)
        if len(head) < _EVLR_HEADER:
            raise _BadFile(f"truncated LAS: extended VLR {number + 1} of {layout.evlr_count} is cut short")
        position += _EVLR_HEADER + struct.unpack_from("<Q", head, 20)[0]
        if position > layout.file_size:
            raise _BadFile(f"truncated LAS: extended VLR {number + 1} of {layout.evlr_count} runs past the end of "
                           "the file")


def _check_scales(layout: _Layout) -> None:
    scales = np.asarray(layout.scales, dtype=np.float64)
    if not (np.all(np.isfinite(scales)) and np.all(scales != 0)):
        raise _BadFile(f"malformed LAS header: scales {', '.join(f'{v:g}' for v in scales)} (each must be a finite "
                       "non-zero number)")
    if not np.all(np.isfinite(layout.offsets)):
        raise _BadFile("malformed LAS header: the offsets are not finite")


# --- the points --------------------------------------------------------------------------------------


def _check_uncompressed_points(layout: _Layout) -> None:
    """The points fill the space between the point-data offset and the next section exactly."""
    count, record = layout.count, layout.record_length
    end = layout.point_offset + count * record
    available = layout.next_section - layout.point_offset
    if end > layout.file_size:
        whole = available // record
        raise _BadFile(f"truncated LAS: the header announces {count} points but only {whole} are there")
    if end == layout.next_section:
        return
    if layout.next_section == layout.file_size:
        raise _BadFile(f"malformed LAS: {layout.file_size - end} bytes after the {count} points the header "
                       "announces")
    section = "extended VLRs" if layout.evlr_count and layout.next_section == layout.evlr_start else "waveform data"
    raise _BadFile(f"malformed LAS: {count} points of {record} bytes from byte {layout.point_offset} end at byte "
                   f"{end}, but the {section} start at byte {layout.next_section}")


def _check_compressed_points(stream, layout: _Layout) -> None:
    """The laszip VLR names a compressor lazrs reads; the chunk table agrees with the count and the file."""
    if layout.laszip is None:
        raise _BadFile("malformed LAZ: the points are compressed but the file has no laszip VLR")
    vlr = layout.laszip
    if len(vlr) < _LASZIP_FIXED_PART:
        raise _BadFile(f"malformed LAZ: the laszip VLR has {len(vlr)} bytes")
    compressor, coder = struct.unpack_from("<HH", vlr, 0)
    chunk_size = struct.unpack_from("<I", vlr, 12)[0]
    item_count = struct.unpack_from("<H", vlr, 32)[0]
    if compressor not in _CHUNKED:
        name = _COMPRESSORS.get(compressor, "unknown")
        raise _BadFile(f"unsupported LAZ compressor {compressor} ({name}): only the chunked compressors 2 and 3 "
                       "(LASzip 2 and later) are read")
    if coder != 0:
        raise _BadFile(f"unsupported LAZ coder {coder} (only the arithmetic coder 0 exists)")
    if len(vlr) != _LASZIP_FIXED_PART + 6 * item_count:
        raise _BadFile(f"malformed LAZ: the laszip VLR lists {item_count} items in {len(vlr)} bytes")
    item_bytes = sum(size for _, size in _laszip_items(vlr))
    if item_bytes != layout.record_length:
        raise _BadFile(f"malformed LAZ: the laszip items make {item_bytes}-byte records, the header "
                       f"{layout.record_length}-byte ones")
    if chunk_size == 0:
        raise _BadFile("malformed LAZ: a chunk size of 0 points")
    data_start = layout.point_offset + 8  # the 8 bytes at the offset are the chunk table's offset
    section_end = layout.next_section
    stream.seek(layout.point_offset)
    raw = stream.read(8)
    if len(raw) < 8:
        raise _BadFile("truncated LAZ: the file ends at its point data")
    table_offset = struct.unpack("<q", raw)[0]
    if table_offset == -1:  # written by a streaming LASzip: the offset is the file's last 8 bytes
        stream.seek(layout.file_size - 8)
        table_offset = struct.unpack("<q", stream.read(8))[0]
        section_end = min(section_end, layout.file_size - 8)
    if not data_start <= table_offset <= section_end - _CHUNK_TABLE_HEADER:
        raise _BadFile(f"malformed LAZ: the chunk table offset {table_offset} lies outside the compressed data "
                       f"(bytes {data_start} to {section_end - _CHUNK_TABLE_HEADER})")
    stream.seek(table_offset)
    version, chunk_count = struct.unpack("<II", stream.read(_CHUNK_TABLE_HEADER))
    if version != 0:
        raise _BadFile(f"malformed LAZ: chunk table version {version} (only 0 exists)")
    compressed_bytes = table_offset - data_start
    # Each chunk starts with its first point uncompressed: no more chunks than that many records fit.
    most = compressed_bytes // layout.record_length
    if chunk_size != _VARIABLE_CHUNKS:
        needed = -(-layout.count // chunk_size)
        if chunk_count != needed:
            raise _BadFile(f"malformed LAZ: {layout.count} points in chunks of {chunk_size} make {needed} chunks, "
                           f"but the chunk table lists {chunk_count}")
    if chunk_count > most:
        raise _BadFile(f"malformed LAZ: the chunk table lists {chunk_count} chunks, but {compressed_bytes} bytes of "
                       f"compressed data hold {most} at most")
    if chunk_count == 0:
        return
    import lazrs

    stream.seek(table_offset)
    try:
        table = lazrs.read_chunk_table_only(io.BytesIO(stream.read(section_end - table_offset)), lazrs.LazVlr(vlr))
    except BaseException as exc:  # noqa: BLE001 - lazrs errors and panics
        raise _BadFile(f"malformed LAZ: unreadable chunk table ({_describe(exc)})") from None
    byte_total = sum(int(entry[1]) for entry in table)
    if byte_total != compressed_bytes:
        raise _BadFile(f"malformed LAZ: the chunks of the chunk table hold {byte_total} bytes, but the compressed "
                       f"data is {compressed_bytes} bytes")
    if chunk_size == _VARIABLE_CHUNKS:
        point_total = sum(int(entry[0]) for entry in table)
        if point_total != layout.count:
            raise _BadFile(f"malformed LAZ: the chunks of the chunk table hold {point_total} points, the header "
                           f"announces {layout.count}")
    if compressor == _LAYERED:
        _check_layered_counts(stream, layout, table, data_start)


def _check_layered_counts(stream, layout: _Layout, table, data_start: int) -> None:
    """A layered chunk holds its first point uncompressed, its point count, the size of each layer, then the
    layers: the sizes fill the chunk's bytes of the chunk table exactly, and the counts add up to the count."""
    layers = 0
    for item_type, item_size in _laszip_items(layout.laszip):
        per_item = _LAYERS.get(item_type, item_size if item_type == _BYTE14 else None)
        if per_item is None:
            raise _BadFile(f"malformed LAZ: item type {item_type} in a layered (LAS 1.4) compressed file")
        layers += per_item
    before_layers = layout.record_length + 4 + 4 * layers
    position, total = data_start, 0
    for number, entry in enumerate(table):
        chunk_bytes = int(entry[1])
        stream.seek(position + layout.record_length)
        sizes = stream.read(4 + 4 * layers)
        if chunk_bytes < before_layers or len(sizes) < 4 + 4 * layers:
            raise _BadFile(f"malformed LAZ: chunk {number + 1} of {len(table)} has {chunk_bytes} bytes, too few")
        chunk_count, *layer_sizes = struct.unpack(f"<I{layers}I", sizes)
        if before_layers + sum(layer_sizes) != chunk_bytes:
            raise _BadFile(f"malformed LAZ: the layers of chunk {number + 1} of {len(table)} hold "
                           f"{before_layers + sum(layer_sizes)} bytes, the chunk table says {chunk_bytes}")
        total += chunk_count
        position += chunk_bytes
    if total != layout.count:
        raise _BadFile(f"malformed LAZ: the chunks hold {total} points, the header announces {layout.count}")


def _laszip_items(vlr: bytes):
    """(type, size) of each item the laszip VLR lists."""
    count = struct.unpack_from("<H", vlr, 32)[0]
    return [struct.unpack_from("<HH", vlr, _LASZIP_FIXED_PART + 6 * i) for i in range(count)]


def _check_bounds(points: np.ndarray, layout: _Layout) -> None:
    """Every point lies within the header's min and max (one scale step of slack), unless those are all 0."""
    if not len(points) or not any(layout.mins + layout.maxs):
        return
    mins, maxs = np.asarray(layout.mins), np.asarray(layout.maxs)
    slack = np.abs(np.asarray(layout.scales)) + 1e-9 * np.maximum(np.abs(mins), np.abs(maxs))
    low, high = points.min(axis=0), points.max(axis=0)
    for axis, name in enumerate("xyz"):
        if not (low[axis] >= mins[axis] - slack[axis] and high[axis] <= maxs[axis] + slack[axis]):
            raise _BadFile(f"malformed LAS: the points' {name} runs from {low[axis]:.10g} to {high[axis]:.10g}, "
                           f"outside the header's bounds {mins[axis]:.10g} to {maxs[axis]:.10g}")


@contextlib.contextmanager
def _quiet():
    """laspy logs a short read as an error: with no logging set up, Python would print it on stderr.
    The reader reports the problem itself, so laspy's logger is silenced while it reads."""
    logger = logging.getLogger("laspy")  # the parent of laspy.lasreader, whose level it inherits
    level = logger.level
    logger.setLevel(logging.CRITICAL + 1)
    try:
        yield
    finally:
        logger.setLevel(level)
