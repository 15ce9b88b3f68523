"""From a cloud to planes: the outlier filter, voxel and facet detectors, region growing, the plane table."""
