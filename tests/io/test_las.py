"""LAS and LAZ headers that lie, files that crashed or hung the backend, and the real files of laspy and PDAL.

Issue 23: laspy believes the header. A LAS 1.4 point count one too high read an extended VLR's
bytes as a point, one too low (or the point offset moved by a byte) was measured, a LAZ whose count
was lowered gave a prefix of its points; a garbage VLR count looped for ever, a LASzip 1.x file made
lazrs panic, a flipped byte of the chunk table's offset or of the chunk size made lazrs allocate
tens of GB and abort the process. Each case is refused here in one line. The cases that killed or
hung the process without the checks are read in a child process (:func:`_read_isolated`), so that
a crash or a hang fails the test instead of pytest.

The real files (``tests/data/las/``, see its README) are each read to the points laspy reads, or
refused in one line.
"""

import io
import os
import struct
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from holecli.errors import LoadError
from holecli.io import read_cloud

laspy = pytest.importorskip("laspy")

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "tests" / "data" / "las"

# Fields of the public header block (LAS 1.0 to 1.4).
POINT_OFFSET = 96
VLR_COUNT = 100
LEGACY_COUNT = 107
LEGACY_BY_RETURN = 111  # 5 x u32
EVLR_START = 235  # 1.4: u64, then the EVLR count u32, then the point count u64
EVLR_COUNT = 243
COUNT_14 = 247
BY_RETURN_14 = 255  # 15 x u64
MAX_X = 179  # max x, min x, max y, min y, max z, min z (f64)


def _points(n, seed=0):
    return np.random.default_rng(seed).uniform(0.0, 10.0, size=(n, 3))


def write_las(path, n=60, version="1.4", point_format=6, evlr=True, vlr=False, seed=0):
    """A LAS or LAZ file (by the extension) of ``n`` random points on 0.001 steps; with an extended VLR
    after the points (1.4) and a VLR before them when asked."""
    header = laspy.LasHeader(point_format=point_format, version=version)
    header.scales, header.offsets = [0.001] * 3, [0.0] * 3
    las = laspy.LasData(header)
    las.x, las.y, las.z = _points(n, seed).T
    las.return_number[:], las.number_of_returns[:] = 1, 1  # the points by return say n
    if vlr:
        las.vlrs.append(laspy.VLR(user_id="holecli", record_id=1, description="before", record_data=b"V" * 40))
    if evlr and version == "1.4":
        from laspy.vlrs.vlrlist import VLRList

        las.evlrs = VLRList([laspy.VLR(user_id="holecli", record_id=7, description="after", record_data=b"E" * 100)])
    las.write(str(path))
    return path


def _edited(path, *edits):
    """A copy of the file (``edited.<ext>`` beside it) with (offset, format, value) written in."""
    data = bytearray(path.read_bytes())
    for offset, fmt, value in edits:
        struct.pack_into(fmt, data, offset, value)
    out = path.with_name("edited" + path.suffix)
    out.write_bytes(bytes(data))
    return out


def _count_edits(path, count):
    """Edits that make every point count of the header ``count``, and its points by return "not given"
    (all 0): a consistent lie, which only the sections (or the bounds) can show."""
    data = path.read_bytes()
    edits = [(LEGACY_BY_RETURN + 4 * i, "<I", 0) for i in range(5)]
    if data[25] >= 4:
        edits += [(COUNT_14, "<Q", count)] + [(BY_RETURN_14 + 8 * i, "<Q", 0) for i in range(15)]
        if struct.unpack_from("<I", data, LEGACY_COUNT)[0]:
            edits.append((LEGACY_COUNT, "<I", count))
    else:
        edits.append((LEGACY_COUNT, "<I", count))
    return edits


def _count(path):
    data = path.read_bytes()
    return struct.unpack_from("<Q", data, COUNT_14)[0] if data[25] >= 4 else struct.unpack_from("<I", data, LEGACY_COUNT)[0]


