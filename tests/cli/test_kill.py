"""A run killed at any moment leaves the complete previous set or the complete new one.

``measure`` runs on a cloud large enough to take seconds and is killed (SIGINT and
SIGKILL) at many points of its run, densest where it writes; after each kill the folder
must verify as the previous run's set or the new run's (or hold a committed set that the
next command finishes), and the next command must clean what the killed one left.
"""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from helpers import digest, run_cli, scene_points, write_xyz

from geostructure.errors import OutputError
from geostructure.io import outdir as outdir_module
from geostructure.io.outdir import JOURNAL, STAGING, recover, verified_record

pytestmark = pytest.mark.slow

ARGS = ["--no-auto", "--zeta", "0.015", "-q"]


def measure_command(cloud: Path, out: Path) -> list[str]:
    return [sys.executable, "-m", "geostructure", "measure", str(cloud), "-o", str(out), *ARGS]


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """Two clouds and the complete folder each gives, with the wall time of the second."""
    root = tmp_path_factory.mktemp("kill")
    clouds = {
        name: write_xyz(root / f"{name}.xyz", scene_points(150_000, seed=seed))
        for name, seed in (("old", 1), ("new", 2))
    }
    folders, seconds = {}, 0.0
    for name, cloud in clouds.items():
        folders[name] = root / f"ref_{name}"
        t = time.perf_counter()
        subprocess.run(measure_command(cloud, folders[name]), check=True, timeout=300)
        seconds = time.perf_counter() - t
    return clouds, folders, seconds


def which_set(folder: Path, folders: dict) -> str:
    """'old' or 'new': the complete set the folder holds; fails on anything else."""
    record = verified_record(folder)
    planes = digest(folder / "planes.csv")
    found = [name for name, ref in folders.items() if digest(ref / "planes.csv") == planes]
    assert len(found) == 1, "planes.csv is neither run's"
    assert Path(record["input"]).name == f"{found[0]}.xyz", "run.json and planes.csv are of different runs"
    return found[0]


def test_a_killed_measure_leaves_one_complete_set(runs, tmp_path):
    clouds, folders, seconds = runs
    # Kill times: across the whole run, and densely over its last fifth, where it writes.
    # The last two leave time to spare (a loaded CI machine runs slower than the reference did).
    fractions = [0.1, 0.3, 0.5, 0.7] + [0.8 + 0.025 * i for i in range(9)] + [1.5, 3.0]
    seen = {"old": 0, "new": 0, "committed": 0}
    for i, fraction in enumerate(fractions):
        work = tmp_path / f"work{i}"
        shutil.copytree(folders["old"], work)
        process = subprocess.Popen(measure_command(clouds["new"], work), stderr=subprocess.PIPE, text=True)
        time.sleep(seconds * fraction)
        process.send_signal(signal.SIGINT if i % 2 else signal.SIGKILL)
        try:
            _, err = process.communicate(timeout=120)
        except subprocess.TimeoutExpired:  # stuck: ask it where its threads are, then end it
            process.send_signal(signal.SIGUSR1)
            time.sleep(2.0)
            process.kill()
            _, err = process.communicate()
            pytest.fail(f"measure outlived {'an interrupt' if i % 2 else 'a kill'} at {fraction:.3f} of its run by "
                        f"120 s; its threads:\n{err}")  # fmt: skip
        assert "Traceback" not in err, err
        if (work / STAGING / JOURNAL).exists():  # killed inside the commit: the next command finishes it
            seen["committed"] += 1
            recover(work)
            assert which_set(work, folders) == "new"
        else:
            seen[which_set(work, folders)] += 1
        recover(work)  # what a next command does first: nothing of the killed run is left
        assert not (work / STAGING).exists()
        assert not [p.name for p in work.iterdir() if p.name.endswith(".tmp")]
    assert seen["old"] and seen["new"] + seen["committed"], seen  # kills landed before and after the commit


def test_the_next_run_cleans_what_a_killed_one_left(runs, tmp_path, capsys):
    clouds, folders, seconds = runs
    work = tmp_path / "work"
    shutil.copytree(folders["old"], work)
    (work / STAGING).mkdir()
    (work / STAGING / "planes.csv").write_text("half")  # a killed run's staged file, uncommitted
    (work / ".regions.ply.abcd1234.tmp").write_text("x")  # an older version's temporary file
    code, _, err = run_cli(capsys, "measure", clouds["new"], "-o", work, *ARGS)
    assert code == 0, err
    assert which_set(work, folders) == "new"
    assert {p.name for p in work.iterdir()} == {".geostructure-lock", *os.listdir(folders["new"])}


