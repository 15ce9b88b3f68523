"""Poisson surface reconstruction (Open3D), trimmed where support is thin, sampled back to
points for measuring, as the paper does (its "Surface Tessellation" stage).

Poisson closes every hole with a smooth invented surface; each vertex's density (how
many input points supported it) tells them apart, and vertices below the ``trim_quantile``
of density are cut away, so no plane is measured on a surface nobody filmed.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from geostructure.errors import GeoStructureError


@dataclass(frozen=True)
class SurfaceOptions:
    depth: int = 9  # octree depth: 2^depth cells across the cloud
    trim_quantile: float = 0.05  # cut vertices whose support is below this quantile
    normal_neighbours: int = 30
    samples_per_point: float = 1.0  # points sampled on the mesh per dense point
    seed: int = 0


@dataclass
class SurfaceReport:
    vertices: int
    triangles: int
    trimmed: int
    points: int
    seconds: float

    def summary(self) -> str:
        return (
            f"Poisson mesh of {self.triangles:,} triangles ({self.trimmed:,} thin-support vertices trimmed), "
            f"{self.points:,} points sampled in {self.seconds:.1f} s"
        )


def _open3d():
    try:
        import open3d as o3d
    except ImportError as exc:
        raise GeoStructureError(
            "the surface stage needs Open3D (pip install 'geostructure[reconstruct]'; on Debian "
            f"also apt-get install libgl1 libgomp1); or give `mesh=False` ({exc})."
        ) from None
    return o3d


def poisson_points(points: np.ndarray, viewpoints: np.ndarray, options: SurfaceOptions = SurfaceOptions()):
    """Mesh ``points`` and sample it; returns (sampled points, mesh, SurfaceReport).

    ``viewpoints`` (camera centres) orient the normals: a surface faces the cameras that saw it.
    """
    o3d = _open3d()
    t = time.perf_counter()
    centre = points.mean(axis=0)
    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points - centre))
    cloud.estimate_normals(o3d.geometry.KDTreeSearchParamKNN(options.normal_neighbours))
    normals = np.asarray(cloud.normals)
    nearest_view = _nearest(points, viewpoints) - centre
    flip = np.einsum("ij,ij->i", normals, nearest_view - (points - centre)) < 0
    normals[flip] *= -1
    cloud.normals = o3d.utility.Vector3dVector(normals)
    with o3d.utility.VerbosityContextManager(o3d.utility.VerbosityLevel.Error):
        mesh, density = o3d.geometry.TriangleMesh.create_from_point_cloud_poisson(cloud, depth=options.depth)
    density = np.asarray(density)
    cut = density < np.quantile(density, options.trim_quantile)
    mesh.remove_vertices_by_mask(cut)
    mesh.remove_unreferenced_vertices()
    if len(mesh.triangles) == 0:
        raise GeoStructureError("the Poisson surface is empty after trimming; try `mesh=False`.")
    n = max(1000, int(options.samples_per_point * len(points)))
    sampled = np.asarray(mesh.sample_points_uniformly(n).points) + centre
    mesh.translate(centre)
    report = SurfaceReport(
        len(mesh.vertices), len(mesh.triangles), int(cut.sum()), len(sampled), time.perf_counter() - t
    )
    return sampled, mesh, report


def _nearest(points: np.ndarray, viewpoints: np.ndarray) -> np.ndarray:
    from scipy.spatial import cKDTree

    _, index = cKDTree(viewpoints).query(points)
    return viewpoints[index]
