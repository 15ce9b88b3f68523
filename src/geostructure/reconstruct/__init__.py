"""Reconstruction (the paper's stages 0-2): video or photos -> frames -> SfM -> dense cloud ->
Poisson surface -> points, tied to the world by a georeference."""
