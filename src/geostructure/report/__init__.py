"""Reports: files other tools read (exports) and pictures geologists read (stereonets)."""
