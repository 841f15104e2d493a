"""What the terminal shows after ``euc-sim ride`` and ``euc-sim rides``: one line a fact.

:func:`summary_lines` reads the ride's :class:`~euc_sim.rides.result.RideResult`: the key figures
(the page's tiles, the same strings), then the held-out errors, the verdict, the effects, the mass,
the wheel's limit, the windows and the simulated replay.  :func:`history_lines` reads the ``rides``
JSON: one line a ride in one zone, then the battery's trend and the latest ride's change.  The
commands print the lines; nothing here writes.
"""

from __future__ import annotations

from pathlib import Path

from euc_sim.rides.balance.verdict import unit_label
from euc_sim.report.ride.history_page import pwm_cell, start_in, table_zone
from euc_sim.report.ride.contract import error_measure
from euc_sim.report.ride.page import falls_sentence
from euc_sim.report.ride.page_html import key_figure_lines
from euc_sim.report.ride.ride_time import clock_of, span_at, spans_legend
from euc_sim.report.ride.series import number
from euc_sim.rides.result import RideResult
from euc_sim.rides.sim.sim_steps import TARGET_RATIO
from euc_sim.rides.sim.simulate import StepScore

__all__ = ["summary_lines", "history_lines"]


def _step_line(st: StepScore) -> str:
    """One step's held-out battery-power error and its ratio to the balance fit's."""
    p, r = st.heldout_rmse.get("P_W"), st.ratio_to_balance
    return (f"battery-power RMS {p:.0f} W" if p is not None else "no battery-power error") + \
        (f", {r:.2f}x the balance fit's held-out error (target {TARGET_RATIO:g}x)" if r else "")


def _mass_lines(res: RideResult) -> list[str]:
    """The mass, the drivetrain's unidentified terms, the PWM and the compared ride."""
    m, wheel = res.mass.mass, res.mass.fit.spec.wheel_mass
    if m.estimate is None:
        lines = [f"  total mass: not identified ({m.why})"]
    else:
        lines = [f"  total mass (rider + wheel): {m.estimate:.0f} kg"
                 + (f" 95% [{m.ci95[0]:.0f}, {m.ci95[1]:.0f}]" if m.ci95 else "")]
        if wheel is not None:
            lines.append(f"  rider (with gear): {m.estimate - wheel:.0f} kg")
    for name, why in res.mass.unidentified.items():
        lines.append(f"  not identified: {name}: {why}")
    if res.mass.pwm_unchecked:
        lines.append(f"  PWM held out: no check, {res.mass.pwm_unchecked}")
    elif res.mass.pwm_heldout is not None:
        lines.append(f"  PWM held out: {res.mass.pwm_heldout:.1f} percentage points RMS")
    if res.differences is not None and res.differences.sentence:   # "this ride" is the compared one: named as the page does
        other, said = Path(str(res.balance.compare or "")).name, res.differences.sentence
        lines.append("  compared: " + (f"the compared ride ({other})" + said[len("this ride"):]
                                       if other and said.startswith("this ride") else said))
    return lines


def _limit_line(res: RideResult) -> str:
    """The wheel's limit and where the cut-out comes before it."""
    lim, cut = res.rider.summary.limits, res.cutout
    tail = (cut.danger if cut.danger else
            "the cut-out stays above it at every charge" if cut.curves and lim.speed_limit_mps
            else f"cut-out not known: {cut.why}" if cut.why else "cut-out not compared")
    return f"limit: {lim.words()}; {tail}"


def _effect_lines(res: RideResult) -> list[str]:
    """The held-out errors, the verdict and each effect kept, named or a candidate."""
    an, v = res.balance, res.verdict
    cr, u = an.cross, an.error_unit
    lines = [("" if v.battery_power else "V·I, NOT battery power: ")
             + f"held-out error ({error_measure(an)}): inertia-only "
             f"{cr.heldout_nominal:.1f} {u}, augmented {cr.heldout_augmented:.1f} "
             f"{u}, ratio {cr.ratio:.2f}",
             f"  verdict: {v.text}"]
    for e in res.effects:
        kind = "named" if e.name in v.named else "candidate"
        flag = "" if e.plausible else "  IMPLAUSIBLE"
        al = f"  aliases: {', '.join(e.aliases)}" if e.aliases else ""
        lines.append(f"  {kind}: {e.name} = {e.estimate:.4g} {unit_label(e.unit)} "
                     f"95% [{e.ci95[0]:.4g}, {e.ci95[1]:.4g}]{flag}{al}")
    return lines


