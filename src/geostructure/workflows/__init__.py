"""What a command does, as functions: measure an outcrop, save a run, add sets."""
