#!/usr/bin/env python
"""Showed which spatial coupling lateral_dynamics misses, by taking the 3-D physics apart at 1 kHz: docs/spatial.md.

Which spatial coupling does ``lateral_dynamics`` miss?  An ablation on noise-free 3-D rides.

Part 1, the physics at 1 kHz (no recording, no smoothing of the angles): the ride is
simulated by :func:`euc_sim.simulation.spatial.simulate_3d`; every step's full MuJoCo
state (qpos, qvel, ctrl) is captured as the loop hands it to ``mujoco.mj_step`` (wrapped
for the run; the loop and its physics are untouched, and the captured states are checked
against the run's recorded C) and re-evaluated with ``mj_forward``.  From the simulation's own planar
projection (x the travelled distance, γ, φ = γ + rider_pitch) the moment about P that
the planar model leaves out is, exactly,

    e = R F_x + F_γ + F_φ,   F = M q̈ + h − G (eq. 5),

and the wheel row R F_x − M_d.  What ``lateral_dynamics`` models
(:func:`effects.lateral_forces` + :func:`effects.rider_lean_forces`, coupling 1, the true
tilt, yaw and lean) is subtracted; the remainder is then compared with each candidate
computed from the MuJoCo state:

* ``torsional``: the tyre patch's moment (MuJoCo's torsional friction, condim 4) along
  the tilted axle e_a, e_a·τ_c;
* ``contact offset``: the moment of the floor's force about the plane's P = C − R e_u
  (the crowned tyre's contact point is not P), e_a·((p_c − P) × F_c);
* ``rider twist``: the rider's rotation with his twist rate (hinge ``rider_twist``)
  against the same without it, −e_a·d/dt(I_r ω_r) + e_a·d/dt(I_r (ω_r − q̇_twist n_r));
* ``gyroscopic``: every body's exact rotational term −e_a·d/dt(I_b ω_b) (full inertia
  tensors) less what the planar model and ``lateral_dynamics`` carry for it
  (the J-parts of the planar rows, of lateral_forces and of rider_lean_forces).

Part 2, the diagnosis's own view: the same ride recorded at 120 Hz without sensor noise,
``diagnose``'s residual at the true h with the lateral column at coupling 1, then with the
1 kHz truth's tilt/yaw inputs in place of the recording's 0.5 s Savitzky–Golay fits
(the planar projection of the 3-D state), and with the candidates added as columns.

    python studies/lateral_ablation.py [--paths circle slalom figure_eight] [--duration 20]
        [--rider-noise 0 3] [--seed 1] [--out /tmp/h22-3d/ablation]

Output: a table on stdout and ``ablation.json`` under ``--out``.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))


def capture_run(path: str, duration: float, rider_noise: float, seed: int, speed=None, radius=None):
    """simulate_3d's run and every step's (qpos, qvel, ctrl), captured by the control callback."""
    import mujoco

    from euc_sim.model.parameters import TABLE3
    from euc_sim.simulation.engine import default_rider
    from euc_sim.simulation.spatial import PATH_SPEEDS, default_lateral, simulate_3d

    states = []
    # the lateral rider is designed (and cached) before stepping is watched: its
    # linearisation steps the model too
    default_lateral(TABLE3, PATH_SPEEDS[path] if speed is None else float(speed), 1e-3)
    step = mujoco.mj_step

    def watched(m, d, *a, **k):        # the state each step starts from; physics untouched
        states.append((d.qpos.copy(), d.qvel.copy(), d.ctrl.copy()))
        return step(m, d, *a, **k)

    rider = default_rider(TABLE3, noise_std=rider_noise)
    mujoco.mj_step = watched
    try:
        run = simulate_3d(path, duration, rider=rider, seed=seed, speed=speed, radius=radius,
                          native=False)      # the Python loop: its mj_step calls are the capture
    finally:
        mujoco.mj_step = step
    N = len(run) - 1
    states = states[-N:]
    C = np.array([s[0][:3] for s in states])
    gap = float(np.max(np.abs(C - run[["C_X", "C_Y", "C_Z"]].to_numpy()[:N])))
    if gap > 1e-9:
        raise RuntimeError(f"captured states do not match the run (max |ΔC| {gap:.3g} m)")
    return run, states


def _rot_momentum(R_b, I_diag, w):
    """I_world ω for a body of principal inertia I_diag (body frame R_b, world ω)."""
    return R_b @ (I_diag * (R_b.T @ w))


def exact_terms(run, states, params):
    """Per 1 kHz step, N·m, as moments about the plane's P along the tilted axle e_a.

    ``e``: the planar model's gap R F_x + F_γ + F_φ (its rotational part ``planar_rot``,
    the J·α of the planar rows); ``true_trans`` Σ_b e_a·((r_b − P) × m_b (a_b − g)) and
    ``true_rot`` e_a·Σ_b d(I_b ω_b)/dt of the 3-D bodies (full inertia tensors);
    ``torsional`` and ``offset``, the floor's wrench about P; ``model`` (and its
    ``model_rot``) what ``lateral_dynamics`` carries; ``twist`` the rider's rotational term
    less the same without his twist rate.  Angular momentum about P gives the identity
    true_trans + true_rot = torsional + offset (``identity_gap``), and
    e − model = (e − true_trans − true_rot − model) + torsional + offset.
    """
    import mujoco

    from euc_sim.model import analytic
    from euc_sim.model.spatial import EucSpatial
    from euc_sim.simulation import effects

    sim = EucSpatial(params)
    m, d = sim.model, sim.data
    n = min(len(states), len(run) - 1)
    bid = {k: sim.body[k] for k in ("euc", "wheel", "rider")}
    I_b = {k: m.body_inertia[bid[k]].copy() for k in bid}
    mass = {k: float(m.body_mass[bid[k]]) for k in bid}
    it_v = sim.vadr["rider_twist"]
    tors, offs, lean, lean_d = (np.zeros(n) for _ in range(4))
    H = {k: np.zeros((n, 3)) for k in ("euc", "wheel", "rider", "rider0")}
    X = {k: np.zeros((n, 3)) for k in bid}
    ea_all, P_all = np.zeros((n, 3)), np.zeros((n, 3))
    for k in range(n):
        qp, qv, u = states[k]
        d.qpos[:], d.qvel[:], d.ctrl[:] = qp, qv, u
        mujoco.mj_forward(m, d)
        Re = d.xmat[bid["euc"]].reshape(3, 3)
        psi, theta, _ = sim.euler()
        e_a = Re[:, 1]
        e_u = np.array([np.sin(psi) * np.sin(theta), -np.cos(psi) * np.sin(theta), np.cos(theta)])  # Rz Rx e_z
        P = d.xpos[bid["euc"]] - params.R * e_u
        ea_all[k], P_all[k] = e_a, P
        for i in range(d.ncon):
            c = d.contact[i]
            if sim.tyre_geom in (c.geom1, c.geom2):
                f6 = np.zeros(6)
                mujoco.mj_contactForce(m, d, i, f6)
                fr = c.frame.reshape(3, 3)
                F, T = fr.T @ f6[:3], fr.T @ f6[3:]
                if F[2] < 0:                   # the floor's wrench on the tyre
                    F, T = -F, -T
                tors[k] = e_a @ T
                offs[k] = e_a @ np.cross(c.pos - P, F)
                break
        for b in bid:
            Rb = d.ximat[bid[b]].reshape(3, 3)
            w = d.cvel[bid[b], :3]             # world-frame angular velocity
            H[b][k] = Rb @ (I_b[b] * (Rb.T @ w))
            X[b][k] = d.xipos[bid[b]]
        Rr = d.ximat[bid["rider"]].reshape(3, 3)
        w0 = d.cvel[bid["rider"], :3] - qv[it_v] * d.xaxis[sim.model.jnt_dofadr.tolist().index(it_v)]
        H["rider0"][k] = Rr @ (I_b["rider"] * (Rr.T @ w0))
        lean[k] = qp[sim.qadr["rider_lean"]]
        lean_d[k] = qv[sim.vadr["rider_lean"]]
    dt = float(run["t"].iloc[1] - run["t"].iloc[0])
    along = lambda V: np.einsum("ij,ij->i", ea_all, V)                        # noqa: E731
    dHdt = {k: along(np.gradient(V, dt, axis=0)) for k, V in H.items()}
    g = np.array([0.0, 0.0, -params.g])
    true_trans = sum(along(np.cross(X[b] - P_all, mass[b] * (np.gradient(np.gradient(X[b], dt, axis=0), dt, axis=0) - g)))
                     for b in bid)
    true_rot = dHdt["euc"] + dHdt["wheel"] + dHdt["rider"]
    r = run.iloc[:n]
    q = r[["x", "gamma", "phi"]].to_numpy()
    qd = r[["x_dot", "gamma_dot", "phi_dot"]].to_numpy()
    qdd = np.gradient(qd, dt, axis=0)
    th = r["theta"].to_numpy(); th_d = r["theta_dot"].to_numpy()
    th_dd = np.gradient(th_d, dt)
    ps_d = r["psi_dot"].to_numpy(); ps_dd = np.gradient(ps_d, dt)
    lam_dd = np.gradient(lean_d, dt)
    F = (np.einsum("nij,nj->ni", analytic.mass_matrix(params, q), qdd) + analytic.nonlinear_terms(params, q, qd)
         - analytic.gravity_forces(params, q))
    e = analytic.moment_about_contact(params, F)

    def lat(p):
        return (effects.lateral_forces(p, q, qd, th, th_d, ps_d, ps_dd)
                + effects.rider_lean_forces(p, q, qd, th, th_d, ps_d, ps_dd, lean, lean_d, lam_dd, th_dd))

    Q = lat(params)
    # both terms are linear in the inertias: their rotational part is lat(2J) − lat(J)
    Q2 = lat(params.replace(J=2 * params.J, J0=2 * params.J0, Jw=2 * params.Jw))
    model = analytic.moment_about_contact(params, Q)
    model_rot = analytic.moment_about_contact(params, Q2 - Q)
    planar_rot = params.J * qdd[:, 2] + params.J0 * qdd[:, 1] + params.Jw * qdd[:, 0] / params.R
    # per body: planar − exact − modelled translational moment (everything is linear in each mass)
    per_body = {}
    for b, key in (("wheel", "mw"), ("euc", "m0"), ("rider", "m")):
        pb = params.replace(**{key: 2 * getattr(params, key)})
        Fb = (np.einsum("nij,nj->ni", analytic.mass_matrix(pb, q), qdd) + analytic.nonlinear_terms(pb, q, qd)
              - analytic.gravity_forces(pb, q))
        planar_b = analytic.moment_about_contact(params, Fb) - e
        true_b = along(np.cross(X[b] - P_all, mass[b] * (np.gradient(np.gradient(X[b], dt, axis=0), dt, axis=0) - g)))
        per_body[f"trans_err_{b}"] = planar_b - true_b - analytic.moment_about_contact(params, lat(pb) - Q)
    for b, key in (("wheel", "Jw"), ("euc", "J0"), ("rider", "J")):
        pb = params.replace(**{key: 2 * getattr(params, key)})
        planar_b = {"Jw": params.Jw * qdd[:, 0] / params.R, "J0": params.J0 * qdd[:, 1], "J": params.J * qdd[:, 2]}[key]
        per_body[f"rot_err_{b}"] = planar_b - dHdt[b] - analytic.moment_about_contact(params, lat(pb) - Q)
    # the fix (euc_sim.model.rider_spatial): the rider's translation from G itself in place of
    # the modelled one, and his slender rotation (the upright (J_z − J) term) added
    from euc_sim.model.rider_spatial import plane_coordinates, rider_translation_forces
    dd = lambda y: np.gradient(np.gradient(y, dt, axis=0), dt, axis=0)        # noqa: E731
    psi = r["psi"].to_numpy()
    xi, zeta = plane_coordinates(X["rider"], r[["C_X", "C_Y", "C_Z"]].to_numpy(), psi, th, params.R,
                                 q[:, 1], lean, params.l0)
    Q_rider = lat(params.replace(m=2 * params.m)) - Q
    Q_new = Q - Q_rider + rider_translation_forces(params, q, psi, th, qdd[:, 0], dd(xi), dd(zeta), dd(X["rider"]))
    Q_new[:, 2] -= effects.upright_slender_moment(params, q[:, 2], th, th_d, ps_d)
    per_body["model_new"] = analytic.moment_about_contact(params, Q_new)
    # the same with G in the plane from q and the true h (the planar model's own G)
    xi_q = -params.l0 * np.sin(q[:, 1]) + params.h * np.sin(q[:, 2])
    zeta_q = -params.l0 * np.cos(q[:, 1]) + params.h * np.cos(q[:, 2])
    Q_q = Q - Q_rider + rider_translation_forces(params, q, psi, th, qdd[:, 0], dd(xi_q), dd(zeta_q), dd(X["rider"]))
    Q_q[:, 2] -= effects.upright_slender_moment(params, q[:, 2], th, th_d, ps_d)
    per_body["model_new_q"] = analytic.moment_about_contact(params, Q_q)
    return {**per_body, "t": r["t"].to_numpy(), "e": e, "model": model, "model_rot": model_rot,
            "planar_rot": planar_rot, "true_trans": true_trans, "true_rot": true_rot,
            "torsional": tors, "offset": offs, "twist": -(dHdt["rider"] - dHdt["rider0"]),
            "slender": analytic.moment_about_contact(params, np.stack(
                [np.zeros(n), np.zeros(n), -effects.upright_slender_moment(params, q[:, 2], th, th_d, ps_d)], -1)),
            "identity_gap": true_trans + true_rot - tors - offs}


def _smooth(y, dt, sigma=0.02):
    from scipy.ndimage import gaussian_filter1d
    return gaussian_filter1d(np.asarray(y, float), sigma / dt, mode="nearest")


def part1(terms, dt, trim=1.0):
    """RMS (N·m) of each piece and of the remainder with each candidate added at coefficient 1."""
    keep = slice(int(trim / dt), len(terms["e"]) - int(trim / dt))
    S = {k: _smooth(v, dt)[keep] for k, v in terms.items() if k != "t"}
    rms = lambda y: float(np.sqrt(np.mean(y ** 2)))                         # noqa: E731
    rem = S["e"] - S["model"]
    miss_rot = S["planar_rot"] - S["true_rot"]              # what the rotations leave out of the plane
    miss_trans = (S["e"] - S["planar_rot"]) - S["true_trans"]
    rows = {
        "identity check |true_trans + true_rot − torsional − offset|": rms(S["identity_gap"]),
        "e, the planar model's gap": rms(S["e"]),
        "remainder after lateral_dynamics (coupling 1)": rms(rem),
        "  its translational part (exact − modelled)": rms(miss_trans - (S["model"] - S["model_rot"])),
        "  its rotational part (exact − modelled)": rms(miss_rot - S["model_rot"]),
        "  the floor's wrench about P (torsional + offset)": rms(S["torsional"] + S["offset"]),
        "+ tyre torsional moment": rms(rem - S["torsional"]),
        "+ contact offset": rms(rem - S["offset"]),
        "+ rider twist": rms(rem - S["twist"]),
        "+ upright slender rider": rms(rem - S["slender"]),
        "+ exact rotations (gyroscopic, full inertia)": rms(rem - (miss_rot - S["model_rot"])),
        "+ exact translations": rms(rem - (miss_trans - (S["model"] - S["model_rot"]))),
    }
    for k in sorted(S):
        if k.startswith(("trans_err_", "rot_err_")):
            rows[f"  {k}"] = rms(S[k])
            rows[f"+ exact {k[:-len(k.split('_')[-1]) - 1].replace('_err', '')} of the {k.split('_')[-1]}"] = rms(rem - S[k])
    rows["+ the rider's exact translation + upright slender rotation"] = rms(
        rem - S["trans_err_rider"] - S["slender"])
    rows["remainder with G's marker translation + slender (model.rider_spatial)"] = rms(S["e"] - S["model_new"])
    rows["same, G in the plane from q and the true h"] = rms(S["e"] - S["model_new_q"])
    rows["+ those + the rider's twist"] = rms(rem - S["trans_err_rider"] - S["slender"] - S["twist"])
    rows["+ those + the floor's wrench (torsional, offset)"] = rms(
        rem - S["trans_err_rider"] - S["slender"] - S["twist"] - S["torsional"] - S["offset"])
    fits = {}
    for name, col in (("s old", S["model"]), ("s new", S["model_new"]),
                      ("s new + twist", S["model_new"] + S["twist"])):
        fits[name] = float(col @ S["e"] / (col @ col))      # the coupling a fit would give
    for name in ("torsional", "offset", "twist", "slender"):
        c = S[name]
        fits[name] = float(c @ rem / (c @ c)) if c @ c > 0 else 0.0
    return rows, fits


def part2(run, params, truth_inputs: bool, truth_q: bool = False, wheel_row: bool = True) -> dict:
    """The diagnosis's view of the same ride, recorded at 120 Hz without sensor noise: the
    coupling s fitted with h (1 for the physics), the estimate √s·(band peak of the recorded
    tilt) against the truth (band peak of the 1 kHz tilt), and the remainder, N·m.

    ``truth_inputs``: the tilt and yaw inputs (ϑ, ϑ̇, ψ̇, ψ̈) are the 1 kHz truth at the
    samples instead of the recording's 0.5 s Savitzky–Golay fits; ``truth_q``: the planar
    state (x, γ, φ and rates) is the simulation's own instead of the Section 2 pipeline's
    projection of the markers; ``wheel_row`` False: M_d taken as unrecorded (the kinematic
    row M_d,1 − M_d,2 alone)."""
    from dataclasses import replace

    from euc_sim.diagnosis.candidates import build_problem
    from euc_sim.diagnosis.common import H_BOUNDS
    from euc_sim.diagnosis.prepare import prepare
    from euc_sim.diagnosis.residual import residual_model
    from euc_sim.identification import regression as reg
    from euc_sim.simulation import effects
    from euc_sim.simulation.spatial import spatial_recording

    rec = spatial_recording(run, noise="none", seed=0, hide_torques=not wheel_row)
    prep = prepare(rec, params.replace(h=0.6), {"name": "ablation"})
    if truth_inputs:
        t = prep.kin.t
        ts = run["t"].to_numpy()
        tr = {"theta": run["theta"].to_numpy(), "theta_d": run["theta_dot"].to_numpy(),
              "psi_d": run["psi_dot"].to_numpy()}
        tr["psi_dd"] = np.gradient(tr["psi_d"], ts)
        lat = dict(prep.lateral)
        lat.update({k: np.interp(t, ts, v) for k, v in tr.items()})
        prep = replace(prep, lateral=lat)
    if truth_q:
        ts = run["t"].to_numpy()
        qs = run[["x", "gamma", "phi"]].to_numpy()
        qds = run[["x_dot", "gamma_dot", "phi_dot"]].to_numpy()
        at = lambda a: np.column_stack([np.interp(prep.kin.t, ts, a[:, i]) for i in range(3)])   # noqa: E731
        prep = prep.with_kin(at(qs), at(qds), at(np.gradient(qds, ts, axis=0)))
    model = residual_model(prep)
    time_ = np.concatenate([prep.kin.t[prep.keep]] * (2 if model.W is not None else 1))
    h = reg.fit_set(reg.Problem(model, {}, time_, H_BOUNDS), ()).h
    for _ in range(4):                          # columns at the augmented h, as diagnose does
        problem, info = build_problem(prep, h)
        sub = reg.Problem(model, {"lateral_dynamics": problem.candidates["lateral_dynamics"]}, time_, H_BOUNDS)
        fit = reg.fit_set(sub, ("lateral_dynamics",))
        if abs(fit.h - h) < 1e-4:
            break
        h = fit.h
    s_fit = float(fit.theta["lateral_dynamics"][0])
    truth = effects.band_peak_tilt(run["theta"].to_numpy(), float(run["t"].iloc[1] - run["t"].iloc[0]))
    est = info["lateral_dynamics"]["scale"] * np.sqrt(max(s_fit, 0.0))
    return {"s": s_fit, "h": float(fit.h), "estimate": float(est), "truth": float(truth),
            "error_pct": float(100 * (est - truth) / truth), "remainder": float(np.sqrt(fit.rss / fit.n))}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--paths", nargs="+", default=["circle", "slalom", "figure_eight"])
    ap.add_argument("--duration", type=float, default=20.0)
    ap.add_argument("--rider-noise", type=float, nargs="+", default=[0.0, 3.0])
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--out", type=Path, default=Path("/tmp/h22-3d/ablation"))
    args = ap.parse_args(argv)
    from euc_sim.model.parameters import TABLE3
    args.out.mkdir(parents=True, exist_ok=True)
    report = []
    for rn in args.rider_noise:
        for path in args.paths:
            t0 = time.perf_counter()
            run, states = capture_run(path, args.duration, rn, args.seed)
            terms = exact_terms(run, states, TABLE3)
            dt = float(terms["t"][1] - terms["t"][0])
            rows, fits = part1(terms, dt)
            p2 = {"recorded inputs": part2(run, TABLE3, False), "truth tilt/yaw inputs": part2(run, TABLE3, True),
                  "truth planar state": part2(run, TABLE3, False, True),
                  "no wheel row (M_d hidden)": part2(run, TABLE3, False, False, False),
                  "no wheel row, truth state and inputs": part2(run, TABLE3, True, True, False)}
            for k, v in p2.items():
                rows[f"diagnose view, {k}: s / error / remainder"] = v
            report.append({"path": path, "rider_noise": rn, "part1": rows, "fitted_coef": fits,
                           "seconds": time.perf_counter() - t0})
            print(f"\n{path}, rider noise {rn:g} N·m ({time.perf_counter() - t0:.0f} s)")
            for k, v in rows.items():
                if isinstance(v, dict):
                    print(f"  {k:<45} s {v['s']:.3f}, h {v['h']:.3f} m, estimate {v['error_pct']:+.1f} %, "
                          f"remainder {v['remainder']:.4f} N·m")
                else:
                    print(f"  {k:<45} {v:.4f} N·m")
            print("  fitted coefficients: " + ", ".join(f"{k} {v:+.2f}" for k, v in fits.items()))
    (args.out / "ablation.json").write_text(json.dumps(report, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
