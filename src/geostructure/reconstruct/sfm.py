"""Sparse Structure from Motion with pycolmap: SIFT features, matching, incremental mapping.

Video frames are matched sequentially (each with its next ``overlap`` frames, plus loop
detection off: the clip is one pass); photo sets up to ``EXHAUSTIVE_LIMIT`` images are
matched exhaustively. The largest model is kept; when it holds fewer than half the images,
mapping is tried again from a start that allows forward motion (walks along a street).
"""

from __future__ import annotations

import time
import warnings
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from geostructure.errors import InputError

IMAGE_SUFFIXES = {".jpg", ".jpeg", ".png", ".tif", ".tiff", ".bmp"}
EXHAUSTIVE_LIMIT = 60
RELAXED_INIT_ANGLE = 4.0  # degrees; COLMAP's default 16 finds no start in forward-moving sequences


@dataclass(frozen=True)
class SfmOptions:
    matching: str = "auto"  # auto | sequential | exhaustive
    max_image_size: int = 1600  # SIFT on images downscaled to this (px, longest side)
    max_features: int = 8192
    overlap: int = 10  # sequential matching: each frame with its next N
    single_camera: bool = True  # one camera for all images (a video, one photographer)
    threads: int = -1
    seed: int = 0


@dataclass
class SfmReport:
    images: int
    registered: int
    points: int
    mean_reprojection_error: float  # pixels
    matching: str
    seconds: dict

    def summary(self) -> str:
        return (
            f"registered {self.registered} of {self.images} images, {self.points:,} sparse points, "
            f"mean reprojection error {self.mean_reprojection_error:.2f} px ({self.matching} matching)"
        )


@contextmanager
def quiet_colmap(level: int = 3):
    """COLMAP logs every step through glog: to stderr, and for each error a log file in the
    temporary folder. While it works, keep only what stops the process (level 3, FATAL), and
    never to a file: a failure is said in GeoStructure's own sentence instead. The settings
    are restored afterwards."""
    import pycolmap

    settings = pycolmap.logging
    old = settings.minloglevel, settings.logtostderr
    settings.minloglevel, settings.logtostderr = level, True
    try:
        yield
    finally:
        settings.minloglevel, settings.logtostderr = old


def list_images(folder) -> list[Path]:
    folder = Path(folder)
    if not folder.is_dir():
        raise InputError(f"{folder}: not a folder of images.")
    images = _images_in(folder)
    if not images:
        raise InputError(f"{folder}: holds no images (.jpg, .png or .tif){_where_images_are(folder)}")
    check_images(images)
    return images


def _images_in(folder: Path) -> list[Path]:
    return sorted(p for p in folder.iterdir() if p.suffix.lower() in IMAGE_SUFFIXES and p.is_file())


def _where_images_are(folder: Path) -> str:
    """The end of the no-images sentence: a dataset often keeps its photos one level down
    (``images/``), so name the subfolders that hold some.

    Examples
    --------
    >>> import tempfile
    >>> root = Path(tempfile.mkdtemp())
    >>> (root / "images").mkdir(); (root / "images" / "a.jpg").touch(); (root / "images" / "b.JPG").touch()
    >>> _where_images_are(root) == f", but its subfolder {root / 'images'} holds 2: give that folder."
    True
    """
    found = []
    for sub in sorted(p for p in folder.iterdir() if p.is_dir()):
        try:
            n = len(_images_in(sub))
        except OSError:  # unreadable: it holds none we can use
            n = 0
        if n:
            found.append((sub, n))
    if not found:
        return "; give a folder of photos or a video."
    if len(found) == 1:
        return f", but its subfolder {found[0][0]} holds {found[0][1]}: give that folder."
    named = ", ".join(f"{sub} ({n})" for sub, n in found[:3]) + (", ..." if len(found) > 3 else "")
    return f", but its subfolders {named} hold some: give one of them."


def check_images(images) -> None:
    """Refuse a file that is not an image before SfM spends minutes on it (PIL reads headers only)."""
    from PIL import Image, UnidentifiedImageError

    for path in images:
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", Image.DecompressionBombWarning)  # judged below, by its size
                with Image.open(path) as image:
                    width, height = image.size
                    image.verify()
        except Image.DecompressionBombError:  # past PIL's own bound, above this one: no size given
            raise InputError(
                f"{path}: its header claims more pixels than any photo of an outcrop "
                f"({MAX_IMAGE_PIXELS // 1_000_000} megapixels at most); remove it or scale it down."
            ) from None
        except (UnidentifiedImageError, OSError, SyntaxError, ValueError):
            raise InputError(
                f"{path}: is not an image that can be read (damaged, or not a photo); remove it from the folder."
            ) from None
        if width * height > MAX_IMAGE_PIXELS:
            raise InputError(
                f"{path}: its header claims {width:,} x {height:,} pixels, more than any photo of an outcrop "
                f"({MAX_IMAGE_PIXELS // 1_000_000} megapixels at most); remove it or scale it down."
            )


#: The largest photo read: a 100-megapixel camera's, and more (PIL refuses from 179). A PNG
#: whose header claimed 40000 x 40000 stopped the run with PIL's DecompressionBombError.
MAX_IMAGE_PIXELS = 150_000_000


