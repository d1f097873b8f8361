"""Validation cases with known answers (``sphfluid validate``)."""
