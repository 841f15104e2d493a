"""Rendering of a ride's results: the CONTRACT's JSON, the report folder, the Markdown and HTML
pages, their sections and every figure."""
