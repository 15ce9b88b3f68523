"""Row-split work in threads (geostructure.core.threads): the same bits whatever the number of
threads, a block's error raised in the caller, and a writers' pool left only once its threads
are done, even on an interrupt."""

import os
import signal
import threading
import time

import numpy as np
import pytest

from geostructure.core import threads
from geostructure.detect.cells import CellGrid, grid_planes
from geostructure.synthetic import outcrop_scene


def test_cell_planes_are_the_same_bits_on_one_thread_and_on_four(monkeypatch):
    points = outcrop_scene(width=8.0, height=5.0, point_spacing=0.02, seed=2).cloud.local
    grid = CellGrid.of(points, 0.025)
    assert len(grid) > 2 * threads.MIN_ROWS_PER_THREAD  # enough cells to be split
    planes = {}
    for cores in (1, 4):
        monkeypatch.setattr(threads, "available_cores", lambda cores=cores: cores)
        planes[cores] = grid_planes(grid)
    for field in ("normal", "block_centroid", "variation", "residual", "defined", "neighbour"):
        assert np.array_equal(getattr(planes[1], field), getattr(planes[4], field), equal_nan=True), field


def test_rows_are_split_in_order_and_every_row_once():
    blocks = threads.row_blocks(100_003, workers=3, min_rows=10)
    covered = np.concatenate([np.arange(100_003)[b] for b in blocks])
    assert len(blocks) == 3 and np.array_equal(covered, np.arange(100_003))
    assert threads.row_blocks(5, workers=8, min_rows=10) == [slice(0, 5)]


def test_an_error_in_one_block_reaches_the_caller_after_the_others_finish():
    done = []

    def work(rows):
        if rows.start == 0:
            raise ValueError("first block")
        done.append(rows)

    with pytest.raises(ValueError, match="first block"):
        threads.run_blocks(work, 100, workers=2, min_rows=10)
    assert done == [slice(50, 100)]


def test_the_outlier_filter_is_the_same_bits_on_one_thread_and_on_four(monkeypatch):
    from geostructure.detect.filter import local_filter

    points = outcrop_scene(width=8.0, height=5.0, point_spacing=0.02, seed=2).cloud.local
    judged = {}
    for cores in (1, 4):
        monkeypatch.setattr(threads, "available_cores", lambda cores=cores: cores)
        judged[cores] = local_filter(points, 0.02, 3.0)  # some 0.1M voxels: split too
    assert len(points) > 2 * threads.MIN_ROWS_PER_THREAD
    assert np.array_equal(judged[1].keep, judged[4].keep)
    assert np.array_equal(judged[1].distance, judged[4].distance)
    assert not judged[1].keep.all()  # a filter that judged something


def test_omp_num_threads_bounds_the_threads_as_dask_workers_set_it(monkeypatch):
    monkeypatch.setenv("OMP_NUM_THREADS", "1")
    assert threads.available_cores() == 1
    assert threads.row_blocks(10**6) == [slice(0, 10**6)]
    monkeypatch.setenv("OMP_NUM_THREADS", "not a number")  # ignored, as OpenBLAS ignores it
    assert threads.available_cores() >= 1


def test_an_interrupt_during_a_tree_query_is_raised_once_the_query_is_done():
    """A Ctrl-C raised while SciPy waited on its query threads freed the arrays they wrote
    (a segmentation fault in a third of the interrupts during the Lastoni half's normals)."""
    import os
    import signal
    import time

    finished = []

    class Tree:  # a KD-tree whose query is interrupted half way
        def query(self, points, k, workers):
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(0.2)  # an interrupt not held back is raised here
            finished.append(workers)
            return np.zeros((len(points), k)), np.zeros((len(points), k), dtype=np.intp)

    with pytest.raises(KeyboardInterrupt):
        threads.tree_query(Tree(), np.zeros((4, 3)), k=2)
    assert finished == [threads.available_cores()]


def test_every_threaded_tree_query_holds_interrupts_back():
    """SciPy's threads are asked for only through ``tree_query``."""
    import re
    from pathlib import Path

    package = Path(threads.__file__).parents[1]
    threaded = re.compile(r"\.query\([^)]*workers\s*=")
    found = [
        f"{path.relative_to(package)}:{number}"
        for path in package.rglob("*.py")
        for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1)
        if threaded.search(line) and path.name != "threads.py"
    ]
    assert found == []


def test_an_interrupt_inside_submit_still_waits_for_the_thread_it_started(monkeypatch):
    """A Ctrl-C landing in ``submit`` after the pool started a thread, before it counted it,
    left that thread writing after the pool was left (its regions.laz reached an output
    folder's staging after the folder was cleaned)."""
    real_start = threading.Thread.start

    def start_then_interrupt(thread):
        real_start(thread)
        os.kill(os.getpid(), signal.SIGINT)  # to the main thread, still inside submit

    done = []

    def slow():
        time.sleep(0.3)
        done.append(True)

    monkeypatch.setattr(threading.Thread, "start", start_then_interrupt)
    with pytest.raises(KeyboardInterrupt):
        with threads.finished_pool(2) as pool:
            pool.submit(slow)
            time.sleep(1.0)  # the interrupt, held back in submit, lands here at the latest
    assert done, "the pool was left while its thread still ran"
