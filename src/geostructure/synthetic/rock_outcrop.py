"""A rough rock outcrop cut by joint sets, with exact ground truth per facet and per set.

Real outcrops are harder than walls: hundreds of joint faces 0.2 to 1.5 m across, from a
few sets, each face rough, the cloud noisy in a correlated way and holed where steps hide
the rock from the cameras. :func:`outcrop_scene` builds such a face:

1. **Sets and their planes.** Each :class:`JointSet` is a family of planes spaced along the
   set's mean normal by exponential gaps of the set's mean ``spacing`` (the classic model of
   joint spacing, ISRM 1978), each plane's normal drawn from a Fisher distribution of
   concentration ``kappa`` about the mean (:func:`fisher_directions`). With a set's
   ``persistence``, its joints are discs of about that diameter instead (Baecher et al.
   1977), as dense as planes ``spacing`` apart, so that a joint's trace ends on the face.
2. **Facets.** The mean face (``face_dip``/``face_dip_direction``, 20 x 8 m by default) is
   cut into Voronoi cells about seeds whose density varies smoothly over the face, so the
   facets' sizes spread from a few decimetres to a couple of metres about a median near
   ``facet_size``. Each cell is exposed on one joint plane: of a set drawn at random, the
   plane nearest to the cell's centre. A set whose planes stand end-on to the face
   (:data:`END_ON`) is not drawn: it shows on such a face as traces, not faces. Facets therefore truncate each other at the cell
   boundaries and the face is stepped by up to half a spacing, as rock breaks along joints.
3. **Roughness and noise.** Every point moves along the face normal by a smooth random
   field of RMS ``roughness`` (the rock's own asperities, wavelengths 5 to 50 cm), by a
   slower field of RMS ``correlated_noise`` (SfM's correlated error, wavelengths 0.5 to
   3 m), by white noise ``noise``, and a share ``outlier_fraction`` are floaters 5 to 30 cm
   off the face.
4. **Occlusion.** Cameras on a path in front of the face see a point when it faces them and
   is nearest in its pixel (a z-buffer); a point is kept when two cameras see it, as SfM
   needs.

The facet truth is taken from the points that survive: centre (mean noise-free position),
normal, exposed area, set and plane; the set truth is the generator's mean and kappa, the
realised mean normal spacing along scanlines on the face (a disc met only within its
radius) and P32 from it (Dershowitz & Herda 1992).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from geostructure.core.cloud import Cloud
from geostructure.core.orientation import normal_from_orientation
from geostructure.core.threads import tree_query
from geostructure.errors import ParameterError
from geostructure.synthetic.face_texture import facet_seeds, jittered_grid, smooth_field, visible_points
from geostructure.synthetic.jointsets import joint_discs, nearest_joint, persistent_planes
from geostructure.synthetic.scanlines import scanline_crossings


@dataclass(frozen=True)
class JointSet:
    """One set of the generator: mean orientation (degrees), Fisher ``kappa``, mean normal
    spacing (m), the relative share of the face's facets it takes, and its ``persistence``:
    None for planes through the whole rock mass, or the mean diameter (m) of its joints as
    discs (Baecher et al. 1977; lognormal diameters), so that a joint's trace ends on the face.

    Parameters
    ----------
    name : str
        The set's name (``J1``).
    dip, dip_direction : float
        The mean plane's orientation (degrees).
    kappa : float
        Fisher's concentration of the normals.
    spacing : float
        Mean normal spacing (m).
    share : float
        The relative share of the face's facets it takes.
    persistence : float, optional
        The joints' mean diameter (m) as discs; None: planes through the rock mass.

    Examples
    --------
    >>> JointSet("J1", 45.0, 180.0, kappa=80.0, spacing=0.6).persistence is None
    True"""

    name: str
    dip: float
    dip_direction: float
    kappa: float
    spacing: float
    share: float = 1.0
    persistence: float | None = None

    @property
    def normal(self) -> np.ndarray:
        """Upward unit normal (east, north, up)."""
        return normal_from_orientation(self.dip_direction, self.dip)


#: Three sets on a face dipping 75 to the south: one dipping out of the face (planar
#: sliding), one steep into it (exposed as overhangs; toppling), one oblique.
#: A set makes facets on the face only when the cosine between its mean normal and the face's
#: is at least this (its planes more than 17.5 degrees from square to the face); its planes
#: are still there, met by the scanlines of the truth. The default sets all make facets on
#: the default face (cosines 0.61 to 0.87); on a face dipping 75/270, J1 and J2 stand end-on
#: (0.18 and 0.09).
END_ON = 0.3
DEFAULT_SETS = (
    JointSet("J1", dip=45.0, dip_direction=180.0, kappa=80.0, spacing=0.6),
    JointSet("J2", dip=70.0, dip_direction=0.0, kappa=80.0, spacing=0.5),
    JointSet("J3", dip=65.0, dip_direction=235.0, kappa=60.0, spacing=0.7),
)


@dataclass
class OutcropScene:
    """A synthetic outcrop cloud and its truth; positions absolute (``offset`` included).

    Per facet (F): ``facet_set``, ``facet_plane`` (index of its plane within the set),
    ``facet_center``, ``facet_normal`` (upward unit), ``facet_area`` (m^2, exposed, from the
    kept points), ``facet_censored`` (cut short by the cloud's edge:
    the face's border or a hole the cameras left). Per point (N): ``facet_index`` (-1 for floaters) and ``clean`` (the
    noise-free position). Per set (S): ``sets``, ``set_spacing`` (mean normal spacing along
    scanlines on the face, m), ``set_p32`` (m^2/m^3), the same of the
    planes the face exposes (``exposed_set_spacing``, ``exposed_set_p32``), and every plane
    the set has, exposed or not: ``set_plane_normals``, ``set_plane_points`` (a point on
    each, a disc's centre; relative to ``offset``) and ``set_plane_radii`` (inf for planes
    through the rock mass), all along :meth:`scanlines`. The mean face runs through ``offset`` along
    ``face_axes`` (strike, up-dip) over ``face_size`` (m).

    Parameters
    ----------
    cloud : Cloud
        The points.
    sets : tuple of JointSet
        The sets drawn.
    face_normal : ndarray
        The mean face's unit normal.
    facet_set, facet_plane, facet_center, facet_normal, facet_area, facet_censored : ndarray
        Per facet, as above.
    facet_index, clean : ndarray
        Per point, as above.
    set_spacing, set_p32, exposed_set_spacing, exposed_set_p32 : ndarray
        Per set, as above.
    point_spacing : float
        The points' spacing on the face (m).
    set_plane_normals, set_plane_points, set_plane_radii : tuple of ndarray
        Per set, every plane it has.
    face_axes, face_size, offset
        The mean face's axes, size and origin.

    Examples
    --------
    >>> scene = outcrop_scene(width=4.0, height=3.0, seed=1)
    >>> len(scene.facet_set) == len(scene.facet_normal), scene.face_size
    (True, (4.0, 3.0))
    """

    cloud: Cloud
    sets: tuple
    face_normal: np.ndarray
    facet_set: np.ndarray
    facet_plane: np.ndarray
    facet_center: np.ndarray
    facet_normal: np.ndarray
    facet_area: np.ndarray
    facet_censored: np.ndarray
    facet_index: np.ndarray
    clean: np.ndarray
    set_spacing: np.ndarray
    set_p32: np.ndarray
    point_spacing: float
    exposed_set_spacing: np.ndarray | None = None
    exposed_set_p32: np.ndarray | None = None
    set_plane_normals: tuple = ()
    set_plane_points: tuple = ()
    set_plane_radii: tuple = ()
    face_axes: np.ndarray | None = None
    face_size: tuple = (0.0, 0.0)
    offset: np.ndarray | None = None

    @property
    def facet_diameter(self) -> np.ndarray:
        """Diameter (m) of the circle of each facet's exposed area."""
        return 2.0 * np.sqrt(self.facet_area / np.pi)

    @property
    def set_normals(self) -> np.ndarray:
        return np.array([s.normal for s in self.sets])

    def exposed_set_statistics(self, min_diameter: float = 0.0) -> list[dict]:
        """Fisher statistics of each set's exposed facets (at least ``min_diameter`` across),
        each facet counted once: the truth a measurement of the exposure can reach."""
        from geostructure.rockmass.sets import fisher_statistics  # lazy: the generator does not need the statistics

        big = self.facet_diameter >= min_diameter
        return [fisher_statistics(self.facet_normal[(self.facet_set == s) & big]) for s in range(len(self.sets))]

    def scanlines(self, set_index: int, line_spacing: float = 0.25, exposed_only: bool = False) -> dict:
        """One set's joints along scanlines laid on the mean face: the truth of its spacing.

        The lines run across the face rectangle, every ``line_spacing``, in the direction of
        the set's mean normal projected onto the face (ISRM 1978's best-placed scanline), and
        meet the set's generated planes: all of them, exposed or not, or with ``exposed_only``
        those that show as at least one facet, which is what a measurement of the face's
        surface can reach (a joint that never breaks the face shows no face). The mean normal
        is the realised one, of the planes the lines meet (the principal axis of their
        normals): a set with a few joints on the face has a mean a few degrees from the
        generator's, and the cosine that corrects the gaps depends on it.

        Returns ``gaps``, the normal spacings between consecutive planes along a line (gaps
        times the cosine between line and mean normal, Terzaghi's correction), ``length`` (m
        of line), ``crossings``, ``cosine``, ``mean`` and ``c13``, 1 / mean |n . line| over
        the planes met.
        """
        normals, points = self.set_plane_normals[set_index], self.set_plane_points[set_index]
        radii = self.set_plane_radii[set_index]
        if exposed_only:
            shown = np.unique(self.facet_plane[self.facet_set == set_index])
            normals, points, radii = normals[shown], points[shown], radii[shown]
        generated = self.sets[set_index].normal
        face = (self.face_normal, self.face_axes, self.face_size)
        first = scanline_crossings(normals, points, generated, face, line_spacing, radii)
        met = np.unique(first["met"])
        if len(met) >= 2:
            mean = np.linalg.eigh(normals[met].T @ normals[met])[1][:, -1]
            mean = mean if mean @ generated >= 0 else -mean
            first = scanline_crossings(normals, points, mean, face, line_spacing, radii)
        first.pop("met")
        return first


