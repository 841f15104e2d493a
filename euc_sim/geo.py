"""Positions on the Earth: great-circle distances and local metres from GPS fixes."""

from __future__ import annotations

import numpy as np

__all__ = ["EARTH_RADIUS_M", "haversine", "local_metres"]

#: The Earth's mean radius, m (a sphere: distances good to 0.5 % anywhere, far better
#: than GPS over a ride).
EARTH_RADIUS_M = 6_371_000.0


def haversine(lat1, lon1, lat2, lon2) -> np.ndarray:
    """Great-circle distance, m, between points given in degrees (broadcast), on a sphere of :data:`EARTH_RADIUS_M`."""
    p1, p2 = np.radians(lat1), np.radians(lat2)
    dl = np.radians(np.asarray(lon2, float) - np.asarray(lon1, float))
    a = np.sin((p2 - p1) / 2) ** 2 + np.cos(p1) * np.cos(p2) * np.sin(dl / 2) ** 2
    return 2 * EARTH_RADIUS_M * np.arcsin(np.sqrt(np.clip(a, 0.0, 1.0)))


def local_metres(lat, lon, origin: tuple[float, float]) -> np.ndarray:
    """Equirectangular projection about ``origin`` (lat, lon deg): (n, 2) metres east and north (0.1 % within 10 km)."""
    lat0, lon0 = np.radians(origin[0]), np.radians(origin[1])
    x = EARTH_RADIUS_M * np.cos(lat0) * (np.radians(np.asarray(lon, float)) - lon0)
    y = EARTH_RADIUS_M * (np.radians(np.asarray(lat, float)) - lat0)
    return np.column_stack([np.ravel(x), np.ravel(y)])
