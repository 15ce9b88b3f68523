"""Values and numeric kernels: clouds, planes, parameters, orientations, grids. No files."""