@pytest.mark.parametrize("step", range(1, 16))
def test_ctrl_c_at_each_rename_leaves_one_whole_set_and_says_which(runs, tmp_path, monkeypatch, capsys, step):
    """A real SIGINT at the n-th rename: before the journal the old set stays; once the
    commit has begun it finishes, so no command is needed to repair the folder, and the
    message says which set the folder holds (it said "previous" beside a half-moved one)."""
    clouds, folders, _ = runs
    work = tmp_path / "work"
    shutil.copytree(folders["old"], work)
    real, calls = os.replace, []

    def interrupted(src, dst):
        calls.append(dst)
        if len(calls) == step:
            os.kill(os.getpid(), signal.SIGINT)
        real(src, dst)

    monkeypatch.setattr(outdir_module.os, "replace", interrupted)
    from geostructure.cli import main

    code = main(["measure", str(clouds["new"]), "-o", str(work), *ARGS])
    err = capsys.readouterr().err
    monkeypatch.setattr(outdir_module.os, "replace", real)
    assert not (work / STAGING).exists(), (calls, err)
    held = which_set(work, folders)
    if len(calls) < step:
        assert code == 0 and held == "new"
    else:
        assert code == 130
        assert ("holds this run's new set" in err) == (held == "new"), err
        assert ("keeps its previous set" in err) == (held == "old"), err


@pytest.mark.parametrize("step", range(1, 16))
def test_an_interruption_at_each_rename_of_the_commit(runs, tmp_path, monkeypatch, step):
    """Deterministic: interrupt the n-th rename of a measure (the staged writes, the record, the
    journal, then the commit's moves), as a kill at that instant would; 15 is past the last."""
    clouds, folders, _ = runs
    work = tmp_path / "work"
    shutil.copytree(folders["old"], work)
    real, calls = os.replace, []

    def interrupted(src, dst):
        calls.append(dst)
        if len(calls) == step:
            raise KeyboardInterrupt
        real(src, dst)

    monkeypatch.setattr(outdir_module.os, "replace", interrupted)
    from geostructure.cli import main

    code = main(["measure", str(clouds["new"]), "-o", str(work), *ARGS])
    assert code == (130 if len(calls) >= step else 0)
    monkeypatch.setattr(outdir_module.os, "replace", real)
    committed = (work / STAGING / JOURNAL).exists()
    if committed:  # before recovery: the old set still whole, or a half-moved one that no reader accepts
        try:
            assert which_set(work, folders) == "old"
        except OutputError:
            pass
        recover(work)
    assert which_set(work, folders) == ("new" if committed or code == 0 else "old")


SWALLOWED = """
import time, weakref
from geostructure.__main__ import interrupts_never_swallowed
interrupts_never_swallowed()
class Cloud: pass
cloud = Cloud()
def on_free(ref): raise KeyboardInterrupt  # as a Ctrl-C landing in a weakref's callback
ref = weakref.ref(cloud, on_free)
try:
    del cloud  # Python prints such an exception, ignores it, and goes on
    time.sleep(5)
    print("ran on")
except KeyboardInterrupt:
    print("interrupted")
"""


def test_an_interrupt_in_a_callback_python_ignores_still_ends_the_command():
    """A Ctrl-C in a weakref callback while a report was drawn printed Python's traceback
    and the command ran on to exit 0."""
    done = subprocess.run([sys.executable, "-c", SWALLOWED], capture_output=True, text=True, timeout=60)
    assert done.stdout.strip() == "interrupted"
    assert "Traceback" not in done.stderr and "Exception ignored" not in done.stderr


WRAPPED = """
import sys
from geostructure import cli
def drawn(args):  # as a Ctrl-C inside matplotlib's axes while a report was drawn
    try:
        raise KeyboardInterrupt
    except KeyboardInterrupt as interrupt:
        raise RuntimeError("Error calling __set_name__ on '_axis_method_wrapper'") from interrupt
parser = cli.build_parser()
args = parser.parse_args(["demo", "-o", sys.argv[1]])
args.run = drawn
parser.parse_args = lambda argv=None: args
sys.exit(cli.main([], parser=parser))
"""


def test_an_interrupt_python_wrapped_in_an_error_ends_as_an_interrupt(tmp_path):
    """A Ctrl-C while matplotlib's axes were imported came out as Python's RuntimeError
    ("Error calling __set_name__"), exit 1 and a traceback, in `sets` on the Lastoni half."""
    done = subprocess.run(
        [sys.executable, "-c", WRAPPED, str(tmp_path / "out")], capture_output=True, text=True, timeout=60
    )
    assert done.returncode == 130, done.stderr
    assert "Traceback" not in done.stderr
    assert done.stderr.strip().startswith("geostructure: interrupted;")
