"""Ground-truth CSV: what a geologist measured with a compass, one row per surface.

Columns (header required, any order, case-insensitive)::

    surface, strike, dip, dip_direction[, center_x, center_y, center_z][, normal_x, normal_y, normal_z]

Any two of strike, dip and dip direction suffice. Dip may carry its quadrant as in the
paper (``89(E)``, ``40 SE``); with strike and a quadrant, the dip direction is the one of
strike +- 90 that points into the quadrant. A row may instead give only a normal. When a
row gives angles and a normal that disagree by more than 2 degrees, the angles win and
a warning names the surface.
"""

from __future__ import annotations

import re
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from geostructure.core.cloud import MAX_COORDINATE
from geostructure.core.orientation import (
    Frame,
    angle_between_normals,
    azimuth_difference,
    normal_from_orientation,
    orientation_from_normals,
)
from geostructure.errors import GeoStructureWarning, InputError
from geostructure.io.usercsv import read_user_rows

QUADRANTS = {
    "N": 0,
    "NNE": 22.5,
    "NE": 45,
    "ENE": 67.5,
    "E": 90,
    "ESE": 112.5,
    "SE": 135,
    "SSE": 157.5,
    "S": 180,
    "SSW": 202.5,
    "SW": 225,
    "WSW": 247.5,
    "W": 270,
    "WNW": 292.5,
    "NW": 315,
    "NNW": 337.5,
}
_DIP = re.compile(r"^\s*([+-]?\d+(?:\.\d*)?)\s*\(?\s*([NSEW]{0,3})\s*\)?\s*$", re.I)


class TruthWarning(GeoStructureWarning):
    """A ground-truth row is inconsistent with itself."""


@dataclass
class GroundTruth:
    """Surfaces with dip, dip direction (degrees, in ``frame``), normals (cloud axes) and
    optional centres (absolute cloud coordinates; NaN where not given)."""

    names: list[str]
    dip: np.ndarray
    dip_direction: np.ndarray
    normals: np.ndarray
    centres: np.ndarray

    @property
    def strike(self) -> np.ndarray:
        return (self.dip_direction - 90.0) % 360.0

    @property
    def has_centres(self) -> np.ndarray:
        return np.isfinite(self.centres).all(axis=1)

    def __len__(self) -> int:
        return len(self.names)


def parse_dip(text: str, path, line: int) -> tuple[float, str]:
    """``"89(E)"`` -> (89.0, "E"); ``"40"`` -> (40.0, "")."""
    match = _DIP.match(text)
    if not match or (match.group(2) and match.group(2).upper() not in QUADRANTS):
        raise InputError(f"{path}: line {line}: dip '{text}' is not a number with an optional quadrant like 89(E).")
    dip = float(match.group(1))
    if not 0 <= dip <= 90:
        raise InputError(f"{path}: line {line}: dip {dip} is outside 0 to 90 degrees.")
    return dip, match.group(2).upper()


def dip_direction_from_strike(strike: float, quadrant: str) -> float:
    """Right-hand rule (strike + 90), unless the quadrant points the other way."""
    dd = (strike + 90.0) % 360.0
    if quadrant and azimuth_difference(dd, QUADRANTS[quadrant]) > 90:
        dd = (strike - 90.0) % 360.0
    return dd


#: The most surfaces a ground-truth file may hold: the one-to-one matching grows faster than
#: their number (10,000 took 5.5 s, 40,000 31 s, a million ran past minutes).
MAX_SURFACES = 10_000


