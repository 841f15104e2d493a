"""The ride JSON's ``differences`` for ``euc-sim ride LOG --compare OTHER``.

Glue between the two rides' drivetrain analyses (:mod:`euc_sim.rides.drivetrain_report`)
and the pure functions of :mod:`euc_sim.rides.differences`: the residual of LOG's
battery-power model on OTHER, LOG's battery model on OTHER's voltage and LOG's
speed scale on OTHER's GPS speed give each physics' held-out gain; both rides'
signals give the signatures whose correlations say what the pair cannot tell apart.
"""

from __future__ import annotations


import numpy as np

from euc_sim.rides.differences import (alias_table, difference_interval, heldout_gain,
                                       parameters_from_ride,
                                       residual_coefficient, ride_differences, signature_columns)
from euc_sim.rides.ride import as_ride, ride_name
from euc_sim.rides.mass import mass_regressors

__all__ = ["log_model_residual", "pair_tests", "pair_aliases", "differences_json"]

#: Speed above which rows enter the held-out tests, m/s.
V_MIN = 1.0
#: Speed above which GPS and wheel speed are compared, m/s.
V_GPS = 2.0


def log_model_residual(sig, fit, v_min: float = V_MIN):
    """OTHER's battery power minus LOG's model of it, with the rows kept.

    The same prediction as :func:`euc_sim.rides.mass.predict_power` (LOG's
    coefficients and delay on OTHER's signals), keeping which rows it scores.

    Returns
    -------
    ok : ndarray of bool
        Rows of ``sig`` scored.
    residual : ndarray
        Logged minus predicted power on those rows, W.
    """
    c = fit.coef or {}
    if "inertia" not in c or fit.lag is None:          # no balance fitted on LOG
        return np.zeros(len(sig.t), bool), np.empty(0)
    lag = int(round(fit.lag / np.median(np.diff(sig.t))))
    force = ((c["inertia"], c.get("rolling", 0.0), c.get("drag", 0.0))
             if fit.copper_column == "force" else None)
    cols = mass_regressors(sig, lag, force)
    names = [n for n in c if n in cols]
    ok = np.isfinite(sig.P) & (np.nan_to_num(sig.v) > v_min)
    for n in names:
        ok &= np.isfinite(cols[n])
    pred = sum(c[n] * cols[n] for n in names)
    pred = pred if sig.signed else np.abs(pred)
    return ok, sig.P[ok] - pred[ok]


def _coef(params: list) -> dict:
    return {p["name"]: p["estimate"] for p in params
            if p["name"] in ("total_mass", "rolling_resistance", "aerodynamic_drag")
            and p.get("estimate") is not None}


def _signatures(sig, coef: dict) -> dict:
    cur = sig.extra.get("current")
    return signature_columns(sig.v, sig.av, sig.P, sig.t, cur, sig.climb, coef)


def _tests(t, residual, candidate, base=None, scale: float = 1.0, intercept: bool = True) -> tuple:
    """(held-out gain, the coefficient given LOG's model times ``scale``) of one candidate."""
    gain = heldout_gain(t, residual, candidate, base, intercept=intercept)
    c = residual_coefficient(t, residual, candidate, base, intercept=intercept)
    return gain, None if c is None else (c[0] * scale, (c[1][0] * scale, c[1][1] * scale))


def _voltage_tests(sig, battery_coef: dict | None) -> tuple:
    """A free pack resistance on OTHER's voltage, LOG's resistance removed (Ω)."""
    V, I = sig.extra.get("voltage"), sig.extra.get("current")
    if V is None or I is None or not battery_coef:
        return None, None
    dt = np.r_[0.0, np.diff(sig.t)]
    dt[dt > 1.0] = 0.0
    Q = np.cumsum(np.nan_to_num(I) * dt) / 3600.0
    return _tests(sig.t, V + battery_coef["R_int"] * I, -I, base=-Q[:, None])


def _speed_tests(path, scale: float) -> tuple:
    """A free speed scale on OTHER's GPS speed, LOG's scale removed (ratio − 1)."""
    d = as_ride(path).log.data          # a parsed log as it is, a path read
    if "gps_speed" not in d:
        return None, None
    v, g = d["v"].to_numpy(float), d["gps_speed"].to_numpy(float)
    ok = np.isfinite(g) & (v > V_GPS)
    if ok.sum() < 100:
        return None, None
    return _tests(d["t"].to_numpy(float)[ok], g[ok] - scale * v[ok], v[ok], scale=1.0 / scale,
                  intercept=False)


