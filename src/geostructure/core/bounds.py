"""Per-column minimum and maximum of point arrays, fast.

``points.min(axis=0)`` on a C-ordered (N, 3) array runs numpy's inner loop over three
elements at a time: at 8M points it took 0.15 s, and a measure took some 180 such bounds
(4 s in all). Viewed as rows of ``3 k`` values the same reduction runs on long contiguous
rows, then folds the ``k`` partial results: 0.016 s, and the same values exactly.
"""

from __future__ import annotations

import numpy as np

#: Rows folded into one long row.
FOLD = 1024


def _reduce(a: np.ndarray, ufunc) -> np.ndarray:
    a = np.asarray(a)
    if a.ndim != 2 or len(a) < 2 * FOLD or not a.flags.c_contiguous:
        return ufunc.reduce(a, axis=0)
    n, c = len(a), a.shape[1]
    whole = n // FOLD * FOLD
    folded = ufunc.reduce(ufunc.reduce(a[:whole].reshape(-1, c * FOLD), axis=0).reshape(FOLD, c), axis=0)
    return folded if whole == n else ufunc(folded, ufunc.reduce(a[whole:], axis=0))


def column_min(a: np.ndarray) -> np.ndarray:
    """``a.min(axis=0)`` of a 2-D array, by folding rows (see the module's description).

    Examples
    --------
    >>> a = np.random.default_rng(0).random((5000, 3))
    >>> bool((column_min(a) == a.min(axis=0)).all())
    True
    """
    return _reduce(a, np.minimum)


def column_max(a: np.ndarray) -> np.ndarray:
    """``a.max(axis=0)`` of a 2-D array, by folding rows (see the module's description).

    Examples
    --------
    >>> a = np.random.default_rng(0).integers(-9, 9, (5001, 3))
    >>> bool((column_max(a) == a.max(axis=0)).all())
    True
    """
    return _reduce(a, np.maximum)


def first_bad_coordinates(points: np.ndarray, limit: float, offset=None) -> tuple[str, int, int] | None:
    """What is wrong with ``points`` (N, 3; relative to ``offset`` (3,) when given), from
    their bounds first (no copy of the cloud; NaN and inf reach them), the rows read only to
    name one: ``("not finite", count, first row)``, ``("too far", count, first row)`` for a
    coordinate beyond ``limit``, or None. The checks of a file's points and of a cloud before
    measuring word it each their own way.

    Examples
    --------
    >>> first_bad_coordinates(np.array([[0.0, 1, 2], [3, np.nan, 5], [np.inf, 0, 0]]), 1e9)
    ('not finite', 2, 1)
    >>> first_bad_coordinates(np.array([[0.0, 1, 2], [3, 4, 2e9]]), 1e9)
    ('too far', 1, 1)
    >>> first_bad_coordinates(np.zeros((4, 3)), 1e9) is None
    True
    """
    if not len(points):
        return None
    shift = np.zeros(3) if offset is None else np.asarray(offset, dtype=np.float64)
    lower, upper = column_min(points) + shift, column_max(points) + shift
    if not (np.isfinite(lower).all() and np.isfinite(upper).all()):
        bad = ~np.isfinite(points).all(axis=1)
        return "not finite", int(bad.sum()), int(np.flatnonzero(bad)[0])
    if max(float(np.abs(lower).max()), float(np.abs(upper).max())) > limit:
        far = np.abs(points + shift).max(axis=1) > limit
        return "too far", int(far.sum()), int(np.flatnonzero(far)[0])
    return None
