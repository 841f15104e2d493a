"""Great-circle distances and local metres agree with each other and with a known arc."""

import numpy as np
import pytest

from euc_sim.geo import EARTH_RADIUS_M, haversine, local_metres


def test_one_degree_of_latitude_is_the_arc_of_the_mean_radius():
    assert haversine(48.0, -2.0, 49.0, -2.0) == pytest.approx(EARTH_RADIUS_M * np.pi / 180, rel=1e-12)
    assert haversine(48.0, -2.0, 48.0, -2.0) == 0.0


def test_local_metres_match_the_great_circle_within_a_few_kilometres():
    rng = np.random.default_rng(0)
    lat = 48.1 + rng.uniform(-0.03, 0.03, 50)
    lon = -2.1 + rng.uniform(-0.04, 0.04, 50)
    xy = local_metres(lat, lon, (48.1, -2.1))
    flat = np.hypot(xy[:, 0], xy[:, 1])
    assert np.allclose(flat, haversine(48.1, -2.1, lat, lon), rtol=1e-3)
    assert np.all(np.sign(xy[:, 0]) == np.sign(lon + 2.1)) and np.all(np.sign(xy[:, 1]) == np.sign(lat - 48.1))
