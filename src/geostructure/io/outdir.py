"""The result folder: one run's outputs appear together or not at all.

Every command that writes into an output folder does it through :func:`output_set`, a
small transaction:

1. the files are written into a hidden staging folder inside OUTDIR (same file system, so
   a full disk or a crash there leaves OUTDIR as it was);
2. the run record (``run.json``, or ``sweep.json``) gets a manifest, ``outputs``, naming
   every file of the set with its size and SHA-256, and is staged too;
3. a journal, ``COMMIT.json``, is written into the staging folder: the commit point;
4. the files are renamed into OUTDIR, the record last, and files of the previous set that
   the new one does not replace are removed (only those whose size and hash prove this
   program wrote them); then the staging folder goes.

A run killed before step 3 leaves the previous set untouched; one killed during step 4 is
finished by the next command that opens the folder (:func:`recover`). Readers trust a
folder only after :func:`verified_record` has checked every file against the manifest, so
a folder holding a mixture (a hand-copied ``planes.csv``, a crash of an older version)
is refused instead of reported on.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import tempfile
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

from geostructure.core.threads import signals_deferred
from geostructure.errors import OutputError
from geostructure.io.atomic import TEMP_PATTERN, json_ready, write_json
from geostructure.io.runrecord import check_run_record

STAGING = ".geostructure-staging"
JOURNAL = "COMMIT.json"
LOCK = ".geostructure-lock"

MEASURE_FILES = (
    "planes.csv",
    "planes_dips.csv",
    "planes.geojson",
    "planes.gpkg",
    "regions.ply",
    "regions.laz",
    "voxel_planes.ply",
    "voxel_planes.laz",
    "run.json",
)
EVALUATION_FILES = ("evaluation.csv", "evaluation.json")
#: What ``evaluate --fractures`` writes: the run against a field map.
VALIDATION_FILES = ("validation.csv", "validation.json")
#: What ``sets`` writes (and ``measure --sets``): the set table, and the plane tables with a set column.
SETS_FILES = (
    "sets.csv",
    "spacing.csv",
    "joints.csv",
    "traces.csv",
    "trace_vertices.csv",
    "traces.dxf",
    "planes.csv",
    "planes_dips.csv",
    "planes.geojson",
    "planes.gpkg",
    "regions.laz",
)
REPORT_FILES = ("report.html", "stereonet.png", "stereonet.svg", "rose.png")
KINEMATICS_FILES = ("kinematics.csv", "wedges.csv", "kinematics.json", "kinematics.png")
SWEEP_FILES = ("sweep.csv", "sweep.json") + tuple(
    f"sweep_{factor}.{fmt}" for factor in ("zeta", "theta", "psi", "k", "all") for fmt in ("png", "svg")
)
#: Every name GeoStructure writes into an output folder; no other file there is ever touched.
OWNED = frozenset(
    MEASURE_FILES + EVALUATION_FILES + VALIDATION_FILES + SETS_FILES + REPORT_FILES + SWEEP_FILES + KINEMATICS_FILES
)


def check_outdir(outdir) -> Path:
    """Refuse an output folder that cannot be used, before any work, leaving nothing behind
    (a probe folder is made in it, or in its nearest existing parent, and removed at once).

    Examples
    --------
    >>> check_outdir("/dev/null")
    Traceback (most recent call last):
    ...
    geostructure.errors.OutputError: /dev/null: is a file, not a folder; give a folder for the outputs.
    """
    outdir = Path(outdir)
    if outdir.exists() and not outdir.is_dir():
        raise OutputError(f"{outdir}: is a file, not a folder; give a folder for the outputs.")
    existing = outdir
    while not existing.exists():
        existing = existing.parent
    if not existing.is_dir():
        raise OutputError(f"{outdir}: cannot be created, since {existing} is a file.")
    if not os.access(existing, os.W_OK | os.X_OK):
        raise OutputError(
            f"{outdir}: the output folder is not writable."
            if existing == outdir
            else f"{outdir}: cannot be created in {existing} (not writable)."
        )
    check_output_targets(outdir)
    # The permission bits do not tell everything: root passes them where the file system
    # itself refuses (/proc, a root-squashed NFS share), and the refusal came only when the
    # results were written, after the whole measurement. A folder made and removed at once
    # asks the file system.
    try:
        os.rmdir(tempfile.mkdtemp(prefix=".geostructure-probe-", dir=existing))
    except OSError as exc:
        raise OutputError(
            f"{outdir}: the output folder is not writable (the file system refused: {exc.strerror})."
            if existing == outdir
            else f"{outdir}: cannot be created in {existing} (the file system refused: {exc.strerror})."
        ) from None
    return outdir


def check_output_targets(outdir) -> None:
    """Refuse a folder where an output's place is taken by a folder or a link: the set
    would move in without that file (or the staging folder be left behind)."""
    outdir = Path(outdir)
    if not outdir.is_dir():
        return
    for name in sorted(OWNED | RECORD_NAMES):
        target = outdir / name
        if target.is_symlink() or (target.exists() and not target.is_file()):
            raise OutputError(
                f"{target}: is {'a link' if target.is_symlink() else 'a folder'} where the output {name} goes; "
                f"move it away or choose another output folder."
            )


def prepare_outdir(outdir) -> Path:
    """Check OUTDIR (:func:`check_outdir`) and create it; for stages that keep their own files."""
    outdir = check_outdir(outdir)
    try:
        outdir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputError(f"{outdir}: cannot create the output folder ({exc.strerror}).") from None
    return outdir


def check_inputs_not_outputs(outdir, inputs) -> None:
    """Refuse an input file that a run would overwrite or remove: one of OUTDIR's output
    names, or a file in its staging folder (the run's own working folder)."""
    outdir = Path(outdir)
    if not outdir.is_dir():
        return
    staging = (outdir / STAGING).resolve()
    for source in inputs:
        if source is None or not Path(source).is_file():
            continue
        if staging in Path(source).resolve().parents:
            raise OutputError(
                f"{source}: lies in {outdir / STAGING}, the run's own working folder; copy it elsewhere first."
            )
        for name in sorted(OWNED):
            target = outdir / name
            if target.exists() and os.path.samefile(source, target):
                raise OutputError(
                    f"{source}: is the output {name} of {outdir}, which this run would overwrite; "
                    f"copy it elsewhere or choose another output folder."
                )


def file_entry(path: Path) -> dict:
    """Size and SHA-256 of one file, as the manifest records them."""
    digest = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            digest.update(block)
    return {"bytes": path.stat().st_size, "sha256": digest.hexdigest()}


def _matches(path: Path, entry) -> bool:
    try:
        return (
            isinstance(entry, dict)
            and path.is_file()
            and path.stat().st_size == entry.get("bytes")
            and file_entry(path)["sha256"] == entry.get("sha256")
        )
    except OSError:
        return False


def read_record(path: Path) -> dict | None:
    """A JSON record (``run.json``, a journal) as a dict; None when absent or not one (or
    nested too deep to read: 100,000 brackets)."""
    try:
        record = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError, RecursionError):
        return None
    return record if isinstance(record, dict) else None


