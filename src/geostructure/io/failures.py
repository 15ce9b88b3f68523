"""A damaged file read as one sentence naming it, never a traceback or a crash.

Two kinds of failure come from the libraries under the readers:

- errors (a parse error, a short read) that :func:`translated_read_errors` turns into a
  :class:`~..errors.GeoStructureError`, in memory and chunk by chunk alike. lazrs, the LAZ
  decompressor, also *panics* on some damaged files (a Rust panic, raised through pyo3 as
  ``PanicException``, which derives from ``BaseException`` and slipped past ``except
  Exception``);
- crashes no handler can catch. The LASzip bindings, where installed, segfaulted on damaged
  files laspy handed them when lazrs refused: :func:`laz_readers` keeps to lazrs. And lazrs
  aborts the whole process when an allocation fails ("memory allocation of 57044217400
  bytes failed"), as a flipped byte of a LAZ file's chunk size or chunk table makes it ask:
  :func:`check_laz_chunks` reads those few numbers first and refuses what cannot be true.
"""

from __future__ import annotations

import struct
from contextlib import contextmanager
from pathlib import Path

from geostructure.errors import GeoStructureError, InputError

#: The most bytes one LAZ chunk may decompress to: a chunk is 50,000 points (some 1.7 MB)
#: in the files LAStools, PDAL and laspy write; above this the number is damaged.
MAX_CHUNK_BYTES = 2**31

#: The record the LASzip specification gives the compression's parameters.
LASZIP_RECORD_ID = 22204

#: LASzip's compressors that cut the points into chunks listed in a chunk table (pointwise
#: chunked, layered chunked); compressor 1 compresses the points one after another.
CHUNKED_COMPRESSORS = (2, 3)


def laz_readers() -> tuple:
    """The LAZ decompressors laspy may read points with: lazrs's, parallel then serial.

    Where the LASzip bindings (``laszip``) are installed too, laspy falls back to them when
    lazrs refuses a file, and they crashed the process on damaged files (a segmentation
    fault in ``LasUnZipper``); lazrs's refusal is the user's answer.
    """
    import laspy  # lazy: only LAS/LAZ readers need it

    return (laspy.LazBackend.LazrsParallel, laspy.LazBackend.Lazrs)


def is_library_failure(exc: BaseException) -> bool:
    """Whether ``exc`` is a library's failure: an ``Exception``, or a Rust library's panic
    raised through pyo3 (``PanicException``, a ``BaseException`` as an interrupt is).

    Examples
    --------
    >>> is_library_failure(ValueError("no")), is_library_failure(KeyboardInterrupt())
    (True, False)
    """
    return isinstance(exc, Exception) or type(exc).__name__ == "PanicException"


@contextmanager
def _damaged(path, what: str):
    """A library's failure inside the block as "``path``: its ``what`` is damaged (...)"."""
    try:
        yield
    except BaseException as exc:
        if not is_library_failure(exc) or isinstance(exc, GeoStructureError):
            raise
        raise InputError(f"{path}: its {what} is damaged ({exc}).") from None


def read_error(path, exc: BaseException) -> GeoStructureError | None:
    """The one-sentence error for a library's failure to read ``path``; None for what must
    go on as it is (this package's own errors, an interrupt, the interpreter's exit).

    Examples
    --------
    >>> str(read_error(Path("scan.laz"), ValueError("IoError: failed to fill whole buffer")))
    'scan.laz: cannot be read as LAZ (IoError: failed to fill whole buffer).'
    >>> read_error(Path("scan.laz"), KeyboardInterrupt()) is None
    True
    """
    path = Path(path)
    if isinstance(exc, (GeoStructureError, KeyboardInterrupt, SystemExit, GeneratorExit)):
        return None
    if isinstance(exc, PermissionError):
        return GeoStructureError(f"{path}: permission denied.")
    if isinstance(exc, MemoryError):
        return GeoStructureError(f"{path}: does not fit in memory ({path.stat().st_size:,} bytes on disk).")
    if not is_library_failure(exc):
        return None
    detail = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
    return GeoStructureError(f"{path}: cannot be read as {path.suffix[1:].upper()} ({detail}).")


@contextmanager
def translated_read_errors(path):
    """Reading ``path`` inside the block, a library's failure comes out as :func:`read_error`."""
    try:
        yield
    except BaseException as exc:
        error = read_error(path, exc)
        if error is None:
            raise
        raise error from None


def check_laz_chunks(path, header) -> None:
    """Refuse a LAZ file whose chunk size or chunk table cannot be true, before lazrs reads
    its points (and asks for memory on their word): a chunk that decompresses to more than
    :data:`MAX_CHUNK_BYTES`, or a chunk table out of the file, of a version LASzip does not
    write, of more chunks than the file has bytes, or whose chunks hold more bytes than the
    file. ``header``: laspy's, of the open file. A LAS file passes untouched.

    Examples
    --------
    >>> import laspy
    >>> check_laz_chunks("plain.las", laspy.LasHeader())  # no compression record: nothing to check
    """
    import lazrs  # lazy: only LAZ files need it

    record = next((v for v in header.vlrs if getattr(v, "record_id", None) == LASZIP_RECORD_ID), None)
    if record is None:
        return
    path = Path(path)
    with _damaged(path, "LAZ compression record"):
        compression = lazrs.LazVlr(record.record_data)
    point_bytes = max(int(compression.item_size()), 1)
    if not compression.uses_variable_size_chunks() and compression.chunk_size() * point_bytes > MAX_CHUNK_BYTES:
        raise InputError(
            f"{path}: its LAZ compression record is damaged: chunks of {compression.chunk_size():,} points "
            f"({compression.chunk_size() * point_bytes / 2**30:.0f} GiB each)."
        )
    if struct.unpack_from("<H", bytes(record.record_data))[0] not in CHUNKED_COMPRESSORS:
        return  # points compressed one after another: no chunk table
    size = path.stat().st_size
    start = int(header.offset_to_point_data)
    with open(path, "rb") as fh:
        fh.seek(start)
        raw = fh.read(8)
        if len(raw) < 8:
            return  # no points to read: the reader says so
        (table,) = struct.unpack("<q", raw)
        if table == -1:  # written to a stream: the table's offset is the file's last 8 bytes
            fh.seek(max(size - 8, 0))
            (table,) = struct.unpack("<q", fh.read(8).rjust(8, b"\0"))
        if not start + 8 <= table <= size - 8:
            raise InputError(f"{path}: its LAZ chunk table is damaged (at byte {table} of {size}).")
        fh.seek(table)
        version, chunks = struct.unpack("<II", fh.read(8))
        if version != 0 or chunks > size - start:
            raise InputError(
                f"{path}: its LAZ chunk table is damaged (version {version}, {chunks:,} chunks in {size:,} bytes)."
            )
        fh.seek(start)
        with _damaged(path, "LAZ chunk table"):
            entries = lazrs.read_chunk_table(fh, compression)
    held = sum(int(n_bytes) for _, n_bytes in entries)
    if held > size - start:
        raise InputError(f"{path}: its LAZ chunk table is damaged: its chunks hold {held:,} bytes, the file {size:,}.")
    if compression.uses_variable_size_chunks():
        largest = max((int(n_points) for n_points, _ in entries), default=0)
        if largest * point_bytes > MAX_CHUNK_BYTES:
            raise InputError(f"{path}: its LAZ chunk table is damaged: a chunk of {largest:,} points.")
