"""Two rides of one route (studies/route_grade.py):
the route matched, the grade along it read on one ride and carried to the other."""

from __future__ import annotations

import dataclasses

import numpy as np
import pandas as pd
import pytest

from euc_sim.rides.balance.design import NOMINAL, balance_design
from euc_sim.rides.balance.fit import fit_balance
from euc_sim.rides.grids.signals import RideAssumptions, ride_signals
from euc_sim.rides.source.logs import Ride
from route_grade import (BIN_M, GRADE_LIMIT, carried_grade, carry_decision, carry_grade, grade_profile,
                         match_by_gps, match_by_speed, match_routes, revisit_check, route_position)

M, G = 110.0, 9.81                  # kg, m/s²
ETA_M, ETA_R, C_RR = 0.85, 0.6, 0.02
ROUTE_M = 2000.0                    # length of the shared route, m
LAT0, LON0 = 48.1, -1.6


def grade(s):
    """The route's true grade, sin α, at s m along it."""
    return 0.05 * np.sin(2 * np.pi * s / 700.0) + 0.02 * np.sin(2 * np.pi * s / 260.0 + 1.0)


def _speed(s, phase: float, level: float, seed: int, road=(330.0, 140.0), route=grade):
    """A rider's speed along the route: slower on the climbs, at the road's corners, and its own."""
    corners = 1.5 * np.cos(2 * np.pi * s / road[0]) + 1.0 * np.cos(2 * np.pi * s / road[1] + phase)
    own = np.random.default_rng(seed).normal(0.0, 0.4, 8)
    wander = sum(own[k] * np.sin(2 * np.pi * s * (k + 1) / 1700.0 + k) for k in range(8))
    return np.clip(level + corners - 20.0 * route(s) + wander, 1.5, None)


def _ride(start_m: float, length_m: float, phase: float, level: float, seed: int,
          gps: bool = False, shift_m: float = 0.0, route=grade, road=(330.0, 140.0),
          turn_m: float = np.inf) -> Ride:
    """A 5 Hz log of a ride from ``start_m`` along the route, its power from the balance;
    back the way it came from ``turn_m``."""
    rng = np.random.default_rng(seed)
    dt = 0.2
    s, ss = start_m, [start_m]
    while s < start_m + length_m:
        s += dt * _speed(np.array([s]), phase, level, seed, road, route)[0]
        ss.append(s)
    s = np.array(ss)
    t = dt * np.arange(len(s))
    v = _speed(s, phase, level, seed, road, route)
    s, way = np.where(s <= turn_m, s, 2 * turn_m - s), np.where(s <= turn_m, 1.0, -1.0)
    a = np.gradient(v, t)
    D = M * a * v + C_RR * M * G * v + M * G * v * route(s) * way
    P = np.where(D > 0, D / ETA_M, ETA_R * D) + 30.0 + rng.normal(0.0, 40.0, len(t))
    data = {"t": t, "v": v, "voltage": np.full_like(t, 84.0), "current": P / 84.0}
    if gps:
        x, y = s, 60.0 * np.sin(s / 250.0) + shift_m
        data["latitude"] = LAT0 + np.degrees(y / 6_371_000.0) + rng.normal(0.0, 3e-5, len(t))
        data["longitude"] = LON0 + np.degrees(x / (6_371_000.0 * np.cos(np.radians(LAT0))))
    return Ride(path=f"ride{seed}.csv", layout="eucworld", variant="", data=pd.DataFrame(data),
                   start=pd.Timestamp("2026-01-01"), absent=(), warnings=(), n_rows_read=len(t),
                   n_rows_merged=0)


def _signals(log):
    return ride_signals(log, RideAssumptions(total_mass=M, m_eq=M))


@pytest.fixture(scope="module")
def pair():
    """Ride A from the route's start, ride B from 100 m along it, at other speeds."""
    a = _signals(_ride(0.0, ROUTE_M, 0.0, 7.0, 1))
    b = _signals(_ride(100.0, ROUTE_M - 100.0, 0.8, 6.0, 2))
    return a, b


def test_the_offset_is_found_from_the_speeds(pair):
    a, b = pair
    m = match_routes(route_position(a.raw), route_position(b.raw))
    assert m is not None and m.method == "speed"
    assert m.offset_m == pytest.approx(100.0, abs=BIN_M)
    assert m.share > 0.9 and m.quality >= 0.6