#: The key under which a record holds the digest of the rest of itself.
SEAL = "record_sha256"


def record_digest(record: dict) -> str:
    """SHA-256 of a record without its seal, in one canonical JSON text."""
    body = {k: v for k, v in record.items() if k != SEAL}
    text = json.dumps(json_ready(body), sort_keys=True, separators=(",", ":"), allow_nan=False)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def sealed(record: dict) -> dict:
    """The record with its digest: a run record edited by hand (a number made an object, an
    offset made a string) is told from the one GeoStructure wrote, and refused, rather than
    read until a reader fails on it.

    Examples
    --------
    >>> record = sealed({"offset": [0.0, 0.0, 10.0]})
    >>> record[SEAL] == record_digest(record), record_digest({**record, "offset": {"a": 1}}) == record[SEAL]
    (True, False)
    """
    return {**{k: v for k, v in record.items() if k != SEAL}, SEAL: record_digest(record)}


def verified_record(outdir, record_name: str = "run.json", command: str = "geostructure measure", ignore=()) -> dict:
    """The run record of OUTDIR, after checking every file it lists is the one it wrote.

    Raises :class:`OutputError` naming the first file that is missing or changed, so no
    reader ever works from a mixture of two runs. Files named in ``ignore`` (about to be
    rewritten) are not checked.

    Parameters
    ----------
    outdir : str or Path
        A folder written by GeoStructure.
    record_name : str
        ``run.json``, or ``sweep.json`` for a sweep's folder.
    command : str
        The command the messages tell the user to run again.
    ignore : sequence of str
        Output names not to check.

    Examples
    --------
    >>> import tempfile
    >>> out = tempfile.mkdtemp()
    >>> with output_set(out) as outputs:
    ...     _ = outputs.path("planes.csv").write_text("region_id\\n")
    >>> _ = open(f"{out}/planes.csv", "a").write("0\\n")  # edited after the run
    >>> verified_record(out)
    Traceback (most recent call last):
    ...
    geostructure.errors.OutputError: ...planes.csv is not the file run.json lists (changed since, or left by another run), so the folder mixes two sets; run 'geostructure measure' again.
    """
    outdir = Path(outdir)
    path = outdir / record_name
    if not path.is_file():
        if any((outdir / name).exists() for name in OWNED):
            raise OutputError(
                f"{outdir}: holds outputs but no {record_name}, so they are an incomplete set; run '{command}' again."
            )
        raise OutputError(f"{path}: no such file; run '{command}' first.")
    record = read_record(path)
    if record is None:
        raise OutputError(f"{path}: not a GeoStructure run record (not a JSON object).")
    if SEAL not in record:
        # An unsealed record is one written by hand, by an older GeoStructure, or one whose
        # seal was deleted: read as an older record, any edit passed the check.
        raise OutputError(
            f"{path}: has no seal ({SEAL}), so it was written by hand or by an older GeoStructure, or edited; "
            f"run '{command}' again."
        )
    try:
        changed = record[SEAL] != record_digest(record)
    except (TypeError, ValueError):  # a value no JSON of ours holds (NaN, a huge integer)
        changed = True
    if changed:
        raise OutputError(
            f"{path}: was changed since GeoStructure wrote it, so it cannot be trusted; run '{command}' again."
        )
    if record_name == "run.json":
        check_run_record(record, path, command)
    outputs = record.get("outputs")
    if not isinstance(outputs, dict):
        raise OutputError(
            f"{path}: lists no outputs (written by an older GeoStructure or by hand), so the folder "
            f"cannot be trusted as one run; run '{command}' again."
        )
    for name, entry in sorted(outputs.items()):
        if name in ignore:
            continue
        if name not in OWNED or "/" in name:
            raise OutputError(f"{path}: lists '{name}', which GeoStructure never writes; run '{command}' again.")
        if not (outdir / name).is_file():
            raise OutputError(
                f"{outdir}: {name} is missing although {record_name} lists it, so the folder holds an "
                f"incomplete set; run '{command}' again."
            )
        if not _matches(outdir / name, entry):
            raise OutputError(
                f"{outdir}: {name} is not the file {record_name} lists (changed since, or left by "
                f"another run), so the folder mixes two sets; run '{command}' again."
            )
    return record