def _simulation_lines(res: RideResult) -> list[str]:
    """The simulated replay's errors step by step and its falls, or why it did not run."""
    sim = res.simulation
    if sim is None:
        return [f"  simulated replay: {res.simulation_why or 'not run'}"]
    lines = []
    if sim.scored_rows:
        first, last = sim.errors[sim.ran[0]]["P_W"], sim.errors[sim.ran[-1]]["P_W"]
        lines.append(f"  simulation along {sim.label}: battery-power RMS nominal {first:.0f} W, "
                     f"augmented {last:.0f} W (ratio {sim.ratio_P:.2f})")
        lines += [f"    step {st.step.name}: " + (_step_line(st) if st.step.why is None else f"not run ({st.step.why})")
                  for st in sim.steps]
    fell = falls_sentence(sim.falls, sim.scored_rows, clock_of(res, sim.label))
    if fell:
        lines.append(f"  simulation along {sim.label}: {fell}")
    return lines


def summary_lines(res: RideResult) -> list[str]:
    """The terminal's summary of a ride's result, one string a line (no newlines).

    Parameters
    ----------
    res : RideResult

    Returns
    -------
    list of str
    """
    lines = key_figure_lines(res) + _effect_lines(res)
    lines += [f"  warning: {w}" for w in res.mass.input_warnings]
    lines += _mass_lines(res) + [f"  {res.rider.mass_check.sentence}", "  " + _limit_line(res)]
    windows, clock = res.traces[0].localisation["windows"], res.rider.clock
    if windows:
        lines.append(f"  windows, {spans_legend(clock)}: " + ", ".join(span_at(clock, a, b, "-")
                                                                    for a, b in windows[:8])
                     + (" ..." if len(windows) > 8 else ""))
    return lines + _simulation_lines(res)


def history_lines(hist, verdicts: bool = False) -> list[str]:
    """The terminal's table of one wheel's rides, one string a line (no newlines).

    Parameters
    ----------
    hist : RideHistory
        The ``euc-sim rides`` result (:class:`~euc_sim.rides.logbook.history.RideHistory`).
    verdicts : bool
        Whether the battery's pack is known (``--wheel``): each ride's resistance then carries
        its verdict.

    Returns
    -------
    list of str
    """
    off, zone = table_zone(hist)
    lines = [f"start times in {zone}"]
    for e in hist.rides:
        s, b = e.summary, e.battery
        r = b.resistance_25C_ohm if hist.basis == "25C" else b.resistance_ohm
        lines.append(f"{start_in(e, off)}  {Path(e.path).name}: {(number(s.distance_m) or 0) / 1000:.1f} km, "
                     f"{number(s.Wh_per_km) or float('nan'):.1f} Wh/km, "
                     f"battery {number(s.battery_used_pct) or 0:.0f} %, "
                     f"max PWM {pwm_cell(number(s.pwm_max_pct), ' %')}, "
                     f"resistance {'–' if r is None else f'{1e3 * r:.0f} mΩ'}"
                     + (f" ({b.verdict})" if verdicts and r is not None else ""))
    if hist.trend:
        lines.append(f"battery: {hist.trend}")
    ch = hist.change
    if ch:
        lines.append(f"latest ride's resistance against the earlier {ch.n_earlier}: {ch.verdict} "
                     f"(difference {1e3 * ch.difference:+.0f} mΩ, 95% [{1e3 * ch.difference_ci95[0]:+.0f}, "
                     f"{1e3 * ch.difference_ci95[1]:+.0f}], p = {ch.p_value:.2g})")
    return lines
