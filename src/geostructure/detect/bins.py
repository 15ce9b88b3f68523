"""Medians and percentiles of values too many to hold, read from counts in fine bins that
add over tiles (docs/tiles.md): angles in :data:`ANGLE_BIN` degrees from 0 to 90, positive
values (residuals, variations) in :data:`LOG_BIN` of a decade from 1e-12 to 1e3. A median so
read is within half a bin of the exact one.
"""

from __future__ import annotations

import numpy as np

#: An angle bin (degrees).
ANGLE_BIN = 1e-4
ANGLE_BINS = int(round(90.0 / ANGLE_BIN)) + 1
#: A bin of a positive value: this fraction of a decade, over LOG_DECADES.
LOG_BIN = 1e-4
LOG_DECADES = (-12.0, 3.0)
LOG_BINS = int(round((LOG_DECADES[1] - LOG_DECADES[0]) / LOG_BIN)) + 1


def angle_counts(angle_deg: np.ndarray) -> np.ndarray:
    """Counts of ``angle_deg`` in the angle bins (:data:`ANGLE_BINS`,)."""
    index = np.minimum((np.asarray(angle_deg, dtype=np.float64) / ANGLE_BIN).astype(np.int64), ANGLE_BINS - 1)
    return np.bincount(index, minlength=ANGLE_BINS)


def log_counts(values: np.ndarray) -> np.ndarray:
    """Counts of positive ``values`` in the log bins (:data:`LOG_BINS`,)."""
    low = LOG_DECADES[0]
    scaled = (np.log10(np.maximum(np.asarray(values, dtype=np.float64), 10.0**low)) - low) / LOG_BIN
    return np.bincount(np.clip(scaled.astype(np.int64), 0, LOG_BINS - 1), minlength=LOG_BINS)


def quantile_bin(counts: np.ndarray, q: float = 0.5) -> float:
    """The bin (a fractional index, its centre) holding the ``q`` quantile of the counted
    values, as ``np.percentile`` places it (linear, between the values at ``q (n - 1)``).

    Examples
    --------
    >>> quantile_bin(np.array([0, 3, 0, 2]))  # values 1, 1, 1, 3, 3: the median is a 1
    1.5
    """
    total = int(counts.sum())
    if not total:
        return 0.0
    rank = q * (total - 1)  # the (fractional) rank of the quantile among the sorted values
    return float(np.searchsorted(np.cumsum(counts), int(np.floor(rank)) + 1)) + 0.5


def angle_quantile(counts: np.ndarray, q: float = 0.5) -> float:
    """The ``q`` quantile (degrees) of the angles counted by :func:`angle_counts`."""
    return quantile_bin(counts, q) * ANGLE_BIN


def log_quantile(counts: np.ndarray, q: float = 0.5) -> float:
    """The ``q`` quantile of the values counted by :func:`log_counts`."""
    return float(10.0 ** (LOG_DECADES[0] + quantile_bin(counts, q) * LOG_BIN))
