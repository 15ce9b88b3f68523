"""Where a pass's chunks are worked: one after another in this process, or as tasks on a
``dask.distributed`` cluster. Both give the chunks' results in chunk order."""

from __future__ import annotations

from geostructure.errors import GeoStructureError, ParameterError

#: Chunks in flight at once on a cluster, per worker: enough to keep each busy, few enough
#: that results waiting to be added stay small.
IN_FLIGHT_PER_WORKER = 2


class SerialExecutor:
    """Each chunk in turn, here."""

    name = "stream"

    def map(self, fn, chunks, context):
        for chunk in chunks:
            yield fn(chunk, context)

    def close(self) -> None:
        pass


class DaskExecutor:
    """Each chunk as a task on a ``dask.distributed`` cluster: the scheduler at ``address``, or
    a ``LocalCluster`` of ``workers`` processes started here. Workers read the spill file,
    so on a real cluster it must lie on a disk they share (``--spill-dir``)."""

    name = "dask"

    def __init__(self, address: str | None = None, workers: int | None = None):
        try:
            from distributed import Client, LocalCluster
        except ImportError:
            raise GeoStructureError("--engine dask needs dask.distributed: pip install 'geostructure[dask]'.") from None
        self._cluster, self._scratch = None, None
        if address:
            try:
                self.client = Client(address, timeout="10s")
            except (OSError, TimeoutError) as error:
                raise ParameterError(f"{address}: no Dask scheduler answers there ({error}).") from None
        else:
            # The workers' scratch space in a folder of this run's, removed on close: Dask's
            # default, dask-scratch-space in the temporary folder, outlived every run.
            import tempfile

            import dask

            self._scratch = tempfile.mkdtemp(prefix="geostructure-dask-")
            with dask.config.set({"temporary-directory": self._scratch}):
                self._cluster = LocalCluster(
                    n_workers=workers or 2,
                    threads_per_worker=1,
                    processes=True,
                    dashboard_address=None,
                    local_directory=self._scratch,
                )
                self.client = Client(self._cluster)
        self.n_workers = max(1, len(self.client.scheduler_info()["workers"]))

    def map(self, fn, chunks, context):
        from collections import deque

        # One future for the whole context (a tuple would be scattered element by element),
        # not keyed by its content: two passes with equal contexts must not share one.
        [shared] = self.client.scatter([context], broadcast=True, hash=False)
        waiting, queue = deque(chunks), deque()
        window = IN_FLIGHT_PER_WORKER * self.n_workers
        while waiting or queue:
            while waiting and len(queue) < window:
                queue.append(self.client.submit(fn, waiting.popleft(), shared, pure=False))
            future = queue.popleft()
            yield future.result()
            future.release()

    def close(self) -> None:
        import shutil

        try:
            self.client.close()
            if self._cluster is not None:
                self._cluster.close()
        finally:
            if self._scratch is not None:
                shutil.rmtree(self._scratch, ignore_errors=True)
