"""Logs written with a concealed, known truth, for blind tests and studies."""
