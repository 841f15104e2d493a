"""The ride JSON's ``differences`` for ``euc-sim ride LOG --compare OTHER``: each domain's rows
of both rides (battery power, terminal voltage, GPS speed) as one
:class:`~euc_sim.rides.compare.differences_fit.PairDesign`, and the signatures whose
correlations say what the pair cannot tell apart.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from euc_sim.rides.compare.channels import readings, whitening
from euc_sim.rides.compare.differences import (ALIAS_CORRELATION, FALSE_NAME_RATE, Tested, alias_table,
                                               parameters_from_fit, physics, ride_differences,
                                               signature_columns)
from euc_sim.rides.compare.differences_fit import DELAY, PairDesign, pair_fit
from euc_sim.rides.compare.resolution import with_floor
from euc_sim.rides.drive.drivetrain_report import reported_mass, reported_terms
from euc_sim.rides.drive.mass import mass_regressors
from euc_sim.rides.grids.power import GPS_V_MIN
from euc_sim.simulation.effects import RECORDS

__all__ = ["own_lag", "window_means", "PowerRows", "power_rows", "power_design", "voltage_design", "gps_design",
           "pair_tests", "pair_aliases", "pair_differences"]

#: Speed above which rows enter the held-out tests, m/s.
V_MIN = 1.0


#: The shared power terms (:func:`euc_sim.rides.drive.mass.mass_regressors`, and ``no_load`` whose difference,
#: ``drivetrain_idle_loss``, is a candidate of the selection but never named).
SHARED_POWER = ("inertia", "rolling", "drag", "copper", "grade")
#: Energy-balance window of the mass, rolling and drag differences, s (the mass fit's middle window).
ROAD_WINDOW = 4.0
#: Largest extra delay of OTHER's current searched, s (the mass fit's own ``max_lag``).
MAX_SHIFT = 1.0


def _power_columns(sig, lag: int, force, m: float) -> tuple[dict, dict]:
    """Shared columns and the difference signatures of one ride at ``lag`` samples (W per unit)."""
    cols = mass_regressors(sig, lag, force)
    zero = np.zeros(len(sig.t))
    shared = {n: cols.get(n, zero) for n in SHARED_POWER}
    shared["no_load"] = zero + 1.0
    delta = {e.name: e.compare.pair(shared, m) for e in RECORDS.having("compare") if e.compare.pair is not None}
    return shared, delta


def _signed_power(sig, mfit, lag: int, force) -> np.ndarray:
    """Battery power, its sign taken from LOG's model where the log records only its size."""
    if sig.signed:
        return sig.P
    cols = mass_regressors(sig, lag, force)
    pred = sum(c * cols[n] for n, c in mfit.coef.items() if n in cols)
    return np.abs(sig.P) * np.sign(pred)


def _rows(sig, arrays) -> np.ndarray:
    ok = np.isfinite(sig.P) & (np.nan_to_num(sig.v) > V_MIN)
    for a in arrays:
        ok &= np.isfinite(a)
    return ok


def own_lag(sig, y, columns: dict) -> int:
    """LOG's delay, samples (a key of ``columns``, lag -> :func:`_power_columns`), by the pair fit's own
    criterion (best RMS of its power on the shared terms), so that a ride against itself shifts by nothing.
    """
    best = (np.inf, 0)
    for lag, (sh, _) in columns.items():
        ok = _rows(sig, [y, *sh.values()])
        if ok.sum() < 200:
            continue
        X = np.column_stack([sh[n][ok] for n in sh])
        r = y[ok] - X @ np.linalg.lstsq(X, y[ok], rcond=None)[0]
        best = min(best, (float(np.sqrt(np.mean(r ** 2))), lag))
    return best[1]


