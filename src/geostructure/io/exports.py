"""Exports for other tools: the Dips/Stereonet CSV (the GIS files: :mod:`.gis`)."""

from __future__ import annotations

from pathlib import Path

from .atomic import write_table_csv


def write_dips_csv(planes, path) -> Path:
    """``planes_dips.csv``: Dip Direction, Dip first (the layout Rocscience Dips and
    Allmendinger's Stereonet import), then the region id and its point count, and its joint
    set (-1 for none) when the planes have one."""
    columns = ["Dip Direction", "Dip", "Region", "Points"]
    values = [
        [round(v, 2) for v in planes.dip_direction.tolist()],
        [round(v, 2) for v in planes.dip.tolist()],
        planes.region_id.tolist(),
        planes.n_points.tolist(),
    ]
    if "set" in planes.extra:
        columns.append("Set")
        values.append(planes.extra["set"].astype(int).tolist())
    rows = [dict(zip(columns, row)) for row in zip(*values)]
    return write_table_csv(rows, path, columns=columns)
