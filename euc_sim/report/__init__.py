"""The rendering layer: the one HTML page template, shared figures, and the ride and diagnosis renderers."""
