"""Row-split work on the machine's cores.

numpy lets go of Python's global lock inside its loops (ufuncs, ``take``, ``searchsorted``),
so the rows of an elementwise computation split into blocks run side by side in threads:
on 2 cores, the closed-form eigenpairs of 0.6M matrices took 0.10 s instead of 0.25 s and
the 27-cell block sums half their time. Each block writes its own rows, so the result is the
same bit for bit whatever the number of threads; work that reduces across rows (a sum
over the cloud) stays in one thread, where its order, and so its last bits, are fixed.

A pool is made per call (about 0.1 ms): nothing is kept between calls.
"""

from __future__ import annotations

import importlib
import os
import signal
import threading
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager
from typing import Callable

#: Fewer rows than this are done in the calling thread: a thread's start costs more.
MIN_ROWS_PER_THREAD = 32_768


def available_cores() -> int:
    """The threads this process's numpy work may use: the cores it may run on (its
    affinity, as a batch scheduler sets it), and no more than ``OMP_NUM_THREADS`` when that
    is set, the limit OpenBLAS and numexpr honour too. Dask's workers set it to 1: there the
    cluster's processes share the cores, and threads in each would only oversubscribe them.

    Examples
    --------
    >>> available_cores() >= 1
    True
    """
    try:
        cores = max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not on Linux
        cores = max(1, os.cpu_count() or 1)
    limit = os.environ.get("OMP_NUM_THREADS", "").strip()
    return max(1, min(cores, int(limit))) if limit.isdigit() else cores