@dataclass
class OutputSet:
    """A transaction over one output folder; write each file to :meth:`path`, then commit."""

    outdir: Path
    staging: Path
    record_name: str
    replace: bool
    record: dict = field(default_factory=dict)
    kept: dict = field(default_factory=dict)  # manifest entries carried over (add mode)
    stale: list = field(default_factory=list)  # previous files this set replaces (replace mode)
    digests: dict = field(default_factory=dict)  # name -> (size, mtime_ns, entry), hashed early

    def path(self, name: str) -> Path:
        """Where to write output ``name`` (in the staging folder until the commit)."""
        if name not in OWNED:
            raise ValueError(f"'{name}' is not a GeoStructure output name")
        self.digests.pop(name, None)  # about to be written (again): an early hash no longer holds
        return self.staging / name

    def final(self, name: str) -> Path:
        """Where output ``name`` will be once committed."""
        return self.outdir / name

    def hash_staged(self, path) -> Path:
        """Hash a staged file now (a writer's thread, idle while another file is written),
        for the commit's manifest: at 8M points hashing the point files took 0.19 s there.
        The commit hashes the file again if it was asked for again (:meth:`path`) or changed
        since (its size or time)."""
        path = Path(path)
        stat = path.stat()
        self.digests[path.name] = (stat.st_size, stat.st_mtime_ns, file_entry(path))
        return path

    def entry(self, name: str) -> dict:
        """The manifest entry of staged file ``name``: its early hash, if it still holds."""
        path = self.staging / name
        stat = path.stat()
        size, mtime, entry = self.digests.get(name, (None, None, None))
        return entry if (size, mtime) == (stat.st_size, stat.st_mtime_ns) else file_entry(path)

    def write_record(self) -> Path:
        """Stage the record as it stands (for readers inside the transaction, such as the
        report), sealed with its own digest (:func:`sealed`)."""
        return write_json(sealed(self.record), self.staging / self.record_name)


