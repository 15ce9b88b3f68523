"""Check the automatic parameters against the sweep on generated scenes (test and benchmark).

A scene variant is judged by z(R), matching by location. The automatic choice passes when
z_auto <= 1.1 * z_best + TOLERANCE, z_best being the lowest z(R) that the paper's four
one-factor sweeps find. The absolute tolerance (0.001 of z, about 0.1 degrees of average
error) is needed because on a clean scene z_best is about 1e-5: a tenth of that is a few
thousandths of a degree, below anything a compass or a cloud can show.
"""

from __future__ import annotations

from dataclasses import dataclass

from geostructure.core.orientation import Frame
from geostructure.core.params import Params
from geostructure.detect.auto import choose_params
from geostructure.detect.pipeline import measure
from geostructure.evaluation.groundtruth import evaluate, scene_truth
from geostructure.evaluation.sweep import FACTORS, run_sweep
from geostructure.synthetic import observatory_scene

TOLERANCE = 0.001

#: Scene variants: the bundled scene, other scales, lower density, more noise.
VARIANTS = {
    "bundled": dict(n_points=300_000),
    "scale 0.1x": dict(n_points=300_000, scale=0.1),
    "scale 10x": dict(n_points=300_000, scale=10.0),
    "sparse (1/25 density)": dict(n_points=12_000),
    "noisy (8 cm)": dict(n_points=300_000, noise=0.08),
    "sparse and noisy": dict(n_points=60_000, noise=0.06),
}


@dataclass
class AutoCheck:
    variant: str
    z_auto: float
    z_default: float
    z_best: float
    found_auto: int
    found_default: int
    choice: str

    @property
    def auto_ok(self) -> bool:
        return self.z_auto <= 1.1 * self.z_best + TOLERANCE

    @property
    def default_ok(self) -> bool:
        return self.z_default <= 1.1 * self.z_best + TOLERANCE


def check_variant(name: str, seed: int, size_factor: float = 1.0, workers: int = 2) -> AutoCheck:
    options = dict(VARIANTS[name])
    options["n_points"] = int(options["n_points"] * size_factor)
    scene = observatory_scene(seed=seed, **options)
    truth = scene_truth(scene, Frame())

    def score(params):
        result = measure(scene.cloud, params)
        return evaluate(result.planes, truth, max_distance=5 * result.voxels.edge)

    # The automatic choice of the voxel method's factors, against the sweep of those factors.
    voxel = Params(detector="voxel")
    choice = choose_params(scene.cloud.local, voxel)
    auto, default = score(choice.params), score(voxel)
    rows = run_sweep(scene.cloud, truth, Frame(), FACTORS, workers=workers)
    best = min([r.z for r in rows] + [auto.z, default.z])
    return AutoCheck(name, auto.z, default.z, best, auto.n_found, default.n_found, choice.describe())
