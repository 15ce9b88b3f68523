"""Where a pass's chunks are worked: one after another in this process, or as tasks on a
``dask.distributed`` cluster. Both give the chunks' results in chunk order."""

from __future__ import annotations

import os
import threading
import warnings

from geostructure.errors import GeoStructureError, GeoStructureNote, ParameterError

#: Chunks in flight at once on a cluster, per worker: enough to keep each busy, few enough
#: that results waiting to be added stay small.
IN_FLIGHT_PER_WORKER = 2
#: Times a pass's context is scattered to the workers again after all that held it died.
MAX_SCATTERS = 3


class SerialExecutor:
    """Each chunk in turn, here: the stream engine's executor by default.

    Examples
    --------
    >>> list(SerialExecutor().map(lambda chunk, context: chunk * context, [1, 2, 3], 10))
    [10, 20, 30]
    """

    name = "stream"

    def map(self, fn, chunks, context):
        for chunk in chunks:
            yield fn(chunk, context)

    def close(self) -> None:
        pass


class DaskExecutor:
    """Each chunk as a task on a ``dask.distributed`` cluster: the scheduler at ``address``, or
    a ``LocalCluster`` of ``workers`` processes started here. Workers read the spill file,
    so on a real cluster it must lie on a disk they share (``--spill-dir``).

    A worker that dies (out of memory, its machine lost) has its tasks run again by Dask on
    the others or on the one its nanny starts again (up to Dask's
    ``distributed.scheduler.allowed-failures`` times a task), and the run says so in a note;
    a task that kills every worker it is given ends the run with an error that says so.

    Parameters
    ----------
    address : str, optional
        A running scheduler (``tcp://HOST:PORT``), asked at once; None: a local cluster.
    workers : int, optional
        The local cluster's worker processes (default 2).
    background : bool
        Start the local cluster in a thread (some 3 s) while the caller reads the survey.

    Examples
    --------
    >>> executor = DaskExecutor(workers=1)  # doctest: +SKIP
    >>> list(executor.map(lambda chunk, context: chunk + context, [1, 2], 1))  # doctest: +SKIP
    [2, 3]
    >>> executor.close()  # doctest: +SKIP
    >>> DaskExecutor.name
    'dask'
    """

    name = "dask"

    def __init__(self, address: str | None = None, workers: int | None = None, background: bool = False):
        try:
            from distributed import Client
        except ImportError:
            raise GeoStructureError("--engine dask needs dask.distributed: pip install 'geostructure[dask]'.") from None
        self._cluster, self._scratch, self._client, self._starting, self._failure = None, None, None, None, None
        #: The workers as a pass starts (to tell the ones it lost), and how many there were.
        self._workers, self.n_workers = set(), 0
        #: Workers that left the cluster while a pass ran, over the whole run.
        self.workers_lost = 0
        if address:  # a scheduler is asked at once: one that does not answer is refused before any work
            try:
                self._client = Client(address, timeout="10s")
            except (OSError, TimeoutError) as error:
                raise ParameterError(f"{address}: no Dask scheduler answers there ({error}).") from None
            self._ready()
            return
        # The workers' scratch space in a folder of this run's, removed on close: Dask's
        # default, dask-scratch-space in the temporary folder, outlived every run.
        import tempfile

        from geostructure.stream.source import DASK_SCRATCH_PREFIX, remove_stale_spills  # lazy: local clusters only

        remove_stale_spills(prefix=DASK_SCRATCH_PREFIX)  # a killed run's: it could not remove its own
        self._scratch = tempfile.mkdtemp(prefix=f"{DASK_SCRATCH_PREFIX}{os.getpid()}-")
        self._starting = threading.Thread(target=self._start_local, args=(workers,), daemon=True)
        if background:  # its start (some 3 s) while this process reads the survey
            self._starting.start()
            return
        from geostructure.core.threads import signals_deferred  # lazy: local clusters only

        # A cluster interrupted in its start was left half made, for distributed's exit hook
        # to trip on: the start finishes, then the interrupt comes, and the cluster is closed.
        try:
            with signals_deferred():
                self._starting.start()
                self._ready()
        except BaseException:
            self.close()
            raise

    def _start_local(self, workers: int | None) -> None:
        import dask
        from distributed import Client, LocalCluster

        try:
            with dask.config.set({"temporary-directory": self._scratch}):
                self._cluster = LocalCluster(
                    n_workers=workers or 2,
                    threads_per_worker=1,
                    processes=True,
                    dashboard_address=None,
                    local_directory=self._scratch,
                )
                self._client = Client(self._cluster)
        except Exception as error:  # raised where the cluster is first needed
            self._failure = error

    def _ready(self) -> None:
        """Wait for a cluster started in the background; raise its failure to start."""
        if self._starting is not None:
            self._starting.join()
            self._starting = None
        if self._failure is not None:
            failure, self._failure = self._failure, None
            raise GeoStructureError(f"the local Dask cluster did not start ({failure}).")
        if self._client is not None and not self.n_workers:
            self.n_workers = max(1, len(self._client.scheduler_info()["workers"]))

    @property
    def client(self):
        """The cluster's client, once the cluster has started."""
        self._ready()
        return self._client

    def map(self, fn, chunks, context):
        from collections import deque
        from concurrent.futures import CancelledError

        from distributed import KilledWorker

        self._workers = set(self.client.scheduler_info()["workers"])  # as the pass starts
        shared, scattered = self._scatter(context), 1
        waiting, queue = deque(chunks), deque()
        window = IN_FLIGHT_PER_WORKER * self.n_workers
        while waiting or queue:
            while waiting and len(queue) < window:
                chunk = waiting.popleft()
                queue.append((chunk, self.client.submit(fn, chunk, shared, pure=False)))
            chunk, future = queue.popleft()
            try:
                result = future.result()
            except (KilledWorker, CancelledError):
                # Given up (the workers that ran it died in turn), or cancelled: every worker
                # that held the scattered context died at once, and it is data, not a task
                # Dask can run again. Scatter it again and send the chunks again, a few times.
                if scattered > MAX_SCATTERS:
                    raise GeoStructureError(
                        "a task of the run's was given up after the Dask workers that ran it died in turn: a "
                        "worker may have too little memory for a chunk or a tile; give the workers more."
                    ) from None
                again = [chunk, *(c for c, _ in queue)]
                for _, pending in queue:
                    pending.release()
                queue.clear()
                waiting.extendleft(reversed(again))
                shared, scattered = self._scatter(context), scattered + 1
                continue
            future.release()
            yield result
        self._note_lost_workers()

    def _scatter(self, context):
        # One future for the whole context (a tuple would be scattered element by element),
        # not keyed by its content: two passes with equal contexts must not share one.
        [shared] = self.client.scatter([context], broadcast=True, hash=False)
        return shared

    def _note_lost_workers(self) -> None:
        """Say so when workers left the cluster during the pass: their tasks were run again."""
        now = set(self.client.scheduler_info()["workers"])
        lost = len(self._workers - now)
        self._workers = now
        if lost:
            self.workers_lost += lost
            warnings.warn(
                f"{lost} Dask worker{'s' if lost > 1 else ''} died or left during the run; Dask ran "
                f"{'their' if lost > 1 else 'its'} tasks again, so the result is whole.",
                GeoStructureNote,
                stacklevel=2,
            )

    def close(self) -> None:
        import logging
        import shutil

        from geostructure.core.threads import signals_deferred  # lazy: closing a local cluster only

        # An interrupt while the cluster started left it half made: closing it tripped an
        # assertion of distributed's, and its exit hook printed the traceback and its log
        # lines after our one sentence. The close runs to its end, quietly.
        logging.getLogger("distributed").setLevel(logging.CRITICAL)
        with signals_deferred():
            try:
                if self._starting is not None:  # closed before it was needed: wait for its start
                    self._starting.join()
                if self._client is not None:
                    self._client.close()
                if self._cluster is not None:
                    try:
                        self._cluster.close()
                    except Exception:  # a worker still starting: the processes are stopped below
                        _forget_cluster(self._cluster)
                    _stop_resource_tracker()
            finally:
                if self._scratch is not None:
                    shutil.rmtree(self._scratch, ignore_errors=True)


def _forget_cluster(cluster) -> None:
    """Take a cluster that failed to close out of distributed's exit hook's list (it would
    try again at exit, and print its traceback), stopping its processes as they stand."""
    from distributed.deploy.spec import SpecCluster

    for worker in list(getattr(cluster, "workers", {}).values()):
        process = getattr(getattr(worker, "process", None), "process", None)
        if process is not None and hasattr(process, "kill"):
            try:
                process.kill()
            except Exception:  # already gone
                pass
    instances = getattr(SpecCluster, "_instances", None)  # private: absent, left to distributed
    if instances is not None:
        instances.discard(cluster)


def _stop_resource_tracker() -> None:
    """Stop and reap the process Python starts beside the local cluster's workers to clean up
    after them: it would otherwise outlive the command by a moment (it exits when it sees
    this process gone), a process left behind for whoever lists them. Started again if
    anything here needs it later."""
    from multiprocessing import resource_tracker

    stop = getattr(resource_tracker._resource_tracker, "_stop", None)  # private: absent, left as it is
    if stop is not None:
        stop()
