"""The paper's four experiments: vary one factor, hold the others, record time and z(R).

Runs of one sweep are independent, so they go to a process pool (``workers``); on a
2-core machine two runs share the cores, which slows each a little. Use ``workers=1`` when
the timings themselves matter more than the wall clock.
"""

from __future__ import annotations

import math
import multiprocessing
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import asdict, dataclass
from functools import partial

import numpy as np

from geostructure.core.params import TABLE1, Params
from geostructure.detect.pipeline import measure
from geostructure.errors import ParameterError
from geostructure.evaluation.groundtruth import evaluate
from geostructure.io.atomic import write_figure

FACTORS = ("zeta", "theta", "psi", "k")
#: Runs of one factor at most: a sweep is a plot, and a mistyped step must not run for days.
MAX_RUNS = 500


@dataclass
class SweepRow:
    factor: str
    value: float
    regions_s: float
    total_s: float
    z: float
    z_wrapped: float
    mean_error_deg: float
    found: int
    missed: int
    planes: int


def factor_values(factor: str, start=None, end=None, step=None) -> np.ndarray:
    """Values of one factor, from the paper's Table 1 unless given; ``end`` is included."""
    if factor not in TABLE1:
        raise ParameterError(f"unknown factor '{factor}'; use one of {', '.join(FACTORS)} or all.")
    lo, hi, st = TABLE1[factor]
    start, end, step = (lo if start is None else start), (hi if end is None else end), (st if step is None else step)
    if not all(np.isfinite(v) for v in (start, end, step)):
        raise ParameterError(f"start, end and step must be finite numbers, got {start}, {end}, {step}.")
    if step <= 0 or end < start:
        raise ParameterError(f"start, end and step must give a rising range, got {start}, {end}, {step}.")
    runs = math.floor((end - start) / step + 1e-6) + 1
    if runs > MAX_RUNS:
        raise ParameterError(
            f"{factor} from {start} to {end} in steps of {step} makes {runs:,} runs; "
            f"at most {MAX_RUNS} are allowed, so take a larger step."
        )
    values = np.arange(start, end + step * 1e-6, step)
    return np.round(values).astype(int) if factor == "k" else np.round(values, 6)


def params_for(base: Params, factor: str, value) -> Params:
    """``base`` with one factor changed, without the out-of-range warning (a sweep walks the
    paper's ranges on purpose)."""
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the sweep walks the paper's ranges on purpose
        return base.with_(**{factor: int(value) if factor == "k" else float(value)})


def run_one(task, cloud, truth, frame) -> SweepRow:
    factor, value, params = task
    t = time.perf_counter()
    result = measure(cloud, params, frame)
    total = time.perf_counter() - t
    ev = evaluate(result.planes, truth)
    return SweepRow(
        factor,
        float(value),
        result.seconds["regions"],
        total,
        ev.z,
        ev.z_wrapped,
        ev.mean_error,
        ev.n_found,
        ev.n_missed,
        len(result),
    )


def run_sweep(
    cloud, truth, frame, factors, base: Params = Params(), *, ranges=None, workers: int = 2, progress=None
) -> list[SweepRow]:
    """Run the experiments for ``factors`` and return one row per run, in order.

    ``ranges`` maps a factor to ``(start, end, step)`` (None entries take Table 1's).
    ``progress(stage, done, total)`` is called as runs finish. The factors are the voxel
    method's, so every run uses ``detector="voxel"`` (the paper's method).
    """
    ranges = ranges or {}
    base = base.with_(detector="voxel")
    tasks = [(f, v, params_for(base, f, v)) for f in factors for v in factor_values(f, *ranges.get(f, (None,) * 3))]
    job = partial(run_one, cloud=cloud, truth=truth, frame=frame)
    report = progress or (lambda *a: None)
    report("sweep", 0, len(tasks))
    if workers <= 1:
        rows = []
        for i, task in enumerate(tasks, start=1):
            rows.append(job(task))
            report("sweep", i, len(tasks))
        return rows
    context = multiprocessing.get_context("fork" if "fork" in multiprocessing.get_all_start_methods() else "spawn")
    with ProcessPoolExecutor(max_workers=workers, mp_context=context) as pool:
        rows = []
        for i, row in enumerate(pool.map(job, tasks), start=1):
            rows.append(row)
            report("sweep", i, len(tasks))
    return rows


def rows_as_dicts(rows: list[SweepRow]) -> list[dict]:
    return [asdict(r) for r in rows]


def plot_sweep(rows: list[SweepRow], stem) -> list:
    """The paper's figure: per factor, time on top (region growing, total) and z(R) below.

    Writes ``stem.png`` and ``stem.svg``; returns the paths.
    """
    from matplotlib.figure import Figure  # a Figure of its own: the caller's pyplot backend is left alone

    factors = [f for f in FACTORS if any(r.factor == f for r in rows)]
    labels = {
        "zeta": "ζ (voxel size factor)",
        "theta": "θ (angle threshold, °)",
        "psi": "ψ (offset, voxel edges)",
        "k": "k (neighbours)",
    }
    fig = Figure(figsize=(4.2 * len(factors), 6.4))
    axes = fig.subplots(2, len(factors), squeeze=False, sharex="col")
    for col, factor in enumerate(factors):
        sel = [r for r in rows if r.factor == factor]
        x = [r.value for r in sel]
        top, bottom = axes[0, col], axes[1, col]
        top.plot(x, [r.regions_s for r in sel], "o-", color="tab:red", label="region growing")
        top.plot(x, [r.total_s for r in sel], "s-", color="tab:blue", label="total")
        top.set_ylabel("time (s)")
        top.set_title(f"{factor} v time")
        bottom.plot(x, [r.z for r in sel], "o-", color="black", label="z(R) as printed")
        bottom.plot(x, [r.z_wrapped for r in sel], "--", color="tab:green", label="z(R) wrap-aware")
        missed = [(r.value, r.z) for r in sel if r.missed]
        if missed:
            bottom.plot(*zip(*missed), "x", color="tab:red", markersize=9, label="surfaces missed")
        bottom.set_ylabel("z(R) (lower is better)")
        bottom.set_xlabel(labels[factor])
        bottom.set_title(f"{factor} v z(R)")
        bottom.set_ylim(bottom=0)
        for ax in (top, bottom):
            ax.grid(alpha=0.3)
        if col == 0:
            top.legend(fontsize=8)
            bottom.legend(fontsize=8)
    fig.tight_layout()
    return write_figure(fig, stem, dpi=120)
