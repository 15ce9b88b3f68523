"""GeoStructure: strike, dip and dip direction of planar surfaces measured from point clouds.

The public API::

    from geostructure import read_cloud, measure, Params, Frame
    cloud = read_cloud("outcrop.laz")
    result = measure(cloud, Params(theta=5), Frame.named("enu"))
    write_outputs(result, "out/")
"""
__version__ = "0.1.0"

from .auto import choose_params
from .cloud import Cloud
from .errors import GeoStructureError
from .io.readers import read_cloud
from .io.writers import write_outputs
from .orientation import Frame, Orientation, angle_between_normals, azimuth_difference, orientation_from_normals
from .params import Params
from .pipeline import Result, measure

__all__ = ["choose_params", "Cloud", "Frame", "GeoStructureError", "Orientation", "Params", "Result", "angle_between_normals",
           "azimuth_difference", "measure", "orientation_from_normals", "read_cloud", "write_outputs",
           "__version__"]
