"""Rendering of a ride's results: the Markdown and HTML pages, their sections and every figure."""