def read_truth(path, frame: Frame = Frame()) -> GroundTruth:
    """Read a ground-truth CSV (see the module docstring) into :class:`GroundTruth`.

    Parameters
    ----------
    path : str or Path
        The CSV: a header, then one row per surface (``surface``, any two of ``strike``,
        ``dip``, ``dip_direction``, optionally ``center_x``, ``center_y``, ``center_z``).
    frame : Frame
        The cloud's frame: the surfaces' normals are written in its axes.

    Returns
    -------
    GroundTruth
        The surfaces' names, orientations, normals and centres (NaN where not given).

    Raises
    ------
    InputError
        No such file, not a text CSV, a row that is not a surface, more than
        :data:`MAX_SURFACES` surfaces.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "truth.csv"
    >>> _ = path.write_text("surface,dip,dip_direction\\nwall,89,090\\nroof,30,180\\n")
    >>> truth = read_truth(path)
    >>> truth.names, truth.dip.tolist()
    (['wall', 'roof'], [89.0, 30.0])
    """
    path = Path(path)
    rows = read_user_rows(path, "ground-truth")
    rows = [
        (i, r) for i, r in enumerate(rows, start=1) if any(c.strip() for c in r) and not r[0].lstrip().startswith("#")
    ]
    if len(rows) < 2:
        raise InputError(f"{path}: needs a header row and at least one surface.")
    if len(rows) - 1 > MAX_SURFACES:
        raise InputError(
            f"{path}: {len(rows) - 1:,} surfaces is more than a ground truth measured by hand holds (at most "
            f"{MAX_SURFACES:,}: each is matched one to one); score a map of many fractures with --fractures."
        )
    header = [c.strip().lower() for c in rows[0][1]]
    repeated = sorted({h for h in header if h and header.count(h) > 1})
    if repeated:
        raise InputError(f"{path}: the header names column '{repeated[0]}' more than once; keep one.")
    if "surface" not in header:
        raise InputError(f"{path}: the header has no 'surface' column.")
    # The centre as center_x, center_y, center_z, or as x, y, z where those are not given (the
    # field map's names: a truth written so had its centres passed over without a word).
    centre_keys = [f"center_{a}" for a in "xyz"]
    if not any(key in header for key in centre_keys) and all(a in header for a in "xyz"):
        centre_keys = list("xyz")
    names, dips, dds, normals, centres = [], [], [], [], []
    for line, row in rows[1:]:
        cell = {h: (row[i].strip() if i < len(row) else "") for i, h in enumerate(header)}
        name = cell["surface"] or f"row {line}"
        dip, dd, normal = _row_orientation(cell, frame, path, line, name)
        names.append(name)
        dips.append(dip)
        dds.append(dd)
        normals.append(normal)
        centres.append([_number(cell, key, path, line) for key in centre_keys])
    return GroundTruth(names, np.array(dips), np.array(dds), np.array(normals), np.array(centres, dtype=np.float64))


def _number(cell: dict, key: str, path, line: int) -> float:
    text = cell.get(key, "")
    if not text:
        return float("nan")
    try:
        value = float(text)
    except ValueError:
        raise InputError(f"{path}: line {line}: {key} '{text}' is not a number.") from None
    if not np.isfinite(value):
        raise InputError(f"{path}: line {line}: {key} '{text}' is not a finite number.")
    bound = next((b for prefix, b in TRUTH_LIMITS.items() if key == prefix or key.startswith(f"{prefix}_")), None)
    if bound is not None and abs(value) > bound[0]:
        raise InputError(f"{path}: line {line}: {key} {text} is no {bound[1]} (at most {bound[0]:g} either way).")
    return value


#: How far each number of a truth row may go either way: an azimuth is degrees (a dip
#: direction of 1e308 was read, and scored), a centre a coordinate no survey exceeds (one
#: at 1e308 made the matching's costs infinite and stopped it with a traceback).
TRUTH_LIMITS = {"strike": (360.0, "strike"), "dip_direction": (360.0, "dip"), "center": (MAX_COORDINATE, "center"),
                "x": (MAX_COORDINATE, "center"), "y": (MAX_COORDINATE, "center"), "z": (MAX_COORDINATE, "center"),
                "normal": (1e6, "normal")}  # fmt: skip


def _row_orientation(cell, frame, path, line, name):
    strike = _number(cell, "strike", path, line)
    dd = _number(cell, "dip_direction", path, line)
    dip, quadrant = parse_dip(cell["dip"], path, line) if cell.get("dip") else (float("nan"), "")
    n = np.array([_number(cell, f"normal_{a}", path, line) for a in "xyz"])
    has_normal = np.isfinite(n).all() and np.linalg.norm(n) > 0
    if np.isnan(dd) and not np.isnan(strike):
        dd = dip_direction_from_strike(strike, quadrant)
    if np.isnan(dd) or np.isnan(dip):
        if not has_normal:
            raise InputError(
                f"{path}: line {line}: surface '{name}' needs two of strike, dip and dip direction, or a normal."
            )
        o = orientation_from_normals(n, frame)
        dip = o.dip[0] if np.isnan(dip) else dip
        dd = o.dip_direction[0] if np.isnan(dd) else dd
    if not np.isnan(strike) and azimuth_difference(dd, strike + 90) > 2 and azimuth_difference(dd, strike - 90) > 2:
        warnings.warn(
            f"{path.name}: surface '{name}': strike {strike:g} and dip direction {dd:g} are not 90 degrees "
            f"apart; using the dip direction.",
            TruthWarning,
            stacklevel=4,
        )
    normal = normal_from_orientation(dd, dip, frame)
    if has_normal:
        off = float(angle_between_normals(n, normal)[0])
        if off > 2:
            warnings.warn(
                f"{path.name}: surface '{name}': its normal is {off:.1f} degrees from its strike/dip "
                f"(dip direction {dd:g}, dip {dip:g}); using the angles.",
                TruthWarning,
                stacklevel=4,
            )
    return float(dip), float(dd % 360.0), normal
