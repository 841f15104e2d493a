#!/usr/bin/env python
"""What the WheelLog pair's balance lacks: current timing, mass, grade along the route (docs/ride_model.md).

    nice python studies/balance_missing_physics.py

Reads ``../shared/data/wheellog/`` (the 16 May and 28 May rides).  Prints, for
both directions (fit on one ride, test on the other; total mass the energy
balance gives, 113.7 and 110.9 kg):

1. a pure delay of the logged power against the speed, −0.3 … 0.8 s;
2. the model's power passed through an exact first-order lag τ before the
   filter (rows within 5 s of a segment end left out, alike for every τ),
   against the second-order expansion the balance uses (``current_lag``, all rows);
3. the inertia-only and every-candidate held-out errors at other masses;
4. the route: residuals binned per 25 m of odometer distance, correlated between
   the rides at offsets −200 … 200 m, and the held-out error when the fit ride's
   grade profile (sin α per bin, from its residual) is carried to the other.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
from scipy.signal import savgol_coeffs

from euc_sim.rides.balance.design import NOMINAL, balance_design
from euc_sim.rides.balance.fit import fit_balance
from euc_sim.rides.grids.signals import RideAssumptions, ride_signals

DATA = Path(__file__).resolve().parents[2] / "shared" / "data" / "wheellog"
RIDES = (("2020_05_16_08_02_06.csv", 113.7), ("2020_05_28_07_52_00.csv", 110.9))
EVERY = list(NOMINAL) + ["rolling_resistance", "aerodynamic_drag", "drivetrain_idle_loss"]
G = 9.81


def signals(name: str, mass: float, shift: float = 0.0):
    """The ride's signals, its logged power advanced by ``shift`` s (undoing a delay)."""
    s = ride_signals(DATA / name, RideAssumptions(total_mass=mass, m_eq=mass))
    raw = s.raw.copy()
    t, seg, P = raw["t"].to_numpy(), raw["segment"].to_numpy(), raw["P"].to_numpy().copy()
    for k in np.unique(seg):
        i = seg == k
        if shift:
            P[i] = np.interp(t[i] + shift, t[i], raw["P"].to_numpy()[i])
    raw["P"] = P
    return dataclasses.replace(s, raw=raw)


def trimmed(d, seconds: float = 5.0, rate: float = 10.0):
    """The design without its rows within ``seconds`` of a segment end."""
    use = d.use.copy()
    n = int(seconds * rate)
    for k in np.unique(d.segment):
        idx = np.flatnonzero(d.segment == k)
        use[idx[:n]] = False
        use[idx[len(idx) - n:]] = False
    return dataclasses.replace(d, use=use)


def exact_lag(d, tau: float, rate: float = 10.0):
    """The design whose prediction passes a first-order lag τ (truncated at 5τ) before L₂."""
    if tau <= 0:
        return d
    n = int(np.ceil(5 * tau * rate)) + 1
    h = np.exp(-np.arange(n) / (tau * rate))
    causal = np.concatenate([np.zeros(n - 1), h / h.sum()])   # centred for numpy.convolve 'same'
    return dataclasses.replace(d, kernel=np.convolve(d.kernel, causal))


def series(d, tau: float, rate: float = 10.0):
    """The design with L₂ replaced by L₂ − τL₂′ + τ²L₂″ (the balance's ``current_lag``)."""
    n = len(d.kernel)
    k = (savgol_coeffs(n, 2) - tau * savgol_coeffs(n, 2, deriv=1, delta=1 / rate)
         + tau ** 2 * savgol_coeffs(n, 2, deriv=2, delta=1 / rate))
    return dataclasses.replace(d, kernel=k)


def heldout(fit_d, test_d, names) -> float:
    return fit_balance(fit_d, names, n_boot=0).rmse_on(test_d)


