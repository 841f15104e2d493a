"""Renderers at the edge: the one HTML page template every report uses."""
