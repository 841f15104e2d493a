"""The ride page's mass and drivetrain section, and the envelope's and the grade's figures.

:func:`page_section` words a ride's total mass, drivetrain, PWM check, grade and envelope
(:mod:`euc_sim.rides.drive.drivetrain_report`) for the page;
:func:`envelope_figure` draws the envelope and :func:`grade_figure` the altitude the
balance implies (:mod:`euc_sim.rides.drive.grade`); the page draws the PWM model's
(:func:`euc_sim.report.ride.fit_figures.pwm_figure`).
"""

from __future__ import annotations

import numpy as np

from euc_sim.rides.balance.verdict import unit_label
from euc_sim.rides.grids.power import G

__all__ = ["envelope_figure", "grade_figure", "page_section", "TYRE_MU"]


#: Tyre-road friction coefficient the envelope figure assumes (dry asphalt, about 1):
#: no tyre carries a sustained acceleration above μ·g, whatever the motor could give.
TYRE_MU = 1.0


def envelope_figure(env):
    """The acceleration the battery voltage allows (and the lean it takes) against speed.

    Full and low charge, of an :class:`~euc_sim.rides.drive.cutout.Envelope`.  The voltage limit is
    drawn only where it is below what the tyre can carry (a ≤ :data:`TYRE_MU`·g, lean atan(μ)); above,
    the model says nothing (the controller's current limit, not in the log, or the tyre's grip
    decides) and the figure says so.

    Returns
    -------
    matplotlib.figure.Figure
    """
    from matplotlib.figure import Figure

    v = env.speed * 3.6
    a_tyre = TYRE_MU * G
    fig = Figure(figsize=(9, 4.6), layout="constrained")
    ax = fig.add_subplot()
    clipped = False
    for name, side, style in (("full", env.full, "-"), ("low", env.low, "--")):
        a = side.accel
        clipped |= bool(np.any(a > a_tyre))
        ax.plot(v, np.where(a <= a_tyre, a, np.nan), style,
                label=f"{name} charge ({side.voltage:.0f} V): voltage limit")
    ax.axhline(a_tyre, color="k", lw=1.0, ls=":",
               label=f"tyre grip, μ ≈ {TYRE_MU:g}: at most {a_tyre:.1f} m/s²")
    if clipped:
        ax.axhspan(a_tyre, 1.15 * a_tyre, color="tab:red", alpha=0.08, lw=0,
                   label="above the tyre's grip: the model\nsays nothing, not drawn")
    top = env.ride_top_speed
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
    fig.suptitle("Cut-out envelope: the acceleration left at full duty (100 %) against speed", fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(loc="upper left", bbox_to_anchor=(1.12, 1.0), fontsize=8, borderaxespad=0.0)
    return fig


def grade_figure(g, title: str = ""):
    """Altitude against distance: GPS, implied by the balance, and the fitted grade term.

    Parameters
    ----------
    g : euc_sim.rides.drive.grade.GradeProfile
    title : str

    Returns
    -------
    matplotlib.figure.Figure
    """
    from matplotlib.figure import Figure

    def broken(y):          # NaN between segments: the implied altitude restarts at each
        cut = np.flatnonzero(g.segment[1:] != g.segment[:-1]) + 1
        return np.insert(g.distance, cut, np.nan), np.insert(y, cut, np.nan)

    fig = Figure(figsize=(9, 5.6), layout="constrained")
    ax = fig.add_subplot()
    ax.plot(*broken(g.gps), color="k", lw=1.2,
            label=f"GPS altitude (ascent {g.climb_gps_m:.0f} m)")
    ax.plot(*broken(g.implied), color="tab:blue", lw=1.0,
            label=f"implied by battery power, ∫(P − P̂ without grade)/(m·g) dt, restarted at "
                  f"GPS after each gap (ascent {g.climb_implied_m:.0f} m; {g.rms_m:.0f} m RMS "
                  f"from GPS)")
    if g.fitted is not None:
        ax.plot(*broken(g.fitted), color="tab:orange", lw=1.0, ls="--",
                label="the fit's grade term, (β_h/m)·GPS altitude (β_h < m: altitude noise "
                      "attenuates it)")
    ax.set_xlabel("distance ridden, km")
    ax.set_ylabel("altitude, m")
    fig.suptitle(title or "Road grade: the altitude the battery-power balance implies, "
                          "against GPS altitude", fontsize=10)
    ax.grid(alpha=0.3)
    fig.legend(loc="outside lower center", fontsize=8)
    return fig


#: A systematic part of the mass's interval (the mass fit's ``systematic``) in people's words:
#: ``efficiency_model`` is the choice of copper-loss column (κ·F² or its proxy κ·a²).
SYSTEMATIC_WORDS = {"efficiency_model": "copper-loss model (κ·F² or κ·a²)",
                    "rotating_share": "rotating inertia's share"}


def _mass_md(res, shown=frozenset()) -> list[str]:
    """The page's lines on the total mass, its interval's parts, warnings and the difference;
    the total mass itself not repeated where ``shown`` (the first screen) has it."""
    m, md_ = res.mass.mass, res.mass
    md = ["## What the wheel weighs with its rider, and how close to a cut-out", ""]
    if m.estimate is None:
        md.append(f"- Total mass (rider + wheel): **not identified**: {m.why}.")
    else:
        ci, eq = m.ci95, m.equivalent
        value = ("in the key figures above" if "total_mass" in shown else
                 f"**{m.estimate:.0f} kg**, 95 % interval " + (f"{ci[0]:.0f}–{ci[1]:.0f} kg" if ci else "–"))
        md.append("- Total mass (rider + wheel"
                  + ("" if eq else ", with the wheel's rotating inertia: no net weight given")
                  + f"): {value} (from battery power alone; speed scale {m.scale.estimate:.3f}, "
                    f"{m.scale.source}; current–speed delay {m.lag:+.1f} s, a shift of the "
                    f"current" + ("; the balance's own lag of it, current_lag, is in Estimates, a first-order lag"
                                  if any(q.name == "current_lag" and q.accepted for q in res.parameters) else "")
                  + ").")
        if eq:
            md.append(f"- The energy balance finds m_eq = {eq['estimate']:.0f} kg (eq. 6: it also "
                      f"accelerates the wheel's rotating inertia J_w/R², taken as "
                      f"{eq['rotating_inertia']:.1f} kg, {eq['rotating_inertia_range'][0]:.1f}–"
                      f"{eq['rotating_inertia_range'][1]:.1f} kg, from the net weight).")
        if m.systematic and m.stat_ci95:
            st = m.stat_ci95
            md.append(f"- The interval is the bootstrap's ({st[0]:.0f}–{st[1]:.0f} kg) with what the "
                      f"log cannot calibrate added in quadrature (95 % half-widths: " + ", ".join(
                          f"{SYSTEMATIC_WORDS.get(k, k.replace('_', ' '))} {v:.1f} kg"
                          for k, v in m.systematic.items()) + ").")
        if m.by_window:
            md.append("- Energy balance over windows of " + ", ".join(
                f"{w:g} s: {x:.0f} kg" for w, x in m.by_window.items())
                + " (the interval pools them: the log cannot choose one).")
        if md_.fit.spec.wheel_mass is not None:
            md.append(f"- Rider with gear: {m.estimate - md_.fit.spec.wheel_mass:.0f} kg "
                      f"(total minus the spec's net weight).")
    for w in md_.input_warnings:
        md.append(f"- **Warning**: {w}.")
    d = md_.mass_difference
    said = any(x.name == "total_mass" and x.independent and x.independent[1]
               for x in (res.differences.items if res.differences else ()))
    if d and said:                  # the differences' block says it, once
        md.append("- The compared ride minus this one: in 'What differs in the compared ride' above.")
    elif d:
        md.append("- The compared ride minus this one: " + (
            f"**{d.estimate:+.0f} kg**, 95 % interval {d.ci95[0]:+.0f} to {d.ci95[1]:+.0f} "
            f"kg: **{d.verdict}**" if d.estimate is not None else
            f"**cannot tell** ({d.why or ''})") + ".")
    return md


def page_section(res, figures: dict, shown=frozenset()) -> list[str]:
    """Markdown lines for the ride page (a :class:`~euc_sim.rides.result.RideResult`'s): mass,
    balance by term, grade, PWM, envelope.

    ``shown``: the quantities the page's first screen already gives (``total_mass``,
    ``internal_resistance``, ``top_speed``; ``pwm_heldout``, the compared ride's PWM check, in
    its limits' section), said here without their numbers.
    """
    md = _mass_md(res, shown)
    sel = res.balance.cross.selection
    if sel:
        md += ["", "How the balance was chosen (the one selection rule of the page): the fit "
                   "ride's error on each of its own five time blocks, fitted on the other four, "
                   "after each kept term. These are not the held-out errors of the verdict, "
                   "which are scored on the ride held out:", "",
               "| step | fit ride, blocked RMS, " + res.balance.error_unit + " |", "|---|---|"]
        md += [f"| + {h['term']} | {h['heldout_rmse']:.0f} |" for h in sel]
    dt = res.drivetrain
    md += ["", "| drivetrain term | estimate | 95 % interval | unit |", "|---|---|---|---|"]
    for name, t in dt.items():
        if t.parameter is not None:            # a balance-fit parameter: in the Estimates table
            continue
        if t.estimate is None:
            md.append(f"| {name} | not identified | {t.why or ''} | |")
        elif name in shown:
            md.append(f"| {name} | in the key figures above | | {unit_label(t.unit)} |")
        else:
            ci = t.ci95
            md.append(f"| {name} | {t.estimate:.4g} | "
                      + (f"{ci[0]:.4g} – {ci[1]:.4g}" if ci else "–") + f" | {unit_label(t.unit)} |")
    md += _nuisance_note(dt)
    g, mass = res.mass.fit.grade, res.mass
    if g is not None:
        md += ["", f"Road grade as the battery sees it: integrating the power the balance "
                   f"leaves unexplained without its grade term, over "
                   f"{float(g.distance[-1]) if g.distance.size else 0.0:.1f} km, "
                   f"gives an altitude {g.rms_m:.0f} m RMS from GPS altitude "
                   f"(ascent {g.climb_implied_m:.0f} m against GPS's "
                   f"{g.climb_gps_m:.0f} m)."]
    if "grade" in figures:
        md += ["", f"![altitude implied by the balance against GPS altitude]({figures['grade']})"]
    if mass.test is not None:
        md += ["", "PWM of the other ride predicted from this one: "
                   + ("in 'Your wheel's limit and the cut-out' above" if "pwm_heldout" in shown else
                      f"no check: {mass.pwm_unchecked}" if mass.pwm_unchecked else
                      f"**{mass.pwm_heldout:.1f} percentage points RMS**" if mass.pwm_heldout
                      is not None else f"not available ({mass.pwm_why or ''})")]
    if "pwm" in figures:
        md += ["", f"![PWM predicted against logged]({figures['pwm']})"]
    env = mass.envelope
    if env.speed is not None:
        end = env.speed[-1] * 3.6

        def left(name):
            x = getattr(env, name).v_limit
            return f"{x * 3.6:.0f} km/h" if x is not None else f"above {end:.0f} km/h (the figure's end)"
        said = (f"the acceleration left at full duty with the pack at {env.full.voltage:.0f} V (100 % "
                f"charge) and at {env.low.voltage:.0f} V (0 %), the charge as this log reads it "
                f"({env.voltage_source}). The speed at which none is left on the level is the cut-out "
                f"chart's: {left('full')} at 100 %, {left('low')} at 0 %. ")
        md += ["", "Envelope (voltage limit): " + said
                   + ("Faster than this ride's top speed (in the key figures above)" if "top_speed" in shown
                      else f"This ride's top speed was {(env.ride_top_speed or float('nan')) * 3.6:.0f} "
                           f"km/h: faster than that")
                   + " the envelope is extrapolated (shaded)."]
    else:
        md += ["", f"Envelope: {env.why or 'not available'}."]
    if "envelope" in figures:
        md += ["", f"![cut-out envelope]({figures['envelope']})"]
    for name, why in mass.unidentified.items():
        if name not in dt or dt[name].estimate is not None:   # else said in the table
            md.append(f"- Not identified, {name}: {why}.")
    return md + [""]


def _nuisance_note(dt: dict) -> list[str]:
    """What the drivetrain table's terms (name -> :class:`~euc_sim.rides.drive.drivetrain.Term`) that
    read the balance's physics again are: the mass fit's own copper and grade terms, and the PWM's
    phase resistance beside the copper loss's."""
    has = lambda k: k in dt and dt[k].estimate is not None  # noqa: E731
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
