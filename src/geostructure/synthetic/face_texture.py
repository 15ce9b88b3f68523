"""How a synthetic face is sampled, roughened and seen: the pieces :mod:`.rock_outcrop` builds
its rock face from, each a function of the face's 2-D coordinates (``ab``, metres along
strike and up dip) and a seeded generator."""

from __future__ import annotations

import numpy as np


def jittered_grid(width, height, step, rng) -> np.ndarray:
    """Points about ``step`` apart over the face, as regular as SfM's pixels but not a lattice."""
    a, b = np.meshgrid(np.arange(0.0, width, step), np.arange(0.0, height, step), indexing="ij")
    ab = np.column_stack([a.ravel(), b.ravel()])
    return ab + rng.uniform(-0.4 * step, 0.4 * step, ab.shape)


def facet_seeds(width, height, facet_size, rng) -> np.ndarray:
    """Voronoi seeds whose density varies smoothly over the face (log-normally, sigma 0.7)."""
    # Density lam = 4 / (pi d^2) would give Poisson-Voronoi cells of median equivalent diameter
    # near d; the varying density and the occlusion's splitting make them smaller, by a
    # factor measured on the default face (about 1.2 in diameter).
    lam = 4.0 / (np.pi * facet_size**2)
    peak = lam * np.exp(2.0 * 0.7)
    n = rng.poisson(peak * width * height)
    candidates = rng.random((n, 2)) * [width, height]
    field = smooth_field(candidates, 0.7, (2.0, 8.0), rng)
    keep = rng.random(n) < np.exp(field - 2.0 * 0.7)
    return candidates[keep]


def smooth_field(ab, rms: float, wavelengths, rng, waves: int = 24) -> np.ndarray:
    """A random smooth field over the face of RMS ``rms``: a sum of plane waves.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> ab = jittered_grid(20.0, 8.0, 0.05, rng)
    >>> h = smooth_field(ab, 0.01, (0.05, 0.5), rng)
    >>> bool(0.007 < np.sqrt(np.mean(h**2)) < 0.013)
    True
    """
    if rms <= 0:
        return np.zeros(len(ab))
    wavelength = np.exp(rng.uniform(np.log(wavelengths[0]), np.log(wavelengths[1]), waves))
    angle = rng.uniform(0.0, np.pi, waves)
    k = (2 * np.pi / wavelength)[:, None] * np.column_stack([np.cos(angle), np.sin(angle)])
    phase = rng.uniform(0.0, 2 * np.pi, waves)
    return rms * np.sqrt(2.0 / waves) * np.cos(ab @ k.T + phase).sum(axis=1)


def visible_points(points, normals, face_normal, along, width, height, step, cameras, distance) -> np.ndarray:
    """Points facing at least two of the cameras and nearest to them in their pixel."""
    if cameras <= 0:
        return np.ones(len(points), dtype=bool)
    up_dip = np.cross(face_normal, along)
    centre = along * width / 2 + up_dip * height / 2
    seen = np.zeros(len(points), dtype=np.int64)
    pixel = 1.5 * step / distance  # radians: a pixel about 1.5 point spacings wide on the face
    for x in np.linspace(0.1 * width, 0.9 * width, cameras):
        camera = centre + (x - width / 2) * along + distance * face_normal
        ray = points - camera
        depth = np.linalg.norm(ray, axis=1)
        facing = np.einsum("ij,ij->i", normals, -ray) > 0.1 * depth
        forward = -face_normal
        u = np.arctan2(ray @ along, ray @ forward)
        v = np.arctan2(ray @ up_dip, ray @ forward)
        key = np.floor(u / pixel).astype(np.int64) * 1_000_003 + np.floor(v / pixel).astype(np.int64)
        _, slot = np.unique(key, return_inverse=True)
        nearest = np.full(slot.max() + 1, np.inf)
        np.minimum.at(nearest, slot[facing], depth[facing])
        seen += facing & (depth <= nearest[slot] + 2.0 * step)
    return seen >= 2