def _valid(sig, y, columns: dict) -> np.ndarray:
    """Rows with every column finite at every shift of ``columns`` (shift -> :func:`_power_columns`):
    one rule for both rides, so a ride against itself fits the same rows.
    """
    arrays = [y]
    for sh, de in columns.values():
        arrays += [*sh.values(), *de.values()]
    return _rows(sig, arrays)


def _stack(first: bool, shared: dict, delta: dict, y, ok, scale: dict, own: dict | None = None,
           owns=()) -> np.ndarray:
    """``[shared…, differences…, own…, y]`` rows of one ride, columns scaled (differences zero on LOG;
    of the channels' own columns ``owns``, this ride's ``own`` only)."""
    nil = np.zeros(ok.sum())
    cols = [shared[n][ok] / scale[n] for n in shared]
    cols += [(nil if first else delta[n][ok] / scale[n]) for n in delta]
    cols += [own[n][ok] if own and n in own else nil for n in owns]
    return np.column_stack(cols + [y[ok]])


def _channel_rows(fit, test, sides: list, scale: dict, channels, window, rate) -> tuple | None:
    """Battery power and each channel of :func:`~euc_sim.rides.compare.channels.readings` on the
    rows where all are finite, combined by their :func:`~euc_sim.rides.compare.channels.whitening`;
    (the channels' own column names, [(tL, ZL), (tO, ZO)]) or None without another channel.
    """
    parts = {"power": [(y, sh, de, {}) for sh, de, y, _ in sides]}
    parts.update(readings(fit, test, [(sh, de, y) for sh, de, y, _ in sides], channels))
    if len(parts) == 1:
        return None
    owns = tuple(n for rows in parts.values() for row in rows for n in row[3])
    oks = []
    for k, (_, _, _, ok) in enumerate(sides):
        for rows in parts.values():
            y, sh, de, own = rows[k]
            for col in (y, *sh.values(), *de.values(), *own.values()):
                ok = ok & np.isfinite(col)
        oks.append(ok)
    if min(ok.sum() for ok in oks) < 200:
        return None
    rides = []
    for k, (ok, r) in enumerate(zip(oks, (fit, test))):
        Z = []
        for rows in parts.values():
            y, sh, de, own = rows[k]
            t, z = r.sig.t[ok], _stack(k == 0, sh, de, y, ok, scale, own, owns)
            Z.append(window_means(t, z, window, rate) if window else (t, z))
        rides.append((Z[0][0], np.stack([z for _, z in Z])))
    W = whitening(rides[0][0], rides[0][1])
    return owns, [(np.tile(t, len(W)), np.einsum("ck,krp->crp", W, Z).reshape(-1, Z.shape[-1])) for t, Z in rides]


def window_means(t: np.ndarray, Z: np.ndarray, width: float, rate: float) -> tuple[np.ndarray, np.ndarray]:
    """Means of ``Z``'s rows over consecutive ``width``-second windows with at least 90 % of their rows."""
    label = np.floor((t - t[0]) / width).astype(int)
    _, inv, n = np.unique(label, return_inverse=True, return_counts=True)
    sums = np.zeros((len(n), Z.shape[1]))
    np.add.at(sums, inv, Z)
    keep = n >= 0.9 * width * rate
    tm = np.bincount(inv, weights=t) / n
    return tm[keep], sums[keep] / n[keep, None]


@dataclass(frozen=True)
class PowerRows:
    """What both of :func:`power_design`'s designs share.

    ``rate`` (Hz) LOG's grid, ``K`` the shifts searched (samples), ``mass`` LOG's total mass (kg),
    ``force`` the copper loss's force terms (or None), ``lag`` LOG's delay (samples); ``yL``,
    ``sL``, ``dL``, ``okL`` LOG's signed power, shared columns, differences and valid rows; ``yO``,
    ``okO`` OTHER's signed power and valid rows, ``colsO`` its columns at each shift ``−K … K``
    beyond LOG's delay.
    """

    rate: float
    K: int
    mass: float
    force: tuple | None
    lag: int
    yL: np.ndarray
    sL: dict
    dL: dict
    okL: np.ndarray
    yO: np.ndarray
    okO: np.ndarray
    colsO: dict


