"""GeoStructure: strike, dip and dip direction of planar surfaces measured from point clouds.

The public API::

    from geostructure import read_cloud, measure, save_measurement, Params, Frame
    cloud = read_cloud("outcrop.laz")
    result = measure(cloud, Params(theta=5), Frame.named("enu"))
    save_measurement(result, "out/")

Names are imported on first use (PEP 562), so ``import geostructure`` and the command
line's start stay fast, and an interrupt while starting is answered without a traceback.
"""

from __future__ import annotations

import importlib
import importlib.metadata

try:  # one version, pyproject.toml's, as installed
    __version__ = importlib.metadata.version("geostructure")
except importlib.metadata.PackageNotFoundError:  # a source tree that was never installed
    __version__ = "0+unknown"

#: Public name -> the module that defines it.
_PUBLIC = {
    "choose_params": "detect.auto",
    "Cloud": "core.cloud",
    "GeoStructureError": "errors",
    "InputError": "errors",
    "OutputError": "errors",
    "ParameterError": "errors",
    "GeoStructureWarning": "errors",
    "GeoStructureNote": "errors",
    "read_cloud": "io.readers",
    "write_outputs": "io.writers",
    "verified_record": "io.outdir",
    "Frame": "core.orientation",
    "Orientation": "core.orientation",
    "angle_between_normals": "core.orientation",
    "angle_between_vectors": "core.orientation",
    "azimuth_difference": "core.orientation",
    "orientation_from_normals": "core.orientation",
    "Params": "core.params",
    "Planes": "core.planes",
    "Measurement": "detect.pipeline",
    "measure": "detect.pipeline",
    "save_measurement": "workflows.saving",
    "add_report": "workflows.saving",
    "add_evaluation": "evaluation.scoring",
    "measure_survey": "workflows.survey",
    "measure_outcrop": "workflows.outcrop",
    "OutcropRun": "workflows.outcrop",
}

__all__ = sorted(_PUBLIC) + ["__version__"]


def __getattr__(name: str):
    if name in _PUBLIC:
        value = getattr(importlib.import_module(f".{_PUBLIC[name]}", __name__), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'geostructure' has no attribute '{name}'")


def __dir__():
    return __all__
