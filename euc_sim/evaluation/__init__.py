"""Blind evaluation of the diagnosis: concealed effects, pairs and firmware laws, simulated, diagnosed blind and scored against the truth (docs/diagnosis.md)."""