def power_rows(fit, test, mass: float) -> PowerRows | None:
    """LOG's delay and both rides' power rows (:class:`PowerRows`), once for both power designs;
    None without a balance fitted on LOG."""
    mf = fit.mass
    if "inertia" not in (mf.coef or {}) or mf.lag is None:
        return None
    rate = 1.0 / np.median(np.diff(fit.sig.t))
    K = int(round(MAX_SHIFT * rate))
    c = mf.coef
    force = (c["inertia"], c.get("rolling", 0.0), c.get("drag", 0.0)) if mf.copper_column == "force" else None
    yL = _signed_power(fit.sig, mf, int(round(mf.lag * rate)), force)
    near = {j: _power_columns(fit.sig, j, force, mass) for j in range(-K, K + 1)}
    lag = own_lag(fit.sig, yL, near)
    colsL = {j: near.get(lag + j) or _power_columns(fit.sig, lag + j, force, mass) for j in range(-K, K + 1)}
    colsO = {j: _power_columns(test.sig, lag + j, force, mass) for j in range(-K, K + 1)}
    yO = _signed_power(test.sig, mf, lag, force)
    return PowerRows(rate, K, mass, force, lag, yL, *colsL[0], _valid(fit.sig, yL, colsL), yO,
                     _valid(test.sig, yO, colsO), colsO)


def power_design(fit, test, rows: PowerRows | None, shifts=None, window: float | None = None, channels=()):
    """Both rides' battery power: LOG's terms shared, a constant each; OTHER's differences and shift.

    Parameters
    ----------
    fit, test : RideDrivetrain
    rows : PowerRows or None
        :func:`power_rows` of ``fit`` and ``test``.
    shifts : sequence of int, optional
        OTHER's extra delays, samples beyond LOG's lag (default ±:data:`MAX_SHIFT`: the
        delay's design); one shift: the mass, rolling and drag differences there.
    window : float, optional
        Rows averaged over windows of this many s (:func:`window_means`).
    channels : sequence of str
        With one shift, the channels stacked beside battery power.

    Returns
    -------
    (PairDesign, transform) or None
        None without a balance fitted on LOG.
    """
    if rows is None:
        return None
    rate, yL, sL, dL, okL, yO, okO = rows.rate, rows.yL, rows.sL, rows.dL, rows.okL, rows.yO, rows.okO
    shifts = list(range(-rows.K, rows.K + 1)) if shifts is None else list(shifts)
    shifted = [rows.colsO.get(j) or _power_columns(test.sig, rows.lag + j, rows.force, rows.mass) for j in shifts]
    if okL.sum() < 200 or okO.sum() < 200:
        return None
    scale = {n: float(np.sqrt(np.mean(sL[n][okL] ** 2))) or 1.0 for n in sL}
    scale.update({n: float(np.sqrt(np.mean(shifted[0][1][n][okO] ** 2))) or 1.0 for n in dL})
    tL, ZL = fit.sig.t[okL], _stack(True, sL, dL, yL, okL, scale)
    tO, ZO = test.sig.t[okO], [_stack(False, s, {n: d[n] for n in dL}, yO, okO, scale) for s, d in shifted]
    if window:
        tL, ZL = window_means(tL, ZL, window, rate)
        tO, ZO = window_means(tO, ZO[0], window, rate)[0], [window_means(tO, z, window, rate)[1] for z in ZO]
    names = (*sL, *dL)
    stacked = _channel_rows(fit, test, [(sL, dL, yL, okL), (*shifted[0], yO, okO)], scale, channels,
                            window, rate) if channels and len(shifts) == 1 else None
    if stacked is not None:
        names, ((tL, ZL), (tO, ZO0)) = (*names, *stacked[0]), stacked[1]
        ZO = [ZO0]
    # the delay's design keeps the mass, rolling and drag differences in every model: the shift
    # is tested beyond them
    design = PairDesign(names, tuple(dL) if len(shifts) == 1 else (), tL, ZL, tO, tuple(ZO), 1.0 / rate)
    return design, {n: (lambda co, n=n: co[n] / scale[n]) for n in dL}


