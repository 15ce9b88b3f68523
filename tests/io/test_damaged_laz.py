"""Damaged LAS/LAZ files: one sentence and exit status 2, in memory and streamed, never a
crash, a runaway allocation or a library's raw message.

A flipped byte of a LAZ file's chunk size or chunk table had lazrs ask for tens of gigabytes
and abort the whole process ("memory allocation of 57044217400 bytes failed", then a core
dump); a flipped byte of its compressed points, read chunk by chunk by the stream engine,
came out as lazrs's traceback with exit status 1; a damaged count of header records had
laspy read records until memory ran out; a damaged scale printed numpy's overflow warning.
Found by the fuzz tests run at a larger scale (``GEOSTRUCTURE_FUZZ_SCALE=60`` and 150): 9
of 3,000 mutated LAZ files aborted."""

from __future__ import annotations

import struct
import subprocess
import sys
import warnings

import laspy
import numpy as np
import pytest
from helpers import UTM, assert_one_sentence, run_cli, write_laz

from geostructure.errors import GeoStructureError
from geostructure.io.failures import LASZIP_RECORD_ID, read_error
from geostructure.io.readers import read_cloud

ENGINES = ("memory", "stream")


@pytest.fixture(scope="module")
def valid(tmp_path_factory) -> bytes:
    """A LAZ file of a rough 10 x 10 m patch at UTM coordinates, as bytes."""
    rng = np.random.default_rng(0)
    points = np.c_[rng.random((3000, 2)) * 10, 0.02 * rng.random(3000)] + UTM
    path = tmp_path_factory.mktemp("valid") / "patch.laz"
    write_laz(path, points)
    return path.read_bytes()


def chunk_size_at(data: bytes, path) -> int:
    """Where the LASzip record's chunk size (a 32-bit count of points) lies in the file."""
    with laspy.open(str(path)) as reader:
        record = next(v for v in reader.header.vlrs if v.record_id == LASZIP_RECORD_ID).record_data
    return data.index(bytes(record)) + 12  # compressor, coder, version, revision, options: 12 bytes


def chunk_table_at(data: bytes, path) -> int:
    """Where the chunk table starts (its version, then its count of chunks)."""
    with laspy.open(str(path)) as reader:
        start = reader.header.offset_to_point_data
    return struct.unpack_from("<q", data, start)[0]


def measured_in_a_process(path, out, engine: str, timeout: float = 120) -> subprocess.CompletedProcess:
    """The command in a process of its own, its address space bounded to 8 GiB: an abort
    there is a status, and a runaway allocation an error, not the test machine's end. (Not
    tighter: on a machine of many cores the threads' stacks and BLAS buffers reserve
    gigabytes of address space they never touch.)"""

    def bounded() -> None:
        import resource

        resource.setrlimit(resource.RLIMIT_AS, (8 * 2**30, 8 * 2**30))

    command = [sys.executable, "-m", "geostructure", "measure", str(path), "-o", str(out), "-q", "--engine", engine]
    return subprocess.run(command, capture_output=True, text=True, timeout=timeout, preexec_fn=bounded)


@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("damage", ["chunk size", "chunk count"])
def test_a_laz_whose_chunks_cannot_be_true_is_refused_not_crashed_on(valid, tmp_path, engine, damage):
    path = tmp_path / "patch.laz"
    path.write_bytes(valid)
    data = bytearray(valid)
    if damage == "chunk size":  # its top byte: chunks of 1.7 billion points, 53 GiB each
        data[chunk_size_at(valid, path) + 3] = 100
    else:  # three billion chunks in a file of some kilobytes
        data[chunk_table_at(valid, path) + 7] = 183
    path.write_bytes(bytes(data))
    done = measured_in_a_process(path, tmp_path / "out", engine)
    assert done.returncode == 2, (done.returncode, done.stderr[-2000:])
    assert_one_sentence(done.stderr, "patch.laz", "damaged")
    assert path.read_bytes() == bytes(data) and not (tmp_path / "out").exists()


@pytest.mark.parametrize("engine", ["auto", "stream"])
def test_a_damaged_count_of_header_records_is_refused_before_laspy_reads_them(valid, tmp_path, engine):
    """A flipped byte of the header's count of variable-length records (939 million): the
    CRS check of the command's start opened the file with laspy, which read records for 50 s
    until its memory ran out (under a 3 GB bound; without one the kernel killed the process
    at 18 GB), before the reader's own check refused the header. Now it takes half a second."""
    path = tmp_path / "patch.laz"
    data = bytearray(valid)
    data[103] = 56  # the count of records: a 32-bit integer at byte 100
    path.write_bytes(bytes(data))
    done = measured_in_a_process(path, tmp_path / "out", engine, timeout=20)
    assert done.returncode == 2, (done.returncode, done.stderr[-2000:])
    assert_one_sentence(done.stderr, "patch.laz", "variable-length records")


