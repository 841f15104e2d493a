"""One ride's mass, drivetrain, PWM and cut-out envelope, as the ride JSON carries them.

:func:`drivetrain_report` runs :mod:`euc_sim.rides.drive.mass` and
:mod:`euc_sim.rides.drive.drivetrain` on a log (and, with ``compare``, predicts the
other ride's battery power and PWM from this one's fit) and returns the
CONTRACT's ``total_mass``, ``drivetrain`` and ``pwm`` objects plus the
``envelope``.  :func:`plot_envelope` draws the envelope's figure (the page draws the
PWM model's: :func:`euc_sim.rides.report.fit_figures.pwm_figure`).  The rider's stated weight is never read.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from euc_sim.io import save_figure
from euc_sim.rides.balance.verdict import unit_label
from euc_sim.rides.drive.drivetrain import Drivetrain, envelope, fit_drivetrain, predict_pwm
from euc_sim.rides.drive.grade import GradeProfile, grade_profile
from euc_sim.rides.drive.mass import MassFit, fit_mass, predict_power
from euc_sim.rides.drive.pwm import no_force_speed
from euc_sim.rides.drive.rotating import without_rotating_inertia
from euc_sim.rides.grids.power import G, MassSettings, PowerSignals, power_signals
from euc_sim.rides.source.ride import Ride
from euc_sim.rides.source.sanity import input_warnings, mass_suspicion
from euc_sim.rides.source.spec import WheelSpec
from euc_sim.rides.source.systematic import mass_difference

__all__ = ["RideDrivetrain", "analyse", "drivetrain_report", "ride_drivetrain", "cutout_of", "plot_envelope", "envelope_figure",
           "page_section", "TYRE_MU",
           "COMPUTED_PWM_RMS", "computed_pwm_note"]

#: A logged duty that its model explains better than this, percentage points, is
#: taken to be computed by the app from speed and voltage, not measured.
COMPUTED_PWM_RMS = 0.3


@dataclass(frozen=True)
class RideDrivetrain:
    """Everything identified on one ride (see :func:`analyse`)."""

    path: str
    sig: PowerSignals
    mass: MassFit
    drivetrain: Drivetrain
    spec: WheelSpec
    grade: GradeProfile | None = None


def analyse(log: Ride, spec: WheelSpec = WheelSpec(), settings: MassSettings = MassSettings()
            ) -> RideDrivetrain:
    """Filter and fit one ride (mass, then drivetrain, then the grade it implies)."""
    sig = power_signals(log, settings)       # the ride keeps its grid: built once
    m_eq = fit_mass(log, settings, sig=sig)
    # the drivetrain balances power with m_eq (eq. 6): the rotating inertia is accelerated too
    dt = fit_drivetrain(sig, m_eq, radius=spec.radius, n_boot=max(10, settings.n_boot // 2),
                        seed=settings.seed)
    alt = log.data["gps_alt"].to_numpy(float) if "gps_alt" in log.data else None
    grade = None if alt is None else grade_profile(sig, m_eq, log.data["t"].to_numpy(float), alt)
    return RideDrivetrain(log.path, sig, without_rotating_inertia(m_eq, spec.wheel_mass), dt, spec, grade)


def _rms(x: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.square(x)))) if x.size else float("nan")


def computed_pwm_note(r: RideDrivetrain) -> str | None:
    """Why the logged duty of ``r`` is taken as computed by the app, or None if measured."""
    if r.drivetrain.pwm_coef is None:
        return None
    pred, obs = predict_pwm(r.sig, r.drivetrain.pwm_coef)
    rms = _rms(pred - obs)
    if rms < COMPUTED_PWM_RMS:
        return (f"the logged duty follows speed and voltage to {rms:.2f} percentage points: "
                f"the app computes it, it is not measured; the resistive drop is not identified")
    return None


def _total_mass(r: RideDrivetrain) -> dict:
    m = r.mass
    why = mass_suspicion(m.estimate)
    if why is not None:                 # never a confident absurd mass
        m = dataclasses.replace(m, estimate=None, ci95=None, stat_ci95=None, why=why, by_window={},
                                equivalent={})
    out = {"estimate": m.estimate, "ci95": list(m.ci95) if m.ci95 else None,
           "unit": "kg", "lag_s": m.lag, "speed_scale": m.scale.estimate, "speed_scale_source": m.scale.source,
           "signed_current": m.signed, "terms": m.terms, "balance": m.history,
           "n_samples": m.n_samples,
           "by_window": [{"window_s": w, "estimate": x} for w, x in m.by_window.items()],
           "equivalent_mass": m.equivalent or None,
           "systematic": dict(m.systematic) if m.estimate is not None else None,
           "statistical_ci95": list(m.stat_ci95) if m.stat_ci95 else None,
           "copper_column": m.copper_column}
    if m.estimate is None:
        out["why"] = m.why
    if r.spec.wheel_mass is not None and m.estimate is not None:
        out["rider_mass"] = {"estimate": m.estimate - r.spec.wheel_mass,
                             "ci95": [x - r.spec.wheel_mass for x in m.ci95] if m.ci95 else None,
                             "note": "total minus the spec's net weight (rider with gear)"}
    else:
        out["rider_mass"] = None
        out["rider_mass_why"] = ("no wheel weight (give --wheel SPEC.csv or --wheel-mass)"
                                 if m.estimate is not None else m.why)
    return out


def _envelope(r: RideDrivetrain, computed_note: str | None) -> dict:
    """The cut-out envelope, or why there is none (``computed_note``: :func:`computed_pwm_note`)."""
    dt = r.drivetrain
    if dt.pwm_coef is None or not dt.mass:
        return {"why": "needs the PWM model and the mass: "
                       + (dt.unidentified.get("pwm") or r.mass.why or "unavailable")}
    if computed_note:
        return {"why": computed_note}
    V = r.spec.battery_voltage or (dt.battery_coef["E0"] if dt.battery_coef else None)
    src = "spec" if r.spec.battery_voltage else "open-circuit voltage fitted at the ride's start"
    v_zero = no_force_speed(dt.pwm_coef, V)
    env = envelope(dt, V, v_max=1.05 * v_zero if v_zero else 2.0 * float(np.nanmax(r.sig.v)))
    env["voltage_source"] = src
    env["ride_top_speed"] = float(np.nanmax(r.sig.v))
    return env


def drivetrain_report(log: Ride, spec: WheelSpec = WheelSpec(), compare=None,
                      settings: MassSettings = MassSettings(), fitted: RideDrivetrain | None = None
                      ) -> tuple[dict, RideDrivetrain, RideDrivetrain | None]:
    """The ride JSON's ``total_mass``, ``drivetrain``, ``pwm``, ``envelope`` and ``wheel``.

    Parameters
    ----------
    log : Ride
        The ride.
    spec : WheelSpec
        Wheel radius, weight, voltage where known.
    compare : Ride, optional
        Another ride of the same wheel: its battery power and PWM are predicted
        from this ride's fit (held out).
    settings : MassSettings
    fitted : RideDrivetrain, optional
        :func:`analyse` of ``log`` already done.

    Returns
    -------
    report : dict
    fit, test : RideDrivetrain
        The analyses (``test`` None without ``compare``).
    """
    r = fitted or analyse(log, spec, settings)
    dtj = r.drivetrain.as_json()
    note = computed_pwm_note(r)
    if note:
        dtj["resistive_drop"] = {"estimate": None, "ci95": None, "unit": "V/N", "why": note}
        dtj.pop("winding_resistance", None)
    rep = {"total_mass": _total_mass(r), "drivetrain": dtj, "envelope": _envelope(r, note),
           "input_warnings": input_warnings(log, r.spec, r.mass.scale),
           "wheel": r.spec.as_json(), "unidentified": dict(r.drivetrain.unidentified),
           "grade": (r.grade.as_json() if r.grade is not None else
                     {"why": "no GPS altitude, or no mass identified: no implied grade"})}
    test = None
    if compare is not None:
        test = analyse(compare, spec, settings)
        rep["mass_difference"] = mass_difference(r.mass, test.mass)
        pred, obs = predict_power(test.sig, r.mass)
        rep["power_heldout"] = {"rmse": _rms(pred - obs), "rms_power": _rms(obs), "unit": "W"}
        if r.drivetrain.pwm_coef is not None and "pwm" in test.sig.extra:
            pp, po = predict_pwm(test.sig, r.drivetrain.pwm_coef)
            rep["pwm"] = {"heldout_rmse": _rms(pp - po), "unit": "%"}
            if note:
                rep["pwm"]["note"] = note
        else:
            rep["pwm"] = {"heldout_rmse": None, "unit": "%",
                          "why": "no PWM or safety-margin column in "
                                 + (compare.name if r.drivetrain.pwm_coef else log.name)}
    return rep, r, test


def cutout_of(r: RideDrivetrain, log, limits: dict):
    """The ride's :class:`euc_sim.rides.drive.cutout.Cutout` (the JSON's ``cutout``).

    Parameters
    ----------
    r : RideDrivetrain
    log : Ride
        The same ride parsed: its battery reading (%) gives the charge.
    limits : dict
        The summary's ``limits``.
    """
    from euc_sim.rides.drive.cutout import Limits, ride_cutout

    d = log.data
    charge = None
    if "battery" in d:
        ok = np.isfinite(d["battery"].to_numpy(float))
        if ok.sum() > 1:
            charge = np.interp(r.sig.t, d["t"].to_numpy(float)[ok], d["battery"].to_numpy(float)[ok])
    why = ("the log's PWM is the app's computation from speed and voltage, not a measurement: it does "
           "not show the load, so neither does a model of it") if computed_pwm_note(r) else None
    return ride_cutout(r.sig, r.drivetrain, r.mass, charge, Limits(**limits), r.spec.battery_voltage, why)


#: Tyre-road friction coefficient the envelope figure assumes (dry asphalt, about 1):
#: no tyre carries a sustained acceleration above μ·g, whatever the motor could give.
TYRE_MU = 1.0


def plot_envelope(env: dict, path, title: str = "") -> Path:
    """Write :func:`envelope_figure` to ``path`` (PNG, atomically)."""
    return save_figure(envelope_figure(env, title), path)


def envelope_figure(env: dict, title: str = ""):
    """The acceleration the battery voltage allows (and the lean it takes) against speed.

    Full and low charge.  The voltage limit is drawn only where it is below what the
    tyre can carry (a ≤ :data:`TYRE_MU`·g, lean atan(μ)); above, the model says
    nothing (the controller's current limit, not in the log, or the tyre's grip
    decides) and the figure says so.

    Returns
    -------
    matplotlib.figure.Figure
    """
    from matplotlib.figure import Figure

    v = np.asarray(env["speed"]) * 3.6
    a_tyre = TYRE_MU * G
    fig = Figure(figsize=(9, 4.6), layout="constrained")
    ax = fig.add_subplot()
    clipped = False
    for name, style in (("full", "-"), ("low", "--")):
        a = np.asarray(env[name]["accel"], float)
        clipped |= bool(np.any(a > a_tyre))
        ax.plot(v, np.where(a <= a_tyre, a, np.nan), style,
                label=f"{name} charge ({env[name]['voltage']:.0f} V): voltage limit")
    ax.axhline(a_tyre, color="k", lw=1.0, ls=":",
               label=f"tyre grip, μ ≈ {TYRE_MU:g}: at most {a_tyre:.1f} m/s²")
    if clipped:
        ax.axhspan(a_tyre, 1.15 * a_tyre, color="tab:red", alpha=0.08, lw=0,
                   label="above the tyre's grip: the model\nsays nothing, not drawn")
    top = env.get("ride_top_speed")
    if top is not None and top * 3.6 < v[-1]:
        ax.axvspan(top * 3.6, v[-1], color="grey", alpha=0.15,
                   label="faster than this ride: extrapolated")
    ax.set_ylim(0.0, 1.15 * a_tyre)
    ax.set_xlim(0.0, v[-1])
    ax.set_xlabel("speed, km/h")
    ax.set_ylabel("acceleration the voltage allows, m/s²")
    sec = ax.secondary_yaxis("right", functions=(lambda a: np.degrees(np.arctan(np.asarray(a) / G)),
                                                 lambda d: G * np.tan(np.radians(d))))
    sec.set_ylabel("forward lean it takes, deg")
    ax.set_title("Upper bound only: the controller's current limit is not in the log and can be "
                 "lower;\nwhere the voltage would allow more than the tyre carries, the model says "
                 "nothing (not drawn)", fontsize=8)
    fig.suptitle(title or "Cut-out envelope: the acceleration left at full duty (100 %) against speed",
                 fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(loc="upper left", bbox_to_anchor=(1.12, 1.0), fontsize=8, borderaxespad=0.0)
    return fig


#: A systematic part of the mass's interval (``total_mass.systematic``) in people's words:
#: ``efficiency_model`` is the choice of copper-loss column (κ·F² or its proxy κ·a²).
SYSTEMATIC_WORDS = {"efficiency_model": "copper-loss model (κ·F² or κ·a²)",
                    "rotating_share": "rotating inertia's share"}


def _mass_md(rep: dict, shown=frozenset()) -> list[str]:
    """The page's lines on the total mass, its interval's parts, warnings and the difference;
    the total mass itself not repeated where ``shown`` (the first screen) has it."""
    tm = rep["total_mass"]
    md = ["## What the wheel weighs with its rider, and how close to a cut-out", ""]
    if tm["estimate"] is None:
        md.append(f"- Total mass (rider + wheel): **not identified**: {tm['why']}.")
    else:
        ci = tm["ci95"]
        eq = tm.get("equivalent_mass")
        value = ("in the key figures above" if "total_mass" in shown else
                 f"**{tm['estimate']:.0f} kg**, 95 % interval " + (f"{ci[0]:.0f}–{ci[1]:.0f} kg" if ci else "–"))
        md.append("- Total mass (rider + wheel"
                  + ("" if eq else ", with the wheel's rotating inertia: no net weight given")
                  + f"): {value} (from battery power alone; speed scale {tm['speed_scale']:.3f}, "
                    f"{tm['speed_scale_source']}; current–speed delay {tm['lag_s']:+.1f} s).")
        if eq:
            md.append(f"- The energy balance finds m_eq = {eq['estimate']:.0f} kg (eq. 6: it also "
                      f"accelerates the wheel's rotating inertia J_w/R², taken as "
                      f"{eq['rotating_inertia']:.1f} kg, {eq['rotating_inertia_range'][0]:.1f}–"
                      f"{eq['rotating_inertia_range'][1]:.1f} kg, from the net weight).")
        if tm.get("systematic") and tm.get("statistical_ci95"):
            st = tm["statistical_ci95"]
            md.append(f"- The interval is the bootstrap's ({st[0]:.0f}–{st[1]:.0f} kg) with what the "
                      f"log cannot calibrate added in quadrature (95 % half-widths: " + ", ".join(
                          f"{SYSTEMATIC_WORDS.get(k, k.replace('_', ' '))} {v:.1f} kg"
                          for k, v in tm["systematic"].items()) + ").")
        if tm.get("by_window"):
            md.append("- Energy balance over windows of " + ", ".join(
                f"{w['window_s']:g} s: {w['estimate']:.0f} kg" for w in tm["by_window"])
                + " (the interval pools them: the log cannot choose one).")
        if tm.get("rider_mass"):
            md.append(f"- Rider with gear: {tm['rider_mass']['estimate']:.0f} kg "
                      f"(total minus the spec's net weight).")
    for w in rep.get("input_warnings", []):
        md.append(f"- **Warning**: {w}.")
    d = rep.get("mass_difference")
    said = any(x.get("name") == "total_mass" and (x.get("independent") or {}).get("ci95")
               for x in rep.get("differences") or [])
    if d and said:                  # the differences' block says it, once
        md.append("- The compared ride minus this one: in 'What differs in the compared ride' above.")
    elif d:
        md.append("- The compared ride minus this one: " + (
            f"**{d['estimate']:+.0f} kg**, 95 % interval {d['ci95'][0]:+.0f} to {d['ci95'][1]:+.0f} "
            f"kg: **{d['verdict']}**" if d.get("estimate") is not None else
            f"**cannot tell** ({d.get('why', '')})") + ".")
    return md


def page_section(rep: dict, figures: dict, shown=frozenset()) -> list[str]:
    """Markdown lines for the ride page: mass, balance by term, grade, PWM, envelope.

    ``shown``: the quantities the page's first screen already gives (``total_mass``,
    ``internal_resistance``, ``top_speed``; ``pwm_heldout``, the compared ride's PWM check, in
    its limits' section), said here without their numbers.
    """
    md = _mass_md(rep, shown)
    sel = rep.get("selection") or []
    if sel:
        md += ["", "How the balance was chosen (the one selection rule of the page): the fit "
                   "ride's error on each of its own five time blocks, fitted on the other four, "
                   "after each kept term. These are not the held-out errors of the verdict, "
                   "which are scored on the ride held out:", "",
               "| step | fit ride, blocked RMS, " + rep.get("error_unit", "W") + " |", "|---|---|"]
        md += [f"| + {h['term']} | {h['heldout_rmse']:.0f} |" for h in sel]
    dt = rep["drivetrain"]
    md += ["", "| drivetrain term | estimate | 95 % interval | unit |", "|---|---|---|---|"]
    for name, t in dt.items():
        if "parameter" in t:            # a balance-fit parameter: in the Estimates table
            continue
        if t.get("estimate") is None:
            md.append(f"| {name} | not identified | {t.get('why', '')} | |")
        elif name in shown:
            md.append(f"| {name} | in the key figures above | | {unit_label(t['unit'])} |")
        else:
            ci = t.get("ci95")
            md.append(f"| {name} | {t['estimate']:.4g} | "
                      + (f"{ci[0]:.4g} – {ci[1]:.4g}" if ci else "–") + f" | {unit_label(t['unit'])} |")
    md += _nuisance_note(dt)
    g = rep.get("grade", {})
    if "rms_implied_vs_gps_m" in g:
        md += ["", f"Road grade as the battery sees it: integrating the power the balance "
                   f"leaves unexplained without its grade term, over {g['distance_km']:.1f} km, "
                   f"gives an altitude {g['rms_implied_vs_gps_m']:.0f} m RMS from GPS altitude "
                   f"(ascent {g['ascent_implied_m']:.0f} m against GPS's "
                   f"{g['ascent_gps_m']:.0f} m)."]
    if "grade" in figures:
        md += ["", f"![altitude implied by the balance against GPS altitude]({figures['grade']})"]
    if rep.get("pwm"):
        p = rep["pwm"]
        md += ["", "PWM of the other ride predicted from this one: "
                   + ("in 'Your wheel's limit and the cut-out' above" if "pwm_heldout" in shown else
                      f"**{p['heldout_rmse']:.1f} percentage points RMS**" if p.get("heldout_rmse")
                      is not None else f"not available ({p.get('why', '')})")]
    if "pwm" in figures:
        md += ["", f"![PWM predicted against logged]({figures['pwm']})"]
    env = rep["envelope"]
    if "speed" in env:
        end = env["speed"][-1] * 3.6

        def left(name):
            x = env[name]["v_limit"]
            return (f"none is left above {x * 3.6:.0f} km/h" if x is not None else
                    f"some is still left at {end:.0f} km/h, the figure's end")
        md += ["", f"Envelope (voltage limit): at full charge ({env['full']['voltage']:.0f} V) "
                   f"{left('full')}; at low charge ({env['low']['voltage']:.0f} V) {left('low')}. "
                   + ("Faster than this ride's top speed (in the key figures above)" if "top_speed" in shown
                      else f"This ride's top speed was {env.get('ride_top_speed', float('nan')) * 3.6:.0f} "
                           f"km/h: faster than that")
                   + " the envelope is extrapolated (shaded)."]
    else:
        md += ["", f"Envelope: {env.get('why', 'not available')}."]
    if "envelope" in figures:
        md += ["", f"![cut-out envelope]({figures['envelope']})"]
    for name, why in rep.get("unidentified", {}).items():
        if (dt.get(name) or {}).get("estimate") is not None or name not in dt:   # else said in the table
            md.append(f"- Not identified, {name}: {why}.")
    return md + [""]


def ride_drivetrain(log, compare=None, spec=None, n_boot: int = 200, seed: int = 0):
    """Mass, drivetrain, PWM and envelope of a ride log, as ``euc-sim ride`` reports them.

    Parameters
    ----------
    log, compare : Ride
        The fit ride and, optionally, the held-out ride.
    spec : WheelSpec, optional
        The wheel's specification (default: none known).
    n_boot : int
        Bootstrap replicates of the mass fit.
    seed : int
        Seed of the bootstrap draws.

    Returns
    -------
    tuple
        :func:`drivetrain_report`'s (report, fit, test).
    """
    from euc_sim.rides.grids.power import MassSettings
    from euc_sim.rides.source.spec import WheelSpec

    return drivetrain_report(log, spec or WheelSpec(), compare, MassSettings(n_boot=n_boot, seed=seed))


def _nuisance_note(dt: dict) -> list[str]:
    """What the drivetrain table's terms that read the balance's physics again are: the mass
    fit's own copper and grade terms, and the PWM's phase resistance beside the copper loss's."""
    has = lambda k: dt.get(k, {}).get("estimate") is not None  # noqa: E731
    own = [k for k in ("winding_resistance", "copper_loss_per_force2", "copper_loss_per_accel2",
                       "grade_mass") if has(k)]
    out = []
    if own:
        what = " and ".join(x for x, k in (("the copper loss", own[0] != "grade_mass"),
                                            ("the climb", "grade_mass" in own)) if k)
        verb = "is the mass fit's own term" if len(own) == 1 else "are the mass fit's own terms"
        out.append(f"{' and '.join(own)} {verb} (how its energy balance holds {what} while it "
                   f"finds the mass); the ride's one balance model gives {what} in Estimates.")
    if has("winding_resistance") and has("phase_resistance_pwm"):
        out.append("phase_resistance_pwm is the PWM's reading of the phase resistance (the duty's "
                   "drop per phase amp); winding_resistance also holds every battery loss growing "
                   "with the phase current squared (the controller's switches), so the two need "
                   "not agree.")
    return ["", " ".join(out)] if out else []
