"""From planes to the rock mass: joint sets, joints, spacing, persistence, intensity, RQD, the notes."""