def run_sfm(image_dir, workdir, options: SfmOptions = SfmOptions(), progress=None):
    """Reconstruct cameras and sparse points; returns (pycolmap.Reconstruction, SfmReport).

    Raises GeoStructureError, saying what to try, when fewer than 3 images register.
    """
    with quiet_colmap():
        return _run_sfm(image_dir, workdir, options, progress)


def _run_sfm(image_dir, workdir, options, progress):
    import pycolmap

    report = progress or (lambda stage, done, total: None)
    image_dir, workdir = Path(image_dir), Path(workdir)
    images = list_images(image_dir)
    workdir.mkdir(parents=True, exist_ok=True)
    database = workdir / "database.db"
    database.unlink(missing_ok=True)  # features of an earlier, different image set must not leak in
    seconds = {}
    # COLMAP's RANSAC (geometric verification, registration) draws from a global generator:
    # seeded, a run repeats (up to the order its threads finish in).
    pycolmap.set_random_seed(options.seed)

    t = time.perf_counter()
    report("features", 0, None)
    extraction = pycolmap.FeatureExtractionOptions()
    extraction.max_image_size = options.max_image_size
    extraction.num_threads = options.threads
    extraction.sift.max_num_features = options.max_features
    pycolmap.extract_features(
        database,
        image_dir,
        image_names=[p.name for p in images],
        camera_mode=pycolmap.CameraMode.SINGLE if options.single_camera else pycolmap.CameraMode.AUTO,
        extraction_options=extraction,
        device=pycolmap.Device.cpu,
    )
    seconds["features"] = time.perf_counter() - t

    t = time.perf_counter()
    report("matching", 0, None)
    matching = options.matching
    if matching == "auto":
        matching = "exhaustive" if len(images) <= EXHAUSTIVE_LIMIT else "sequential"
    matcher = pycolmap.FeatureMatchingOptions()
    matcher.num_threads = options.threads
    if matching == "sequential":
        pairing = pycolmap.SequentialPairingOptions()
        pairing.overlap = options.overlap
        pycolmap.match_sequential(
            database, matching_options=matcher, pairing_options=pairing, device=pycolmap.Device.cpu
        )
    elif matching == "exhaustive":
        pycolmap.match_exhaustive(database, matching_options=matcher, device=pycolmap.Device.cpu)
    else:
        raise InputError(f"unknown matching '{matching}'; use auto, sequential or exhaustive.")
    seconds["matching"] = time.perf_counter() - t

    t = time.perf_counter()
    report("mapping", 0, None)
    mapping = pycolmap.IncrementalPipelineOptions()
    mapping.num_threads = options.threads
    mapping.random_seed = options.seed
    sparse = workdir / "sparse"
    best = _map(database, image_dir, sparse, mapping)
    registered = best.num_reg_images() if best is not None else 0
    if registered < max(3, len(images) // 2):
        # A walk straight ahead (a street, a gallery) gives pairs that COLMAP's default start
        # rejects as forward motion with small triangulation angles; start from such a pair.
        mapping.mapper.init_max_forward_motion = 1.0
        mapping.mapper.init_min_tri_angle = RELAXED_INIT_ANGLE
        relaxed = _map(database, image_dir, workdir / "sparse_relaxed", mapping)
        if relaxed is not None and relaxed.num_reg_images() > registered:
            best, registered = relaxed, relaxed.num_reg_images()
            matching += ", relaxed start"
    seconds["mapping"] = time.perf_counter() - t
    if registered < 3:
        raise InputError(
            f"{image_dir}: SfM registered {registered} of {len(images)} images (at least 3 are needed). "
            "The photos may not overlap: take them so that each shares about two thirds of its view with the "
            "next, avoid plain or shiny surfaces, or try `matching='exhaustive'`."
        )
    best.write(sparse)  # the kept model at sparse/, for the dense stage and for COLMAP's GUI
    return best, SfmReport(
        len(images), registered, best.num_points3D(), float(best.compute_mean_reprojection_error()), matching, seconds
    )


def _map(database, image_dir, folder, options):
    """The model with the most registered images, or None."""
    import pycolmap

    folder.mkdir(exist_ok=True)
    models = pycolmap.incremental_mapping(database, image_dir, folder, options)
    return max(models.values(), key=lambda r: r.num_reg_images(), default=None)


def sparse_points(reconstruction) -> np.ndarray:
    """(N, 3) sparse points of a model, in model coordinates."""
    points = [p.xyz for p in reconstruction.points3D.values()]
    return np.array(points, dtype=np.float64).reshape(-1, 3)


def pair_angle(reconstruction, a: int, b: int, pids) -> float:
    """Median triangulation angle (degrees) of two images on (up to 200 of) their shared points."""
    xyz = np.array([reconstruction.points3D[p].xyz for p in pids[:200]])
    ra = xyz - reconstruction.images[a].projection_center()
    rb = xyz - reconstruction.images[b].projection_center()
    cos = np.einsum("ij,ij->i", ra, rb) / np.linalg.norm(ra, axis=1) / np.linalg.norm(rb, axis=1)
    return float(np.degrees(np.median(np.arccos(np.clip(cos, -1, 1)))))