def voltage_design(fit, test):
    """Both rides' terminal voltage: own open-circuit voltage and charge slope, a shared R, ΔR on OTHER."""
    rides = []
    for sig, Q in ((fit.sig, fit.drivetrain.charge), (test.sig, test.drivetrain.charge)):
        V, I = sig.extra.get("voltage"), sig.extra.get("current")
        if V is None or I is None:
            return None
        ok = np.isfinite(V) & np.isfinite(I)
        if ok.sum() < 200:
            return None
        rides.append((sig.t[ok], V[ok], I[ok], Q[ok]))
    (tL, VL, IL, QL), (tO, VO, IO, QO) = rides
    zL, zO = np.zeros(len(tL)), np.zeros(len(tO))
    ZL = np.column_stack([zL + 1, zL, QL, zL, -IL, zL, VL])
    ZO = np.column_stack([zO, zO + 1, zO, QO, -IO, -IO, VO])
    names = ("const_log", "const_other", "charge_log", "charge_other", "R", "internal_resistance")
    return PairDesign(names, ("internal_resistance",), tL, ZL, tO, (ZO,)), {}


def gps_design(log_path, compare_path):
    """GPS speed over wheel speed on both rides (each a :class:`~euc_sim.rides.source.ride.Ride`):
    a shared scale, OTHER's ratio − 1."""
    rides = []
    for ride in (log_path, compare_path):
        d = ride.data
        if "gps_speed" not in d:
            return None
        v, g = d["v"].to_numpy(float), d["gps_speed"].to_numpy(float)
        ok = np.isfinite(g) & np.isfinite(v) & (v > GPS_V_MIN) & (g > GPS_V_MIN)
        if ok.sum() < 200:
            return None
        rides.append((d["t"].to_numpy(float)[ok], v[ok], g[ok]))
    (tL, vL, gL), (tO, vO, gO) = rides
    ZL = np.column_stack([vL, np.zeros_like(vL), gL])
    ZO = np.column_stack([vO, vO, gO])
    design = PairDesign(("scale", "speed_scale"), ("speed_scale",), tL, ZL, tO, (ZO,))
    return design, {"speed_scale": lambda co: co["speed_scale"] / co["scale"]}


def _entries(res) -> dict[str, Tested]:
    """Each candidate of one :class:`PairFit` by name, as a :class:`~euc_sim.rides.compare.differences.Tested`."""
    corr = res.correlations
    return {n: Tested(e[0], e[1], res.gains.get(n), n in res.selected, res.p_values.get(n),
                      tuple(res.alias_sets.get(n, ())), detectable=res.resolutions.get(n),
                      aliases=tuple(sorted(o for o, r in corr.get(n, {}).items() if abs(r) > ALIAS_CORRELATION)))
            for n, e in res.estimates.items()}


def _delay_resolution(fit, log_path, compare_path) -> float:
    """The finest delay the logs resolve, s: one step of the mass fit's grid or the longer median row interval."""
    dts = [np.median(np.diff(r.data["t"].to_numpy(float))) for r in (log_path, compare_path)]
    return float(max(np.median(np.diff(fit.sig.t)), *dts))