@contextmanager
def output_set(
    outdir,
    *,
    record_name: str = "run.json",
    replace: bool = True,
    inputs=(),
    command: str = "geostructure measure",
    rewrites=(),
    reads=(),
):
    """Open OUTDIR for one all-or-nothing set of outputs.

    ``replace=True`` (a measure, a sweep): the new set replaces the previous one, whose
    files the new one does not rewrite are removed. ``replace=False`` (report, evaluate):
    the files are added to the folder's verified set, and the record is the folder's own;
    the files it will rewrite (``rewrites``) need not verify, as they are replaced, but for
    those it reads first (``reads``: ``sets`` reads ``planes.csv`` and ``regions.laz`` and
    writes them again), which must be the run's as any input is.

    Examples
    --------
    >>> import tempfile
    >>> out = tempfile.mkdtemp()
    >>> with output_set(out) as outputs:
    ...     _ = outputs.path("planes.csv").write_text("region_id\\n")
    ...     outputs.record = {"input": "example"}
    >>> sorted(verified_record(out)["outputs"])
    ['planes.csv']
    """
    check_inputs_not_outputs(outdir, inputs)
    check_output_targets(outdir)
    created = not Path(outdir).is_dir()
    outdir = prepare_outdir(outdir)
    with _removed_on_failure(outdir, created), _locked(outdir):
        recover(outdir)
        outputs = OutputSet(outdir, outdir / STAGING, record_name, replace)
        if replace:
            previous = read_record(outdir / record_name) or {}
            manifest = previous.get("outputs") if isinstance(previous.get("outputs"), dict) else {}
            outputs.stale = [n for n, e in sorted(manifest.items()) if n in OWNED and _matches(outdir / n, e)]
        else:
            outputs.record = verified_record(outdir, record_name, command, ignore=set(rewrites) - set(reads))
            outputs.kept = {n: e for n, e in outputs.record.pop("outputs").items() if n not in rewrites}
        outputs.staging.mkdir()
        try:
            yield outputs
            _commit(outputs)
        except BaseException as exc:
            if (outputs.staging / JOURNAL).exists():
                raise  # committed: the next command finishes the move (recover)
            try:
                clear_staging(outputs.staging)
            except OutputError:
                pass  # something else was put there meanwhile: left, and the next run says so
            if isinstance(exc, OSError):  # a full disk, a quota, a file system gone read-only
                raise OutputError(
                    f"{outdir}: cannot write the outputs ({exc.strerror or exc}); the folder holds what it held before."
                ) from None
            raise


def _commit(outputs: OutputSet) -> None:
    staged = sorted(p.name for p in outputs.staging.iterdir() if p.name != outputs.record_name)
    stray = [n for n in staged if n not in OWNED]
    if stray:
        raise ValueError(f"staged files GeoStructure does not own: {stray}")
    manifest = {**outputs.kept, **{n: outputs.entry(n) for n in staged}}
    outputs.record = {**outputs.record, "outputs": manifest}
    outputs.write_record()
    for name in staged + [outputs.record_name]:
        _fsync(outputs.staging / name)
    remove = [n for n in outputs.stale if n not in manifest and n != outputs.record_name]
    with signals_deferred():  # once the journal is written, the renames finish: never a mixed folder
        write_json({"files": staged + [outputs.record_name], "remove": remove}, outputs.staging / JOURNAL)
        _fsync(outputs.staging)
        _roll_forward(outputs.outdir)


