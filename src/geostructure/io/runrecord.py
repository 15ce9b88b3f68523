"""The values of a run record (``run.json``) checked as any input's.

An output folder is a user's file: its ``run.json`` can be edited and resealed, or lose
its seal. Each value a later command reads (the offset its positions are relative to, the
frame, the unit, the parameters) is checked here, once, where the folder is opened
(:func:`~geostructure.io.outdir.verified_record`), so that no reader fails on it later
with a traceback: an offset of text gave "could not convert string to float", a huge one
StopIteration, the parameters as a list "'list' object has no attribute 'get'".
"""

from __future__ import annotations

import math
import numbers

from geostructure.core.cloud import MAX_COORDINATE
from geostructure.errors import OutputError


def _number(value, bound: float) -> bool:
    return (
        isinstance(value, numbers.Real) and not isinstance(value, bool) and math.isfinite(value) and abs(value) <= bound
    )


def _vector(value, n: int, bound: float) -> bool:
    return isinstance(value, list) and len(value) == n and all(_number(v, bound) for v in value)


def record_problem(record: dict) -> str | None:
    """What is wrong with a run record's values, in words, or None.

    Examples
    --------
    >>> good = {"frame": {"rotation": [[1, 0, 0], [0, 1, 0], [0, 0, 1]]}, "offset": [5e5, 5e6, 300.0]}
    >>> record_problem(good) is None
    True
    >>> record_problem({**good, "offset": ["a", 0, 0]})
    'its offset is not three coordinates'
    >>> record_problem({**good, "params": [1, 2]})
    'its params are not a table of parameters'
    """
    frame = record.get("frame")
    rotation = frame.get("rotation") if isinstance(frame, dict) else None
    if "frame" in record and not (
        isinstance(rotation, list) and len(rotation) == 3 and all(_vector(r, 3, 1.0 + 1e-6) for r in rotation)
    ):
        return "its frame is not a rotation (three rows of three numbers)"
    if "offset" in record and not _vector(record["offset"], 3, MAX_COORDINATE):
        return "its offset is not three coordinates"
    for key in ("params", "counts", "auto", "unit", "north"):
        if record.get(key) is not None and not isinstance(record[key], dict):
            return f"its {key} are not a table of parameters" if key == "params" else f"its {key} is not a table"
    unit = record.get("unit")
    if isinstance(unit, dict):
        if not (_number(unit.get("metres"), 1e6) and unit["metres"] > 0) or not isinstance(unit.get("symbol"), str):
            return "its unit is not a length unit (a symbol and its length in metres)"
    if record.get("crs") is not None and not isinstance(record["crs"], str):
        return "its crs is not a text"
    return None


def check_run_record(record: dict, path, command: str) -> None:
    """Refuse ``run.json`` (at ``path``) whose values no run writes (:func:`record_problem`)."""
    problem = record_problem(record)
    if problem is not None:
        raise OutputError(f"{path}: {problem}, so the folder was edited or damaged; run '{command}' again.")