def pair_tests(fit, test, log_path, compare_path, mass: float, n_boot: int = 200,
               seed: int = 0, channels=()) -> dict[str, Tested]:
    """Each physics OTHER needs beyond the model both rides share (:func:`pair_fit` per domain).

    The current's delay first, on battery power sample by sample (a shift grid);
    then the mass, rolling and drag on battery power and the ``channels`` both
    logs have (:mod:`euc_sim.rides.compare.channels`; none by default), averaged over
    :data:`ROAD_WINDOW` s windows, OTHER at the delay found (when kept);
    terminal voltage for the pack resistance; GPS speed for the speed scale.

    Returns
    -------
    dict of str -> Tested
        Each physics tested by name; the delay's ``resolution`` (:func:`_delay_resolution`,
        s) is added to its ``detectable``'s interval half-width.
    """
    fitted = lambda made: None if made is None else pair_fit(   # noqa: E731
        made[0], level=FALSE_NAME_RATE, family=len(physics()), transform=made[1], n_boot=n_boot, seed=seed)
    out = {}
    if not (fit.sig.current_from_phase and test.sig.current_from_phase):
        channels = tuple(c for c in channels if c != "sag")     # a measured current: sag repeats it
    rows = power_rows(fit, test, mass)
    delay = fitted(power_design(fit, test, rows))
    shift = 0
    if delay is not None:
        out.update(_entries(delay))
        floor, det = _delay_resolution(fit, log_path, compare_path), out[DELAY].detectable
        out[DELAY] = replace(out[DELAY], resolution=floor, detectable=None if det is None else with_floor(det, floor))
        if DELAY in delay.selected:
            shift = int(round(delay.estimates[DELAY][0] * rows.rate))     # s -> samples of LOG's grid
    for res in (fitted(power_design(fit, test, rows, [shift], ROAD_WINDOW, channels)),
                fitted(voltage_design(fit, test)), fitted(gps_design(log_path, compare_path))):
        if res is not None:
            out.update(_entries(res))
    return out


def _coef(params: list) -> dict[str, float]:
    """LOG's estimates by name of the parameters the signatures assume (:func:`signature_columns`'s ``coef``)."""
    assumed = {e.name for e in RECORDS.having("compare") if e.compare.coef is not None}
    return {p.name: p.estimate for p in params if p.name in assumed and p.estimate is not None}


def pair_aliases(fit, test, coef: dict) -> tuple[dict, dict]:
    """:func:`alias_table` over both rides' moving rows; the climb unseen without GPS altitude."""
    a, b = (signature_columns(s.v, s.av, s.P, s.t, s.extra.get("current"), s.climb, coef)
            for s in (fit.sig, test.sig))
    keep = [n for n in a if n in b]
    ma, mb = fit.sig.v > V_MIN, test.sig.v > V_MIN
    both = {n: np.r_[a[n][ma], b[n][mb]] for n in keep}
    aliases, cannot = alias_table(both)
    if fit.sig.climb is None or test.sig.climb is None:
        aliases.setdefault("total_mass", [])
    return aliases, cannot


def pair_differences(physics, log_path, compare_path, n_boot: int = 200, seed: int = 0, channels=()):
    """What differs between two rides of one wheel: ``physics`` (LOG's mass and drivetrain with
    OTHER's analysis), both rides, the pair fits' ``n_boot`` and ``seed``, and the ``channels``
    beside battery power (:func:`pair_tests`).
    """
    fit, test = physics.fit, physics.test
    log_params = parameters_from_fit(physics.mass, physics.terms)
    other_params = parameters_from_fit(reported_mass(test), reported_terms(test))
    coef = _coef(log_params)
    aliases, cannot = pair_aliases(fit, test, coef)
    start = log_path.start
    name = f"the {start.day} {start:%B} ride ({log_path.name})"
    tested = pair_tests(fit, test, log_path, compare_path, coef.get("total_mass", 80.0), n_boot, seed,
                        channels)
    for n, entry in tested.items():     # within a pair fit, its own estimates' correlations
        if n != DELAY:
            aliases[n] = list(entry.aliases)
    return ride_differences(log_params, other_params, tested, aliases, cannot, name,
                            {"mass_difference": physics.mass_difference})
