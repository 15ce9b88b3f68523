"""Synthetic scenes with exact ground truth: the bundled default dataset, tests, benchmarks.

- :func:`observatory_scene`: the paper's six large surfaces in an outdoor scene (the demo).
- :func:`outcrop_scene`: a rough rock face cut by hundreds of small joint facets from a few
  sets, with SfM-like noise and occlusion: the case a rock-slope engineer brings.
- :func:`road_before`, :func:`crest_above`, :func:`bushes_on`: the ground and the vegetation
  a survey of a rock cut holds besides its rock.
"""

from geostructure.synthetic.jointsets import fisher_directions
from geostructure.synthetic.observatory import (
    PAPER_NORMALS,
    PAPER_TABLE,
    Scene,
    Surface,
    observatory_scene,
    paper_surfaces,
    paper_to_enu,
    sample_rectangle,
)
from geostructure.synthetic.rock_outcrop import JointSet, OutcropScene, outcrop_scene
from geostructure.synthetic.surroundings import bushes_on, crest_above, road_before

__all__ = [
    "PAPER_NORMALS",
    "PAPER_TABLE",
    "JointSet",
    "OutcropScene",
    "Scene",
    "Surface",
    "bushes_on",
    "crest_above",
    "fisher_directions",
    "observatory_scene",
    "outcrop_scene",
    "paper_surfaces",
    "paper_to_enu",
    "road_before",
    "sample_rectangle",
]