def _refused(path, match):
    with pytest.raises(LoadError) as error:
        read_cloud(path)
    message = str(error.value)
    assert message.startswith(f"{path}: ") and "\n" not in message
    assert match in message, message
    return message


_CHILD = """
import resource, sys
resource.setrlimit(resource.RLIMIT_AS, (2 << 30, 2 << 30))
from holecli.errors import LoadError
from holecli.io import read_cloud
try:
    cloud = read_cloud(sys.argv[1])
except LoadError as error:
    print("refused:", error.problem)
else:
    print("points:", len(cloud.points))
"""


def _read_isolated(path, timeout=40):
    """read_cloud in a child process with 2 GiB of address space: its one line of stdout ("refused: ..." or
    "points: N"). A crash, a traceback or a hang fails the test."""
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    try:
        run = subprocess.run([sys.executable, "-c", _CHILD, str(path)], capture_output=True, text=True,
                             timeout=timeout, env=env)
    except subprocess.TimeoutExpired:
        pytest.fail(f"reading {path.name} did not end within {timeout} s")
    assert run.returncode == 0 and not run.stderr.strip(), (run.returncode, run.stderr[-2000:])
    return run.stdout.strip()


# --- 1. points that are not in the file ------------------------------------------------------------


@pytest.fixture
def las14(tmp_path):
    return write_las(tmp_path / "evlr.las", 60, "1.4", 6, evlr=True)


def test_las14_with_evlrs_reads_its_points(las14):
    np.testing.assert_allclose(read_cloud(las14).points, _points(60), atol=0.0005 + 1e-12)


@pytest.mark.parametrize("change", [+1, -1, +2, -30])
def test_las14_count_that_is_not_the_points_before_the_evlrs_is_refused(las14, change):
    # +1 read the extended VLR's first bytes as a point; -1 measured 59 of the 60 points.
    path = _edited(las14, *_count_edits(las14, 60 + change))
    _refused(path, "the extended VLRs start at byte")


@pytest.mark.parametrize("shift", [+1, -1, +20])
def test_point_offset_moved_is_refused(tmp_path, shift):
    for version, point_format in (("1.4", 6), ("1.2", 3)):
        path = write_las(tmp_path / f"offset{version}.las", 60, version, point_format, vlr=True)
        offset = struct.unpack_from("<I", path.read_bytes(), POINT_OFFSET)[0]
        with pytest.raises(LoadError) as error:
            read_cloud(_edited(path, (POINT_OFFSET, "<I", offset + shift)))
        assert "\n" not in str(error.value)


def test_count_of_an_uncompressed_file_without_evlrs_must_fill_the_file(tmp_path):
    path = write_las(tmp_path / "plain.las", 60, "1.2", 3)
    _refused(_edited(path, *_count_edits(path, 59)), "bytes after the 59 points")
    _refused(_edited(path, *_count_edits(path, 61)), "the header announces 61 points but only 60 are there")


def test_legacy_count_must_agree_with_the_14_count(las14):
    _refused(_edited(las14, (LEGACY_COUNT, "<I", 59)), "the legacy point count 59 is not the point count 60")


def test_points_by_return_must_add_up_to_the_count(tmp_path):
    # Only the count edited, as a hand edit does: the points by return still say 60.
    path = write_las(tmp_path / "laz12.laz", 60, "1.2", 3)
    _refused(_edited(path, (LEGACY_COUNT, "<I", 59)), "the legacy points by return add up to 60")
    path = write_las(tmp_path / "laz14.laz", 60, "1.4", 6, evlr=False)
    _refused(_edited(path, (COUNT_14, "<Q", 59)), "the points by return add up to 60")


