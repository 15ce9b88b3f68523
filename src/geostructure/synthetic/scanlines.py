"""Scanlines across a synthetic face: where a set's planes cross them (the generator's truth
of spacing and P32, :meth:`~.rock_outcrop.OutcropScene.scanlines`)."""

from __future__ import annotations

import numpy as np


def scanline_crossings(normals, points, mean, face, line_spacing: float, radii=None) -> dict:
    """Planes (``normals``, a point on each) met along lines every ``line_spacing`` across the
    face rectangle (``face``: its normal, its two axes, its width and height), running along
    ``mean`` projected onto the face: gaps (times the cosine), length, crossings, cosine, the
    mean, C13 and the planes met (``met``). With ``radii``, each plane is a disc about its
    point, and a line meets it only within that radius (inf: a whole plane)."""
    face_normal, (along, up_dip), (width, height) = face
    direction = mean - (mean @ face_normal) * face_normal
    direction /= np.linalg.norm(direction)
    across = np.cross(face_normal, direction)
    corners = np.array([[0, 0], [width, 0], [0, height], [width, height]], dtype=np.float64)
    corners3 = corners[:, :1] * along + corners[:, 1:] * up_dip
    gaps, length, met = [], 0.0, []
    for c in np.arange((corners3 @ across).min() + line_spacing / 2, (corners3 @ across).max(), line_spacing):
        origin = c * across
        t_range = _segment_in_rectangle(origin, direction, along, up_dip, width, height)
        if t_range is None:
            continue
        t = np.einsum("pk,pk->p", normals, points - origin) / (normals @ direction)
        inside = (t >= t_range[0]) & (t <= t_range[1])
        if radii is not None:
            crossing = origin + t[:, None] * direction
            inside &= np.einsum("pk,pk->p", crossing - points, crossing - points) <= radii**2
        length += t_range[1] - t_range[0]
        met.append(np.flatnonzero(inside))
        gaps.append(np.diff(np.sort(t[inside])) * float(mean @ direction))
    met = np.concatenate(met) if met else np.zeros(0, dtype=np.int64)
    return {
        "gaps": np.concatenate(gaps) if gaps else np.zeros(0),
        "length": float(length),
        "crossings": int(len(met)),
        "cosine": float(mean @ direction),
        "mean": mean,
        "c13": float(1.0 / np.abs(normals[met] @ direction).mean()) if len(met) else float("nan"),
        "met": met,
    }


def _segment_in_rectangle(origin, direction, along, up_dip, width, height):
    """The (t0, t1) range of the line origin + t direction inside the face rectangle."""
    o = np.array([origin @ along, origin @ up_dip])
    d = np.array([direction @ along, direction @ up_dip])
    lo, hi = -np.inf, np.inf
    for k, size in enumerate((width, height)):
        if abs(d[k]) < 1e-12:
            if not 0.0 <= o[k] <= size:
                return None
            continue
        a, b = (0.0 - o[k]) / d[k], (size - o[k]) / d[k]
        lo, hi = max(lo, min(a, b)), min(hi, max(a, b))
    return (lo, hi) if hi > lo else None


def exposed_trace_chords(scene, set_index: int) -> np.ndarray:
    """The true trace lengths (m) of set ``set_index``'s joints that the face shows (an
    :class:`~.rock_outcrop.OutcropScene`'s): the chord in which each disc with a facet crosses the
    mean face's plane (inf for planes through the rock mass). A disc exposed only where the
    face lies off its mean (in a step) may miss that plane: it is left out.

    Examples
    --------
    >>> from geostructure.synthetic import outcrop_scene
    >>> from geostructure.synthetic.rock_outcrop import DEFAULT_SETS, JointSet
    >>> sets = tuple(JointSet(**{**vars(s), "persistence": 3.0}) for s in DEFAULT_SETS)
    >>> chords = exposed_trace_chords(outcrop_scene(width=6.0, height=4.0, seed=1, sets=sets), 0)
    >>> bool(2.0 < chords.mean() < 5.0)
    True
    """
    shown = np.unique(scene.facet_plane[scene.facet_set == set_index])
    normals = scene.set_plane_normals[set_index][shown]
    centres, radii = scene.set_plane_points[set_index][shown], scene.set_plane_radii[set_index][shown]
    # The disc's centre lies |c . f| / sin(angle) from the line its plane meets the face in.
    sine = np.linalg.norm(np.cross(normals, scene.face_normal), axis=1)
    off = np.abs(centres @ scene.face_normal) / np.maximum(sine, 1e-9)
    half = np.sqrt(np.maximum(radii**2 - off**2, 0.0))  # inf for a plane
    return 2.0 * half[half > 0]
