"""Progress on stderr for the command line; the library itself only calls a callback."""

from __future__ import annotations

import time

from rich.console import Console
from rich.progress import (
    BarColumn,
    MofNCompleteColumn,
    Progress,
    SpinnerColumn,
    TextColumn,
    TimeElapsedColumn,
    TimeRemainingColumn,
)

LABELS = {
    "read": "Reading",
    "auto": "Choosing parameters",
    "filter": "Mahalanobis filter",
    "voxel": "Voxel fit",
    "regions": "Region growing",
    "planes": "Region planes",
    "orientation": "Orientation",
    "write": "Writing",
    "stream": "Streamed passes",
    "thin": "Thinning",
    "label": "Labelling points",
    "keep": "The filter on every point",
    "route": "Cutting into tiles",
    "tiles": "Facets in tiles",
    "sets": "Joint sets",
    "spacing and persistence": "Spacing and persistence",
    "traces": "Fracture traces",
}


class StageProgress:
    """``progress(stage, done, total)`` callback that draws one bar per stage with rich.

    Use as a context manager; with ``enabled=False`` (``--quiet``) it draws nothing.
    """

    def __init__(self, enabled: bool = True, console: Console | None = None):
        self.console = console or Console(stderr=True)
        self.enabled = enabled and self.console.is_terminal
        self._progress = Progress(
            SpinnerColumn(),
            TextColumn("{task.description:<20}"),
            BarColumn(),
            MofNCompleteColumn(),
            TimeElapsedColumn(),
            TimeRemainingColumn(),  # the time left: a streamed survey's passes take minutes
            console=self.console,
            disable=not self.enabled,
        )
        self._tasks: dict[str, int] = {}
        self._current: str | None = None
        self._started = time.perf_counter()

    def __enter__(self):
        self._progress.__enter__()
        return self

    def __exit__(self, *exc):
        self._finish_current()
        self._progress.__exit__(*exc)
        return False

    def __call__(self, stage: str, done: int, total: int | None) -> None:
        if stage != self._current:
            self._finish_current()
            self._current = stage
            self._tasks[stage] = self._progress.add_task(LABELS.get(stage, stage), total=total)
        self._progress.update(self._tasks[stage], completed=done, total=total)

    def _finish_current(self):
        if self._current is not None:
            task = self._tasks[self._current]
            total = self._progress.tasks[task].total or 1
            self._progress.update(task, total=total, completed=total)
