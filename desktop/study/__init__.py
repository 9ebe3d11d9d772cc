"""Studies: comparison detectors, the seed-paper and rocket Monte-Carlo studies, their tables and plots."""
