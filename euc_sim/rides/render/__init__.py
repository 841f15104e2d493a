"""Renderers of a ride's result: the CONTRACT's JSON, the report folder, the pages."""