def timing() -> None:
    for (a, ma), (b, mb) in (RIDES, RIDES[::-1]):
        print(f"\n{a[:10]} -> {b[:10]}")
        for sh in (-0.3, 0.0, 0.1, 0.2, 0.4, 0.8):
            f, t = balance_design(signals(a, ma, sh)), balance_design(signals(b, mb, sh))
            print(f"  delay {sh:+.1f} s: inertia-only {heldout(f, t, NOMINAL):6.1f} W, "
                  f"every candidate {heldout(f, t, EVERY):6.1f} W")
        base_f, base_t = balance_design(signals(a, ma)), balance_design(signals(b, mb))
        for tau in (0.0, 0.2, 0.4):
            f, t = trimmed(exact_lag(base_f, tau)), trimmed(exact_lag(base_t, tau))
            sf, st = series(base_f, tau), series(base_t, tau)
            print(f"  lag {tau:.1f} s: exact {heldout(f, t, NOMINAL):6.1f} W "
                  f"(every candidate {heldout(f, t, EVERY):6.1f}); second-order series "
                  f"{heldout(sf, st, NOMINAL):6.1f} W")


def masses() -> None:
    for m in (80.0, 95.0, 113.7, 130.0):
        for (a, _), (b, _) in (RIDES, RIDES[::-1]):
            f, t = balance_design(signals(a, m)), balance_design(signals(b, m))
            full = fit_balance(f, EVERY, n_boot=0)
            nom = heldout(f, t, NOMINAL)
            print(f"  mass {m:5.1f} kg {a[5:10]}: inertia-only {nom:6.1f} W, every candidate "
                  f"{full.rmse_on(t):6.1f} W (ratio {full.rmse_on(t) / nom:.3f}), "
                  f"C_rr {full.estimate['rolling_resistance']:.3f}")


def _route(name: str, mass: float):
    """Odometer distance from the ride's start (m), every-candidate residual (W), speed, fit."""
    s = signals(name, mass)
    d = balance_design(s)
    full = fit_balance(d, EVERY, n_boot=0)
    dist = np.interp(d.t, s.raw["t"], s.raw["distance"])
    return dist - dist.min(), d.P - d.predict(full.estimate), d.v, full, d


def _binned(dist, x, off, w=25.0, length=1300.0):
    b = np.floor((dist + off) / w).astype(int)
    return np.array([x[b == i].mean() if (b == i).sum() > 3 else np.nan
                     for i in range(int(length / w))])


def _grade(dist, r, v, m, off, w=25.0, length=1300.0):
    """sin α per bin, least squares of the residual on m·g·v."""
    b = np.floor((dist + off) / w).astype(int)
    x = m * G * v
    return np.array([(r[b == i] * x[b == i]).sum() / ((x[b == i] ** 2).sum() + 1e-9)
                     if (b == i).sum() > 3 else 0.0 for i in range(int(length / w))])


def route() -> None:
    (a, ma), (b, mb) = RIDES
    A, B = _route(a, ma), _route(b, mb)
    for off in range(-200, 201, 50):
        x, y = _binned(A[0], A[1], off), _binned(B[0], B[1], 0)
        ok = np.isfinite(x) & np.isfinite(y)
        xv, yv = _binned(A[0], A[2], off), _binned(B[0], B[2], 0)
        print(f"  offset {off:+4d} m: residuals correlate {np.corrcoef(x[ok], y[ok])[0, 1]:+.2f}, "
              f"speeds {np.corrcoef(xv[ok], yv[ok])[0, 1]:+.2f}")
    for (F, mf, off_f), (T, off_t) in (((A, ma, 100), (B, 0)), ((B, mb, 0), (A, 100))):
        sa = _grade(F[0], F[1], F[2], mf, off_f)
        bins = np.clip(np.floor((T[0] + off_t) / 25.0).astype(int), 0, len(sa) - 1)
        r = T[4].P - T[4].predict(F[3].estimate)
        carried = r - mf * G * T[2] * sa[bins]
        print(f"  every candidate held out {np.sqrt(np.mean(r ** 2)):6.1f} W; with the fit ride's "
              f"grade profile {np.sqrt(np.mean(carried ** 2)):6.1f} W (sin α {sa.min():+.3f} to "
              f"{sa.max():+.3f})")


def main() -> int:
    if not DATA.is_dir():
        print(f"{DATA}: the WheelLog rides are not there")
        return 2
    print("1-2. timing of the logged current")
    timing()
    print("\n3. the mass handed to the balance")
    masses()
    print("\n4. the grade along the route (16 May is shifted by the offset)")
    route()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