def outcrop_scene(
    *,
    width: float = 20.0,
    height: float = 8.0,
    point_spacing: float = 0.03,
    sets=DEFAULT_SETS,
    face_dip: float = 75.0,
    face_dip_direction: float = 180.0,
    facet_size: float = 0.5,
    roughness: float = 0.005,
    correlated_noise: float = 0.005,
    noise: float = 0.004,
    outlier_fraction: float = 0.005,
    cameras: int = 5,
    camera_distance: float = 12.0,
    offset=(0.0, 0.0, 0.0),
    seed: int = 0,
) -> OutcropScene:
    """A rough outcrop face cut by joint sets (see the module's description).

    Parameters
    ----------
    width, height : float
        Size (m) of the mean face, along strike and up its dip.
    point_spacing : float
        Spacing (m) of the points on the face before occlusion (3 cm for SfM, 1 cm LiDAR).
    sets : sequence of JointSet
    face_dip, face_dip_direction : float
        Orientation (degrees) of the mean face.
    facet_size : float
        Median diameter (m) the facets are drawn about.
    roughness, correlated_noise, noise : float
        RMS (m) of the rock's asperities, of SfM's correlated error and of white noise.
    outlier_fraction : float
        Share of points that float off the face.
    cameras : int
        Camera positions along the path in front of the face; 0 for no occlusion.
    camera_distance : float
        Their distance (m) from the face.
    offset : (3,) float
        Added to every coordinate (UTM-sized, to test precision).
    seed : int
        The scene is a pure function of its arguments.

    Returns
    -------
    OutcropScene

    Examples
    --------
    >>> scene = outcrop_scene(width=4.0, height=3.0, seed=1)
    >>> len(scene.sets), bool(len(scene.facet_set) > 20), bool(0.3 < np.median(scene.facet_diameter) < 0.8)
    (3, True, True)
    """
    rng = np.random.default_rng(seed)
    sets = tuple(sets)
    face_normal = normal_from_orientation(face_dip_direction, face_dip)  # outward: up and out of the slope
    along = np.cross([0.0, 0.0, 1.0], face_normal)
    along = along / np.linalg.norm(along) if np.linalg.norm(along) > 1e-9 else np.array([1.0, 0.0, 0.0])
    up_dip = np.cross(face_normal, along)

    ab = jittered_grid(width, height, point_spacing, rng)
    seeds = facet_seeds(width, height, facet_size, rng)
    cell = tree_query(cKDTree(seeds), ab)[1]
    seeds3 = seeds[:, :1] * along + seeds[:, 1:] * up_dip

    # Each cell's joint plane: of a set drawn by share, the plane nearest the cell's centre.
    share = np.array([s.share for s in sets], dtype=np.float64)
    # A set whose planes stand end-on to the face shows on it as traces, not as faces: a cell
    # exposed on one would be a step metres deep (its depth grows as one over that cosine).
    cosine = np.abs(np.array([normal_from_orientation(s.dip_direction, s.dip) for s in sets]) @ face_normal)
    if not np.any((cosine >= END_ON) & (share > 0)):
        raise ParameterError(
            f"no joint set makes faces on a face dipping {face_dip:g}/{face_dip_direction:g}: every set's planes "
            f"stand within {np.degrees(np.arcsin(END_ON)):.0f} degrees of square to it."
        )
    share = np.where(cosine >= END_ON, share, 0.0)
    cell_set = rng.choice(len(sets), size=len(seeds), p=share / share.sum())
    cell_normal = np.zeros((len(seeds), 3))
    cell_point = np.zeros((len(seeds), 3))
    cell_plane = np.zeros(len(seeds), dtype=np.int64)
    set_normals, set_points, set_radii = [], [], []
    for s, joint in enumerate(sets):
        if joint.persistence is None:
            normals, points, radii = persistent_planes(joint, np.hypot(width, height) + 2.0, rng)
        else:
            normals, points, radii = joint_discs(joint, (face_normal, along, up_dip), (width, height), rng)
        set_normals.append(normals)
        set_points.append(points)
        set_radii.append(radii)
        mine = np.flatnonzero(cell_set == s)
        nearest = nearest_joint(seeds3[mine], normals, points, radii)
        cell_plane[mine] = nearest
        cell_normal[mine] = normals[nearest]
        cell_point[mine] = points[nearest]
    outward = cell_normal * np.sign(cell_normal @ face_normal)[:, None]

    base = ab[:, :1] * along + ab[:, 1:] * up_dip
    n_cell, p_cell = outward[cell], cell_point[cell]
    depth = np.einsum("ij,ij->i", n_cell, p_cell - base) / np.einsum("ij,j->i", n_cell, face_normal)
    clean = base + depth[:, None] * face_normal

    wobble = (
        smooth_field(ab, roughness, (0.05, 0.5), rng)
        + smooth_field(ab, correlated_noise, (0.5, 3.0), rng)
        + rng.normal(0.0, noise, len(ab))
    )
    floaters = rng.random(len(ab)) < outlier_fraction
    wobble[floaters] += rng.choice([-1.0, 1.0], floaters.sum()) * rng.uniform(0.05, 0.3, floaters.sum())
    points = clean + wobble[:, None] * face_normal

    seen = visible_points(clean, n_cell, face_normal, along, width, height, point_spacing, cameras, camera_distance)
    # A cell is cut short by the cloud's edge (censored) where the face ends, or where part of
    # it is hidden and nothing seen lies in front of that part: a hole in the cloud. (Where a
    # step in front hides it, the cloud has no edge there and the cut is not the cloud's.)
    lost = np.flatnonzero(~seen)
    in_hole = np.isinf(tree_query(cKDTree(ab[seen]), ab[lost], distance_upper_bound=2.0 * point_spacing)[0])
    hidden = np.bincount(cell[lost[in_hole]], minlength=len(seeds)) >= 3
    margin = 1.5 * point_spacing
    at_edge = (ab[:, 0] < margin) | (ab[:, 1] < margin) | (ab[:, 0] > width - margin) | (ab[:, 1] > height - margin)
    cut_cell = hidden | (np.bincount(cell[at_edge], minlength=len(seeds)) > 0)
    points, clean, cell, floaters = points[seen], clean[seen], cell[seen], floaters[seen]

    # Neighbouring cells exposed on the same joint plane are one face: join them.
    original_cell = cell
    cell = _join_coplanar_cells(ab[seen], cell, cell_set * 100_000 + cell_plane, point_spacing)
    cut_joined = np.zeros(len(seeds), dtype=bool)
    np.logical_or.at(cut_joined, cell, cut_cell[original_cell])

    # Facets: the cells that kept at least 3 points, numbered in cell order.
    counts = np.bincount(cell, minlength=len(seeds))
    kept_cells = np.flatnonzero(counts >= 3)
    facet_of_cell = np.full(len(seeds), -1)
    facet_of_cell[kept_cells] = np.arange(len(kept_cells))
    facet_index = facet_of_cell[cell]
    facet_index[floaters] = -1
    centre = np.stack([np.bincount(cell, clean[:, a], len(seeds)) for a in range(3)], axis=1)[kept_cells]
    centre /= counts[kept_cells, None]
    cosine = np.abs(outward[kept_cells] @ face_normal)
    area = counts[kept_cells] * point_spacing**2 / cosine
    upward = cell_normal[kept_cells] * np.where(cell_normal[kept_cells, 2:3] < 0, -1.0, 1.0)

    shift = np.asarray(offset, dtype=np.float64)
    order = rng.permutation(len(points))  # readers never see points grouped by facet
    scene = OutcropScene(
        cloud=Cloud.from_points(points[order] + shift, source="synthetic outcrop"),
        sets=sets,
        face_normal=face_normal,
        facet_set=cell_set[kept_cells],
        facet_plane=cell_plane[kept_cells],
        facet_center=centre + shift,
        facet_normal=upward,
        facet_area=area,
        facet_censored=cut_joined[kept_cells],
        facet_index=facet_index[order],
        clean=clean[order] + shift,
        set_spacing=np.zeros(len(sets)),
        set_p32=np.zeros(len(sets)),
        exposed_set_spacing=np.zeros(len(sets)),
        exposed_set_p32=np.zeros(len(sets)),
        point_spacing=point_spacing,
        set_plane_normals=tuple(set_normals),
        set_plane_points=tuple(set_points),
        set_plane_radii=tuple(set_radii),
        face_axes=np.array([along, up_dip]),
        face_size=(float(width), float(height)),
        offset=shift,
    )
    # Truth along scanlines on the face (ISRM 1978; Priest & Hudson 1976): mean normal spacing
    # = cosine x line length / joints met, and P32 = C13 x P10 (Dershowitz & Herda 1992).
    for s in range(len(sets)):
        for exposed_only, spacing, p32 in (
            (False, scene.set_spacing, scene.set_p32),
            (True, scene.exposed_set_spacing, scene.exposed_set_p32),
        ):
            line = scene.scanlines(s, exposed_only=exposed_only)
            p10 = line["crossings"] / line["length"]
            spacing[s] = line["cosine"] / p10 if p10 > 0 else np.inf
            p32[s] = line["c13"] * p10
    return scene


def _join_coplanar_cells(ab, cell, plane_key, step) -> np.ndarray:
    """Each point's cell, with touching cells on the same plane given the lowest cell's number."""
    pairs = cKDTree(ab).query_pairs(1.5 * step, output_type="ndarray")
    a, b = cell[pairs[:, 0]], cell[pairs[:, 1]]
    same = (a != b) & (plane_key[a] == plane_key[b])
    n = len(plane_key)
    graph = coo_matrix((np.ones(int(same.sum())), (a[same], b[same])), shape=(n, n))
    _, component = connected_components(graph, directed=False)
    lowest = np.full(component.max() + 1, n)
    np.minimum.at(lowest, component, np.arange(n))
    return lowest[component[cell]]
