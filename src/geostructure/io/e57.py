"""E57 scans (pye57): every scan moved by its pose into the file's common frame."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from geostructure.core.cloud import Cloud
from geostructure.errors import InputError


def read_e57(path: Path) -> Cloud:
    """E57 (pye57): all scans, each moved by its pose into the file's common frame."""
    import pye57

    e57 = pye57.E57(str(path))
    claimed = sum(int(e57.get_header(i).point_count) for i in range(e57.scan_count))
    if claimed > 8 * path.stat().st_size:  # a point's coordinates take a bit at the least, packed
        raise InputError(
            f"{path}: its scans claim {claimed:,} points, more than its {path.stat().st_size:,} bytes can hold; "
            f"the file is damaged."
        )
    parts = []
    for i in range(e57.scan_count):
        scan = e57.read_scan(i, ignore_missing_fields=True, transform=True)
        parts.append(np.column_stack([scan["cartesianX"], scan["cartesianY"], scan["cartesianZ"]]))
    points = np.vstack(parts) if parts else np.empty((0, 3))
    return Cloud.from_points(points.astype(np.float64), source=str(path))