def _ride_tests(rd, path, fit, coef: dict) -> dict:
    """Each physics on the ride ``rd`` (at ``path``) under LOG's fitted model ``fit``."""
    ok, res = log_model_residual(rd.sig, fit.mass)
    cols = _signatures(rd.sig, coef)
    t = rd.sig.t[ok]
    out = {n: _tests(t, res, cols[n][ok])
           for n in ("total_mass", "rolling_resistance", "aerodynamic_drag", "current_delay")}
    out["internal_resistance"] = _voltage_tests(rd.sig, fit.drivetrain.battery_coef)
    out["speed_scale"] = _speed_tests(path, fit.mass.scale.estimate)
    return out


def _beyond(own: tuple, other: tuple) -> tuple:
    """OTHER's (gain, coefficient) minus LOG's own under the same model (intervals in quadrature)."""
    (g0, c0), (g1, c1) = own, other
    gain = None if g0 is None or g1 is None else g1 - max(g0, 0.0)
    if c0 is None or c1 is None:
        return gain, None
    d, ci = difference_interval(c0[0], c0[1], c1[0], c1[1])
    return gain, (d, ci)


def pair_tests(fit, test, log_path, compare_path, coef: dict) -> tuple[dict, dict]:
    """Each physics on OTHER beyond LOG's model: held-out gain and the coefficient it needs.

    The same tests on LOG itself are subtracted: what LOG's model already
    misses on its own ride (its fit is an energy balance over windows, not
    the instantaneous least squares of these tests) is not a difference.

    Parameters
    ----------
    fit, test : RideDrivetrain
        LOG's and OTHER's analyses.
    log_path, compare_path : path
        The logs (their GPS speed).
    coef : dict
        LOG's mass, rolling and drag (the signatures' scales).

    Returns
    -------
    gains : dict of str -> float or None
    given : dict of str -> (estimate, (lo, hi)) or None
    """
    own = _ride_tests(fit, log_path, fit, coef)
    other = _ride_tests(test, compare_path, fit, coef)
    out = {n: _beyond(own[n], other[n]) for n in other}
    return {n: g for n, (g, _) in out.items()}, {n: c for n, (_, c) in out.items()}


def pair_aliases(fit, test, coef: dict) -> tuple[dict, dict]:
    """:func:`alias_table` over both rides' moving rows; the climb unseen without GPS altitude."""
    a, b = _signatures(fit.sig, coef), _signatures(test.sig, coef)
    keep = [n for n in a if n in b]
    ma, mb = fit.sig.v > V_MIN, test.sig.v > V_MIN
    both = {n: np.r_[a[n][ma], b[n][mb]] for n in keep}
    aliases, cannot = alias_table(both)
    if fit.sig.climb is None or test.sig.climb is None:
        aliases.setdefault("total_mass", [])
    return aliases, cannot


def differences_json(rep: dict, fit, test, log_path, compare_path) -> dict:
    """The ``differences`` list and its companions for the ride JSON.

    Parameters
    ----------
    rep : dict
        The ride JSON so far (LOG's ``total_mass``, ``drivetrain``, ``mass_difference``).
    fit, test : RideDrivetrain
        LOG's and OTHER's analyses (:func:`euc_sim.rides.drivetrain_report.drivetrain_report`).
    log_path, compare_path : path or RideLog
        Each log, parsed (as the ride pipeline holds it) or a path (then read once).
    """
    from euc_sim.rides.drivetrain_report import drivetrain_report

    log_path, compare_path = as_ride(log_path).log, as_ride(compare_path).log
    other_view = drivetrain_report(compare_path, test.spec, fitted=test)[0]
    log_params, other_params = parameters_from_ride(rep), parameters_from_ride(other_view)
    coef = _coef(log_params)
    aliases, cannot = pair_aliases(fit, test, coef)
    start = log_path.start
    name = f"the {start.day} {start:%B} ride ({ride_name(log_path)})"
    gains, given = pair_tests(fit, test, log_path, compare_path, coef)
    res = ride_differences(log_params, other_params, gains, aliases, cannot, name,
                           rep.get("mass_difference"), given)
    return res.to_json()