def _roll_forward(outdir: Path) -> None:
    """Finish a committed set: move its files into place (the record last), drop the stale ones."""
    staging = outdir / STAGING
    journal = read_record(staging / JOURNAL) or {}
    for name in journal.get("files", []):
        if name in OWNED and (staging / name).exists():
            os.replace(staging / name, outdir / name)
    for name in journal.get("remove", []):
        if name in OWNED:
            (outdir / name).unlink(missing_ok=True)
    _fsync(outdir)
    clear_staging(staging)


#: The files a staging folder may hold besides the outputs: the records and the journal.
RECORD_NAMES = frozenset({"run.json", "sweep.json", JOURNAL})


def clear_staging(staging: Path) -> None:
    """Remove a staging folder and the files GeoStructure writes there (its outputs, records,
    journal and their temporary files); one that holds anything else is refused, left as
    it is: a run never removes what it did not create."""
    staging = Path(staging)
    if not staging.is_dir():
        return
    foreign = []
    for entry in staging.iterdir():
        match = TEMP_PATTERN.match(entry.name)
        name = match.group("name") if match else entry.name
        if (name in OWNED or name in RECORD_NAMES) and entry.is_file() and not entry.is_symlink():
            entry.unlink(missing_ok=True)
        else:
            foreign.append(entry.name)
    if foreign:
        raise OutputError(
            f"{staging}: holds {', '.join(sorted(foreign)[:3])}{' and more' if len(foreign) > 3 else ''}, which "
            f"GeoStructure did not write there; move it out of this working folder, then run again."
        )
    staging.rmdir()


def recover(outdir) -> None:
    """Clean what a killed run left: finish a committed set, drop an uncommitted one and any
    temporary file of an output name."""
    outdir = Path(outdir)
    staging = outdir / STAGING
    if staging.is_dir():
        if read_record(staging / JOURNAL) is not None:
            _roll_forward(outdir)
        else:
            clear_staging(staging)
    for entry in outdir.iterdir():
        match = TEMP_PATTERN.match(entry.name)
        if match and match.group("name") in OWNED and entry.is_file():
            entry.unlink(missing_ok=True)


def folder_state(outdir) -> tuple:
    """What identifies the set an output folder holds now (its records' seals), to tell
    after an interrupt whether the run's new set went in.

    Examples
    --------
    >>> import tempfile
    >>> out = tempfile.mkdtemp()
    >>> before = folder_state(out)
    >>> with output_set(out) as outputs:
    ...     _ = outputs.path("planes.csv").write_text("region_id\\n")
    >>> folder_state(out) != before
    True
    """
    seals = []
    for name in ("run.json", "sweep.json"):
        record = read_record(Path(outdir) / name) if outdir is not None else None
        try:
            seals.append(None if record is None else record.get(SEAL) or record_digest(record))
        except (TypeError, ValueError):  # a record no digest can be taken of: as good as unread
            seals.append(None)
    return tuple(seals)


def _fsync(path: Path) -> None:
    """Flush a file or folder to disk, so a power cut after the commit cannot lose the set."""
    try:
        fd = os.open(path, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass  # some file systems cannot sync a folder; the rename order still holds
    finally:
        os.close(fd)


@contextmanager
def _removed_on_failure(outdir: Path, created: bool):
    """A folder this set created goes again when the set fails before it holds anything but
    its lock (a bad input found once the folder was open): no empty folder is left behind."""
    try:
        yield
    except BaseException:
        if created and {p.name for p in outdir.iterdir()} <= {LOCK}:
            shutil.rmtree(outdir, ignore_errors=True)
        raise


@contextmanager
def _locked(outdir: Path):
    """One writer per folder: a second command writing to the same OUTDIR is refused."""
    try:
        import fcntl
    except ImportError:  # not POSIX: no lock, the journal still keeps sets whole
        yield
        return
    with open(outdir / LOCK, "a") as fh:
        try:
            fcntl.flock(fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            raise OutputError(
                f"{outdir}: another geostructure command is writing to this folder; wait for it to finish."
            ) from None
        try:
            yield
        finally:
            fcntl.flock(fh, fcntl.LOCK_UN)