def test_the_grade_is_recovered_and_carrying_it_lowers_the_other_rides_error(pair):
    a, b = pair
    da, db = balance_design(a), balance_design(b)
    names = list(NOMINAL) + ["rolling_resistance"]
    fit = fit_balance(da, names, n_boot=0)
    pa, pb = route_position(a.raw), route_position(b.raw)
    prof = grade_profile(a, da, fit.estimate, pa)
    mid = 0.5 * (prof.edges[:-1] + prof.edges[1:])
    inner = np.isfinite(prof.sin_alpha) & (mid > 100) & (mid < ROUTE_M - 100)
    # the fit's C_rr takes the grade's mean: the profile is the grade about it
    truth = grade(mid[inner]) - np.mean(grade(mid[inner]))
    got = prof.sin_alpha[inner] - np.mean(prof.sin_alpha[inner])
    assert np.corrcoef(got, truth)[0, 1] > 0.95
    # the fit ride's efficiencies (η_m on its bound 1, η_r high: the grade it cannot see moves
    # them) scale the grade read: 1/η_m motoring, η_r regenerating
    assert 0.7 < np.polyfit(truth, got, 1)[0] < 1.3
    assert np.nanmax(np.abs(prof.sin_alpha)) <= GRADE_LIMIT
    match = match_routes(pa, pb)
    assert carry_decision(prof, match).carry and not carry_decision(prof, None).carry
    before = fit.rmse_on(db)
    after = fit.rmse_on(carry_grade(b, db, carried_grade(prof, match)))
    assert after < 0.6 * before
    misplaced = dataclasses.replace(match, s_fit=match.s_fit + 200.0)
    assert fit.rmse_on(carry_grade(b, db, carried_grade(prof, misplaced))) > before


def test_rides_of_different_routes_do_not_match(pair):
    a, _ = pair
    other = lambda s: 0.04 * np.cos(2 * np.pi * s / 400.0)      # noqa: E731
    c = _signals(_ride(0.0, ROUTE_M, 2.0, 6.5, 3, route=other, road=(410.0, 190.0)))
    pa, pc = route_position(a.raw), route_position(c.raw)
    assert match_by_speed(pa, pc) is None
    assert match_routes(pa, pc) is None


def test_gps_tracks_match_where_they_share_the_road_and_not_elsewhere():
    a = _ride(0.0, 1500.0, 0.0, 7.0, 4, gps=True)
    b = _ride(300.0, 1200.0, 0.8, 6.0, 5, gps=True)
    far = _ride(0.0, 1500.0, 0.8, 6.0, 6, gps=True, shift_m=400.0)     # a parallel street
    pa = route_position(_signals(a).raw)
    m = match_by_gps(pa, route_position(_signals(b).raw, pa.origin))
    assert m is not None and m.method == "gps"
    assert m.offset_m == pytest.approx(300.0, abs=BIN_M)
    assert m.share > 0.95 and np.all(m.direction[np.isfinite(m.s_fit)] == 1.0)
    assert match_routes(pa, route_position(_signals(far).raw, pa.origin)) is None


def test_a_ride_out_and_back_tests_its_own_grade_on_the_way_back():
    names = list(NOMINAL) + ["rolling_resistance"]
    there_and_back = _signals(_ride(0.0, 2 * 1200.0, 0.0, 6.5, 7, gps=True, turn_m=1200.0))
    d = balance_design(there_and_back)
    pos = route_position(there_and_back.raw)
    check = revisit_check(there_and_back, d, fit_balance(d, names, n_boot=0).estimate, pos)
    assert check is not None and check.shared_m > 800.0
    assert check.after < 0.7 * check.before          # the grade, sign turned, holds on the way back
    failed = dataclasses.replace(check, after=check.before)
    prof = grade_profile(there_and_back, d, fit_balance(d, names, n_boot=0).estimate, pos)
    m = match_routes(pos, pos)
    assert carry_decision(prof, m, check).carry and not carry_decision(prof, m, failed).carry
    one_way = _signals(_ride(0.0, 2400.0, 0.0, 6.5, 8, gps=True))
    d1 = balance_design(one_way)
    assert revisit_check(one_way, d1, fit_balance(d1, names, n_boot=0).estimate,
                         route_position(one_way.raw)) is None
