"""The executors: a Dask worker that dies has its tasks run again and the run says so; a task
that kills every worker it is given ends the run with one sentence."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from geostructure.errors import GeoStructureError, GeoStructureNote

pytest.importorskip("distributed")


def die_once(chunk: int, marker: str) -> int:
    """The chunk's square; the first worker to run chunk 3 dies instead (a crash, an
    out-of-memory kill), once for the whole cluster (the marker file)."""
    if chunk == 3 and not Path(marker).exists():
        Path(marker).touch()
        os._exit(1)
    return chunk * chunk


def plus_context(chunk: int, context: int) -> int:
    return chunk + context


def always_die(chunk: int, _context) -> int:
    os._exit(1)


@pytest.fixture(scope="module")
def executor():
    from geostructure.stream import DaskExecutor

    executor = DaskExecutor(workers=2)
    yield executor
    executor.close()


def test_a_worker_that_dies_has_its_task_run_again_and_the_run_says_so(executor, tmp_path):
    # One worker dies: the other still holds the scattered context, and Dask runs the task
    # again.
    with pytest.warns(GeoStructureNote, match=r"1 Dask worker died or left during the run; Dask ran its tasks again"):
        results = list(executor.map(die_once, range(8), str(tmp_path / "died")))
    assert results == [c * c for c in range(8)]  # whole and in chunk order
    assert (tmp_path / "died").exists() and executor.workers_lost == 1


def test_workers_that_all_die_at_once_have_the_context_scattered_again(executor):
    # Every worker stopped at once mid-pass (a restart): the context scattered to them is
    # gone with them; it is scattered again to the new workers and the chunks sent again.
    results = executor.map(plus_context, range(12), 100)
    first = next(results)
    executor.client.restart()
    with pytest.warns(
        GeoStructureNote, match=r"Dask workers? died or left during the run; Dask ran (its|their) tasks again"
    ):
        rest = list(results)
    assert [first, *rest] == [100 + c for c in range(12)]


def test_a_task_that_kills_every_worker_ends_the_run_with_one_sentence(executor):
    with pytest.raises(GeoStructureError, match=r"given up after the Dask workers that ran it died in turn"):
        list(executor.map(always_die, range(2), None))


def test_ctrl_c_while_the_local_cluster_starts_leaves_no_cluster_behind(tmp_path):
    """An interrupt while LocalCluster started left it half made: distributed's exit hook
    then printed an AssertionError traceback and log lines after the one-sentence message.
    The start now finishes, the interrupt follows, and the cluster is closed. In a process
    of its own: the module's cluster would share this one's resource tracker."""
    import subprocess
    import sys

    pytest.importorskip("distributed")
    script = tmp_path / "start.py"
    script.write_text(
        "import os, signal\n"
        "from distributed.deploy.spec import SpecCluster\n"
        "from geostructure.stream import DaskExecutor\n"
        "real = DaskExecutor._start_local\n"
        "def interrupted(self, workers):\n"
        "    os.kill(os.getpid(), signal.SIGINT)  # from the starting thread: the main thread is told\n"
        "    real(self, workers)\n"
        "if __name__ == '__main__':  # the workers' processes import this file again\n"
        "    DaskExecutor._start_local = interrupted\n"
        "    try:\n"
        "        DaskExecutor(workers=1)\n"
        "    except KeyboardInterrupt:\n"
        "        left = [c for c in SpecCluster._instances if c.status.name not in ('closed', 'closing')]\n"
        "        print('interrupted', len(left))\n"
    )
    done = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=120)
    assert done.stdout.strip() == "interrupted 0", (done.stdout, done.stderr)
    assert "Traceback" not in done.stderr and "AssertionError" not in done.stderr, done.stderr