def row_blocks(n_rows: int, workers: int | None = None, min_rows: int = MIN_ROWS_PER_THREAD) -> list[slice]:
    """``n_rows`` split into one contiguous block per thread, each of at least ``min_rows``.

    Examples
    --------
    >>> row_blocks(10, workers=2, min_rows=4)
    [slice(0, 5, None), slice(5, 10, None)]
    >>> row_blocks(10, workers=2, min_rows=8)
    [slice(0, 10, None)]
    """
    workers = available_cores() if workers is None else workers
    n_blocks = max(1, min(workers, n_rows // max(min_rows, 1)))
    bounds = [n_rows * i // n_blocks for i in range(n_blocks + 1)]
    return [slice(a, b) for a, b in zip(bounds[:-1], bounds[1:])]


def run_blocks(work: Callable[[slice], object], n_rows: int, *, workers: int | None = None,
               min_rows: int = MIN_ROWS_PER_THREAD) -> list:  # fmt: skip
    """``work(rows)`` for each of :func:`row_blocks`, side by side; the results in order.

    ``work`` writes its rows of outputs made before the call (or returns its piece).
    An error in any block is raised here, after every block has finished.

    Examples
    --------
    >>> import numpy as np
    >>> x, out = np.arange(100_000.0), np.empty(100_000)
    >>> _ = run_blocks(lambda rows: np.sqrt(x[rows], out=out[rows]), len(x), workers=2)
    >>> bool(np.array_equal(out, np.sqrt(x)))
    True
    """
    blocks = row_blocks(n_rows, workers, min_rows)
    if len(blocks) == 1:
        return [work(blocks[0])]
    with ThreadPoolExecutor(len(blocks)) as pool:
        futures = [pool.submit(work, rows) for rows in blocks]
    return [future.result() for future in futures]


def task_workers(n_rows: int, at_most: int | None = None) -> int:
    """Threads for tasks over ``n_rows`` rows each: one below :data:`MIN_ROWS_PER_THREAD`
    rows (a thread's start costs more), else the cores, at most ``at_most``.

    Examples
    --------
    >>> task_workers(10)
    1
    """
    if n_rows < MIN_ROWS_PER_THREAD:
        return 1
    return available_cores() if at_most is None else min(available_cores(), at_most)


def run_tasks(tasks: list[Callable[[], object]], *, workers: int | None = None) -> list:
    """Independent ``tasks`` (no arguments) side by side; their results in order.

    Examples
    --------
    >>> run_tasks([lambda: 1, lambda: 2], workers=2)
    [1, 2]
    """
    workers = min(available_cores() if workers is None else workers, len(tasks))
    if workers <= 1:
        return [task() for task in tasks]
    with ThreadPoolExecutor(workers) as pool:
        futures = [pool.submit(task) for task in tasks]
    return [future.result() for future in futures]


def preload(*modules: str) -> None:
    """Import ``modules`` in this thread, before starting threads that import them.

    Two threads importing one module share its import lock. An interrupt (Ctrl-C) that
    lands in the main thread while it holds that lock can leave it held, and the other
    thread then waits on it for ever while the main thread waits for that thread: a
    ``measure`` interrupted as it wrote its files hung so (about once in a few hundred
    interrupts), its point-file thread importing laspy while the main thread wrote the voxel
    planes' LAZ. Imported first, here, no other thread is left waiting.

    Examples
    --------
    >>> preload("json")
    """
    for name in modules:
        importlib.import_module(name)


#: The signals a commit holds back until it is done: an interrupt (Ctrl-C) and a polite kill.
DEFERRED_SIGNALS = (signal.SIGINT, signal.SIGTERM)


@contextmanager
def signals_deferred():
    """Hold SIGINT and SIGTERM back while the block runs, then deliver them: the few renames
    that commit a set of outputs finish once begun, so an interrupt there leaves the new set
    whole instead of new files beside the old record; a writer's threads are waited for, so
    none writes into a folder already cleaned. Outside the main thread (where Python
    cannot catch signals) the block runs as it is.

    Examples
    --------
    >>> import os
    >>> try:
    ...     with signals_deferred():
    ...         os.kill(os.getpid(), signal.SIGINT)
    ...         done = True  # the block goes on to its end
    ... except KeyboardInterrupt:
    ...     print("interrupted after the block:", done)
    interrupted after the block: True
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    pending = []
    previous = {sig: signal.signal(sig, lambda number, frame: pending.append(number)) for sig in DEFERRED_SIGNALS}
    try:
        yield
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
        for sig in dict.fromkeys(pending):
            signal.raise_signal(sig)


def tree_query(tree, points, k: int = 1, **options):
    """``tree.query(points, k, **options)`` of a SciPy KD-tree on the machine's cores, with
    an interrupt held back until the query is done.

    SciPy splits a query with ``workers`` over threads of its own and waits for them. A
    Ctrl-C raised in that wait unwound the caller and freed the arrays the threads were
    still writing: the process died of a segmentation fault (exit -11) in about a third of
    the interrupts during the Lastoni half's normals, after or instead of saying how it
    ended. The largest query here takes a second or two, so the interrupt waits for it.

    Examples
    --------
    >>> from scipy.spatial import cKDTree
    >>> import numpy as np
    >>> points = np.arange(12.0).reshape(4, 3)
    >>> distance, index = tree_query(cKDTree(points), points[:2], k=2)
    >>> index.tolist()
    [[0, 1], [1, 0]]
    """
    with signals_deferred():
        return tree.query(points, k, workers=available_cores(), **options)


@contextmanager
def finished_pool(workers: int):
    """A thread pool left only once its threads are done, even on an interrupt: the pool's
    own exit waits, but a Ctrl-C during that wait left its threads writing into the output
    folder's staging after the folder had cleaned it (:func:`signals_deferred`).

    Examples
    --------
    >>> with finished_pool(2) as pool:
    ...     futures = [pool.submit(pow, 2, n) for n in range(4)]
    >>> [f.result() for f in futures]
    [1, 2, 4, 8]
    """
    pool = _WaitedPool(workers)
    try:
        yield pool
    finally:
        interrupt = None
        while True:
            try:
                with signals_deferred():
                    pool.shutdown(wait=True)
                break
            except KeyboardInterrupt as exc:  # landed as the deferral began, before the wait
                interrupt = exc
        if interrupt is not None:
            raise interrupt


class _WaitedPool(ThreadPoolExecutor):
    """A thread pool whose ``submit`` holds an interrupt back until it returns: one landing
    inside it, after the pool started a thread but before it counted it, left a thread its
    shutdown did not wait for (under load, about once in sixty Ctrl-Cs at the first rename of
    ``measure``: that thread's regions.laz reached the staging after the folder had cleaned it)."""

    def submit(self, fn, /, *args, **kwargs):
        with signals_deferred():
            return super().submit(fn, *args, **kwargs)
