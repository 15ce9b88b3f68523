"""Rock Quality Designation (RQD) from the sets' spacing, as a face survey can give it, and
ISRM (1978)'s words for the block size the volumetric joint count Jv implies.

RQD (Deere 1964) is the share of a borehole core in pieces of 0.1 m or longer. It feeds RMR
(Bieniawski 1989) and Q (Barton et al. 1974). A face has no core, so it is estimated from
the discontinuities measured on it, two ways:

- **From Jv** (:func:`rqd_from_jv`): Palmström (2005)'s RQD = 110 - 2.5 Jv, held to 0 to 100
  (100 for Jv of 4 or less, 0 for 44 or more). Jv counts every set whatever its direction,
  so this RQD has none.
- **Along a line** (:func:`rqd_from_frequency`): Priest & Hudson (1976)'s
  RQD = 100 exp(-0.1 lambda) (0.1 lambda + 1), for spacings along the line exponentially
  distributed with ``lambda`` joints per metre. A set of normal spacing S meets a line at
  angle theta to its normal ``cos(theta) / S`` times a metre (Terzaghi 1965), so lambda
  depends on the line: a core drilled along the sets' normals is more broken than one drilled
  between them. :func:`rqd_range` gives the least and the greatest RQD over all directions.
"""

from __future__ import annotations

from itertools import product

import numpy as np

from geostructure.rockmass.spacing import class_of

#: A core piece counts towards RQD from this length (m; Deere 1964).
RQD_PIECE = 0.1


def rqd_from_jv(jv: float) -> float:
    """Palmström (2005)'s RQD = 110 - 2.5 Jv (joints per m^3), held to 0 to 100; NaN for none.

    Examples
    --------
    >>> rqd_from_jv(10.0), rqd_from_jv(2.0), rqd_from_jv(50.0)
    (85.0, 100.0, 0.0)
    """
    if not np.isfinite(jv):
        return float("nan")
    return float(np.clip(110.0 - 2.5 * jv, 0.0, 100.0))


def rqd_from_frequency(frequency) -> np.ndarray | float:
    """Priest & Hudson (1976)'s RQD (percent) for ``frequency`` joints per metre along a line.

    Examples
    --------
    >>> round(rqd_from_frequency(6.0), 1), rqd_from_frequency(0.0)
    (87.8, 100.0)
    """
    x = RQD_PIECE * np.asarray(frequency, dtype=np.float64)
    rqd = 100.0 * np.exp(-x) * (x + 1.0)
    return float(rqd) if rqd.ndim == 0 else rqd


def frequency_along(directions, normals, spacings) -> np.ndarray:
    """Joints per metre along each unit direction (D, 3): the sum over the sets (unit
    ``normals`` (S, 3), normal ``spacings`` (S,) in m) of |n . d| / S.

    Examples
    --------
    >>> frequency_along(np.eye(3), np.array([[0.0, 0.0, 1.0]]), np.array([0.5])).tolist()
    [0.0, 0.0, 2.0]
    """
    return np.abs(np.asarray(directions) @ np.asarray(normals).T) @ (1.0 / np.asarray(spacings, dtype=np.float64))


def rqd_range(normals, spacings) -> tuple[float, float]:
    """The least and the greatest Priest & Hudson RQD over all directions of a line, from
    the sets with a spacing (finite and positive); NaN, NaN without one.

    The frequency along ``d``, sum of |n . d| / S, is the greatest of the sums
    d . (sum of +-n / S) over the sets' signs, so its maximum over directions is exactly the
    longest of those vectors. Its minimum lies where ``d`` meets no joint of two sets (along
    their planes' intersection; anywhere in the plane of a single set): on each cone of
    directions where the signs hold the frequency is linear, and on the sphere such a
    function has no minimum inside a cone where it is positive.

    Examples
    --------
    One set 0.2 m apart: a line along its normal meets 5 joints a metre (RQD 91.0), a line
    in its plane none (100).

    >>> low, high = rqd_range(np.array([[0.0, 0.0, 1.0]]), np.array([0.2]))
    >>> round(low, 1), round(high, 1)
    (91.0, 100.0)
    """
    normals = np.asarray(normals, dtype=np.float64).reshape(-1, 3)
    spacings = np.asarray(spacings, dtype=np.float64)
    ok = np.isfinite(spacings) & (spacings > 0)
    if not ok.any():
        return float("nan"), float("nan")
    scaled = normals[ok] / (np.linalg.norm(normals[ok], axis=1) * spacings[ok])[:, None]  # n / S
    # Every choice of signs with the first set's fixed (d and -d are one line).
    signs = np.array([(1.0, *rest) for rest in product((1.0, -1.0), repeat=len(scaled) - 1)])
    most = float(np.linalg.norm(signs @ scaled, axis=1).max())
    pairs = [np.cross(a, b) for i, a in enumerate(scaled) for b in scaled[i + 1 :]]
    crossings = np.array([c / np.linalg.norm(c) for c in pairs if np.linalg.norm(c) > 1e-12]).reshape(-1, 3)
    fewest = float(frequency_along(crossings, scaled, np.ones(len(scaled))).min()) if len(crossings) else 0.0
    return float(rqd_from_frequency(most)), float(rqd_from_frequency(fewest))


#: ISRM (1978)'s block sizes by the volumetric joint count: the greatest Jv (joints per m^3)
#: of each; above 60, crushed rock.
BLOCK_SIZE_CLASSES = ((1.0, "very large blocks"), (3.0, "large blocks"), (10.0, "medium-sized blocks"),
                      (30.0, "small blocks"), (60.0, "very small blocks"), (np.inf, "crushed rock"))  # fmt: skip


def block_size_class(jv: float) -> str:
    """ISRM (1978)'s description of the blocks for ``jv`` joints per m^3; "" for none.

    Examples
    --------
    >>> block_size_class(0.5), block_size_class(5.0), block_size_class(75.0), block_size_class(float("nan"))
    ('very large blocks', 'medium-sized blocks', 'crushed rock', '')
    """
    return class_of(jv, BLOCK_SIZE_CLASSES)