def test_vlr_count_beyond_the_vlrs_is_refused(tmp_path):
    path = write_las(tmp_path / "vlr.las", 60, "1.2", 3, vlr=True)
    _refused(_edited(path, (VLR_COUNT, "<I", 2)), "2 VLRs announced, but the 94 bytes between the header and the "
                                                  "point data hold 1 at most")
    _refused(_edited(path, (227 + 20, "<H", 41)), "VLR 1 of 1 (41 bytes) runs into the point data")  # its length
    message = _read_isolated(_edited(path, (VLR_COUNT, "<I", 1_000_000_000)))  # laspy looped for ever on such
    assert message.startswith("refused: malformed LAS header: 1000000000 VLRs announced"), message


def test_evlrs_outside_the_file_are_refused(las14):
    size = las14.stat().st_size
    _refused(_edited(las14, (EVLR_COUNT, "<I", 2)), "extended VLR 2 of 2 is cut short")
    _refused(_edited(las14, (EVLR_COUNT, "<I", 10**6)), "1000000 extended VLRs announced")
    _refused(_edited(las14, (EVLR_START, "<Q", size + 10)), "the extended VLRs start at byte")


def test_points_outside_the_header_bounds_are_refused(tmp_path):
    path = write_las(tmp_path / "bounds.las", 60, "1.2", 3)
    data = path.read_bytes()
    offset = struct.unpack_from("<I", data, POINT_OFFSET)[0]
    x = struct.unpack_from("<i", data, offset + 20 * 34)[0]  # point 20's X (34-byte records)
    _refused(_edited(path, (offset + 20 * 34, "<i", x + 50_000)), "outside the header's bounds")
    # Bounds all 0 are not filled in: not checked.
    unfilled = _edited(path, *[(MAX_X + 8 * i, "<d", 0.0) for i in range(6)])
    np.testing.assert_allclose(read_cloud(unfilled).points, _points(60), atol=0.0005 + 1e-12)


def test_laz_with_a_lowered_count_is_refused(tmp_path):
    # Layered (point format 6): each chunk stores its count.
    path = write_las(tmp_path / "layered.laz", 60, "1.4", 6)
    _refused(_edited(path, *_count_edits(path, 59)), "the chunks hold 60 points, the header announces 59")
    # Variable-size chunks (COPC): the chunk table's point counts.
    copc = tmp_path / "simple.copc.laz"
    copc.write_bytes((DATA / "laspy_simple.copc.laz").read_bytes())
    _refused(_edited(copc, *_count_edits(copc, 1064)), "the chunks of the chunk table hold 1065 points")
    # Fixed chunks of 50000 points (format 3): a count a chunk short.
    big = tmp_path / "chunks.laz"
    header = laspy.LasHeader(point_format=3, version="1.2")
    header.scales, header.offsets = [0.01] * 3, [0.0] * 3
    las = laspy.LasData(header)
    grid = np.arange(120_000, dtype=float)
    las.x, las.y, las.z = grid % 300, grid // 300, np.zeros_like(grid)
    las.write(str(big))
    assert len(read_cloud(big).points) == 120_000
    _refused(_edited(big, *_count_edits(big, 70_000)), "70000 points in chunks of 50000 make 2 chunks, but the "
                                                       "chunk table lists 3")


# --- 2. files that killed or hung the run ------------------------------------------------------------


def test_laszip_1x_pointwise_file_is_refused_by_its_compressor():
    message = _read_isolated(DATA / "pdal_simple-laszip-compressor-version-1.2r0.laz")
    assert message == ("refused: unsupported LAZ compressor 1 (pointwise, written by LASzip 1.x): only the chunked "
                       "compressors 2 and 3 (LASzip 2 and later) are read")


