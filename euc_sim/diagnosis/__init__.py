"""Diagnosis: which physics the nominal model leaves out of a recording, and the report."""