@pytest.mark.parametrize("engine", ENGINES)
def test_a_laz_damaged_among_its_points_is_one_sentence_in_memory_and_streamed(valid, tmp_path, capsys, engine):
    """The first single byte of the compressed points whose change the decompressor cannot
    read past: a sentence from both engines (streamed, it was lazrs's traceback)."""
    path = tmp_path / "patch.laz"
    path.write_bytes(valid)
    with laspy.open(str(path)) as reader:
        first_points = reader.header.offset_to_point_data + 8  # past the chunk table's offset
    for position in range(first_points + 40, chunk_table_at(valid, path) - 8, 7):
        data = bytearray(valid)
        data[position] ^= 0x5A
        path.write_bytes(bytes(data))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                read_cloud(path)
            except GeoStructureError as exc:
                if "cannot be read as LAZ" in str(exc):
                    break
    else:
        pytest.skip("no single byte of the compressed points stops this decompressor")
    code, _, err = run_cli(capsys, "measure", path, "-o", tmp_path / "out", "-q", "--engine", engine)
    assert code == 2
    assert_one_sentence(err, "patch.laz", "cannot be read as LAZ")


def test_a_decompressor_panic_is_a_read_error():
    """lazrs's Rust panics reach Python as pyo3's PanicException, a BaseException: a chunk
    table claiming 18 exabytes gave "capacity overflow" and a traceback."""
    panic = type("PanicException", (BaseException,), {})("capacity overflow")
    error = read_error("scan.laz", panic)
    assert isinstance(error, GeoStructureError)
    assert str(error) == "scan.laz: cannot be read as LAZ (capacity overflow)."
    assert read_error("scan.laz", KeyboardInterrupt()) is None and read_error("scan.laz", SystemExit(1)) is None


def test_laz_points_are_read_by_lazrs_alone():
    """Where the LASzip bindings are installed (the tests install them to check the files
    this package writes), laspy fell back to them when lazrs refused a damaged file, and they
    crashed the process (a segmentation fault in the fuzz tests at a larger scale)."""
    from geostructure.io.failures import laz_readers

    assert set(laz_readers()) == {laspy.LazBackend.LazrsParallel, laspy.LazBackend.Lazrs}


def test_a_laz_written_to_a_stream_is_read(valid, tmp_path):
    """LASzip writing to a stream puts -1 where the chunk table's offset goes and the offset
    in the file's last 8 bytes: the check follows it there and reads the file."""
    path = tmp_path / "patch.laz"
    path.write_bytes(valid)
    table = chunk_table_at(valid, path)
    with laspy.open(str(path)) as reader:
        start = reader.header.offset_to_point_data
    data = bytearray(valid)
    struct.pack_into("<q", data, start, -1)
    path.write_bytes(bytes(data) + struct.pack("<q", table))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert len(read_cloud(path)) == 3000
    path.write_bytes(bytes(data) + struct.pack("<q", 10**12))  # the offset at its end damaged
    with pytest.raises(GeoStructureError, match="chunk table is damaged"):
        read_cloud(path)


def test_a_damaged_scale_is_one_sentence_without_numpy_s_warning(tmp_path):
    """A flipped top byte of the x scale (about 1e307) overflowed laspy's scaling to infinity
    with numpy's raw "overflow encountered in multiply" before the coordinate check refused
    the points (the fuzz tests at a larger scale). The header's check now refuses the scale
    itself, before any point is read."""
    rng = np.random.default_rng(0)
    header = laspy.LasHeader(point_format=3, version="1.2")
    header.scales, header.offsets = [0.001] * 3, [500_000, 4_600_000, 0]
    las = laspy.LasData(header)
    las.x, las.y, las.z = (rng.random((500, 3)) * [10, 10, 0.05] + [500_000, 4_600_000, 100]).T
    path = tmp_path / "scan.las"
    las.write(str(path))
    data = bytearray(path.read_bytes())
    data[131 + 7] = 0x7F  # the x scale, a double at byte 131: its sign and top exponent bits
    path.write_bytes(bytes(data))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        with pytest.raises(GeoStructureError, match="scan.las: the header is damaged: the x scale"):
            read_cloud(path)
    assert [str(w.message) for w in caught] == []
