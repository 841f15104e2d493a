"""Identification: recordings, the paper's Section 2 processing, torques and h (Section 4), base parameters,
controller fits, and model selection."""