def test_a_panic_of_lazrs_is_a_one_line_refusal():
    # The panic lazrs raises on the LASzip 1.x file (a BaseException, not an Exception).
    lazrs = pytest.importorskip("lazrs")
    from holecli.io._common import _BadFile
    from holecli.io.las import _backend_error

    data = (DATA / "pdal_simple-laszip-compressor-version-1.2r0.laz").read_bytes()
    vlr = data[227 + 54 : 227 + 54 + 52]
    with pytest.raises(BaseException) as panic:
        lazrs.LasZipDecompressor(io.BytesIO(data[333:]), vlr).decompress_many(bytearray(34 * 10))
    assert type(panic.value).__name__ == "PanicException"
    refusal = _backend_error(panic.value)
    assert isinstance(refusal, _BadFile) and "\n" not in str(refusal)
    assert str(refusal).startswith("damaged LAZ point data (the LAZ backend failed: variable-size chunks")


@pytest.mark.parametrize("version, point_format", [("1.2", 3), ("1.4", 6)])
def test_laz_chunk_table_offset_damaged_is_refused(tmp_path, version, point_format):
    # One flipped byte of this offset made lazrs allocate 55.6 GB and abort the process.
    path = write_las(tmp_path / "table.laz", 60, version, point_format)
    data = path.read_bytes()
    offset = struct.unpack_from("<I", data, POINT_OFFSET)[0]
    table = struct.unpack_from("<q", data, offset)[0]
    for value in (table ^ (1 << 40), table ^ (1 << 12), table - 1, table + 1, offset + 8 + 3, 0):
        message = _read_isolated(_edited(path, (offset, "<q", value)))
        assert message.startswith("refused: malformed LAZ"), (value, message)


def test_laz_chunk_size_damaged_does_not_abort(tmp_path):
    # A flipped high byte of the chunk size made lazrs's parallel decompressor allocate 64 GB and abort.
    path = write_las(tmp_path / "size.laz", 60, "1.4", 6)
    data = path.read_bytes()
    laszip = data.index(b"laszip encoded") - 2  # the VLR header; its record follows the 54 bytes
    chunk_size = laszip + 54 + 12
    assert struct.unpack_from("<I", data, chunk_size)[0] == 50_000
    message = _read_isolated(_edited(path, (chunk_size, "<I", 50_000 + (0x80 << 24))))
    assert message in ("points: 60",) or message.startswith("refused:"), message


# --- 4. the real files of laspy and PDAL ---------------------------------------------------------------

REFUSED = {
    "laspy_simple1_3.las": "outside the header's bounds",
    "pdal_1.2-with-color-clipped.las": "truncated LAS: the header announces 1065 points but only 1064 are there",
    "pdal_bad_vlr_count.las": "VLR 3 of 3 runs into the point data",
    "pdal_garbage_nVariableLength.las": "1069128089 VLRs announced",
    "pdal_no-points.las": "no points",
    "pdal_permutations_1.2-no-points.las": "the header announces 1065 points but only 0 are there",
    "pdal_simple-laszip-compressor-version-1.2r0.laz": "unsupported LAZ compressor 1",
    "pdal_spurious.las": "outside the header's bounds",
}
# Those that hung the process or made lazrs panic without the checks: read in a child process.
ISOLATED = ("pdal_garbage_nVariableLength.las", "pdal_simple-laszip-compressor-version-1.2r0.laz")


def _real_files():
    return sorted(path.name for path in DATA.glob("*.la[sz]")) if DATA.is_dir() else []


def test_the_real_files_are_all_here():
    assert len(_real_files()) == 41 and sum((DATA / name).stat().st_size for name in _real_files()) < 3_000_000


@pytest.mark.parametrize("name", _real_files())
def test_real_file_is_read_as_laspy_reads_it_or_refused(name):
    path = DATA / name
    if name in ISOLATED:
        message = _read_isolated(path)
        assert message.startswith("refused: ") and REFUSED[name] in message, message
        return
    if name in REFUSED:
        _refused(path, REFUSED[name])
        return
    las = laspy.read(str(path))
    expected = np.column_stack([np.asarray(las.x), np.asarray(las.y), np.asarray(las.z)]).astype(np.float64)
    cloud = read_cloud(path)
    assert cloud.dropped == 0
    np.testing.assert_array_equal(cloud.points, expected)
