"""Against the truth: ground-truth surfaces, field maps, frame fits, the paper's sweeps."""
