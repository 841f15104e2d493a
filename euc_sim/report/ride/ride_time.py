"""Times as a rider reads them: clock time in the ride's own zone and time into the ride.

A ride's :class:`~euc_sim.rides.summary.rider_view.Clock` (:func:`~euc_sim.rides.summary.rider_view.ride_clock`:
the log's start in its own zone, the zone, the pauses) turns a time in s from the log's start into words
(:func:`when`: "18:30 (15 min 25 s into the ride)"), and :class:`TimeAxis` leaves the pauses
out of the figures' time axis.
"""

from __future__ import annotations

from dataclasses import dataclass
from datetime import datetime, timedelta
from pathlib import Path
import numpy as np

from euc_sim.report.figures import plain_values
from euc_sim.report.ride.series import number

__all__ = ["hm", "clock_at", "when", "span_words", "pause_words", "clock_of", "spans_legend", "span_at",
           "TimeAxis", "PAUSE_SHOWN"]


def hm(seconds: float) -> str:
    """A duration in hours and minutes, "1 h 05 min" or "25 min"."""
    m = int(round(seconds / 60.0))
    return f"{m // 60} h {m % 60:02d} min" if m >= 60 else f"{m} min"


def _into(seconds: float) -> str:
    """Time into the ride in words: "25 s", "15 min 25 s", "1 h 02 min"."""
    s = int(round(seconds))
    if s >= 3600:
        return f"{s // 3600} h {s // 60 % 60:02d} min"
    return f"{s // 60} min {s % 60:02d} s" if s >= 60 else f"{s} s"


def _min_s(seconds: float) -> str:
    """Time into the ride as a stopwatch shows it: "2:58" (min:s), "1:02:05" (h:min:s)."""
    s = int(round(seconds))
    return f"{s // 3600}:{s // 60 % 60:02d}:{s % 60:02d}" if s >= 3600 else f"{s // 60}:{s % 60:02d}"


def clock_at(clock, t: float, seconds: bool = False) -> str | None:
    """The clock time, "HH:MM" (or "HH:MM:SS" with ``seconds``) in the ride's own zone, ``t`` s
    after the log's start (its :class:`~euc_sim.rides.summary.rider_view.Clock`); None without it."""
    at = _clock_time(clock, t)
    return None if at is None else f"{at:{'%H:%M:%S' if seconds else '%H:%M'}}"


def _clock_time(clock, t: float) -> datetime | None:
    """The time in the ride's own zone ``t`` s after the log's start (its clock's), or None without it."""
    try:
        start = datetime.fromisoformat(str(clock.start))
    except (AttributeError, TypeError, ValueError):
        return None
    return start + timedelta(seconds=float(t))


def clock_of(res, recording):
    """The clock of the ride whose file is ``recording`` (a :class:`~euc_sim.rides.result.RideResult`'s):
    the compared ride's where it is that one, else this ride's."""
    other = res.compared
    if other is not None and recording and Path(other.recording).name == Path(str(recording)).name:
        return other.rider.clock
    return res.rider.clock


def spans_legend(clock) -> str:
    """How :func:`span_at` writes a span: "clock time in UTC+02:00 (time into the ride, min:s)"."""
    zone = getattr(clock, "zone", None)
    return (f"clock time in {zone} (time into the ride, min:s)" if zone and clock_at(clock, 0.0)
            else "time into the ride, min:s")


def span_at(clock, a: float, b: float, dash: str = "–") -> str:
    """A span of the ride, ``a`` to ``b`` s from the log's start, as :func:`spans_legend` says:
    "13:53:59–13:54:04 (2:58–3:03)"; the time into the ride alone without a clock."""
    into = f"{_min_s(a)}{dash}{_min_s(b)}"
    t0, t1 = clock_at(clock, a, True), clock_at(clock, b, True)
    return f"{t0}{dash}{t1} ({into})" if t0 and t1 else into


def when(clock, t: float, also: str = "") -> str:
    """A moment of the ride as a rider reads it: its clock time in the ride's own zone (``clock``)
    and its time into the ride, "18:30 (15 min 25 s into the ride)"; ``also`` joins the parentheses."""
    at, into = clock_at(clock, t), f"{_into(t)} into the ride"
    if at:
        return f"{at} ({into}" + (f"; {also})" if also else ")")
    return into + (f" ({also})" if also else "")


def span_words(clock, s) -> str:
    """When the log ran, clock times in the ride's own zone, "logged 17:21–17:43 in UTC+02:00",
    with its length where the summary ``s``'s duration (another clock) rounds to another; '' without.

    The clock's minutes (as a clock shows them, not rounded) are said only where they are as many as
    the length's (:func:`hm`): else to the second, "logged 16:48:42–17:10:11 (21 min)", never a span
    that reads 22 min beside a length of 21."""
    logged = float(s.logged_s or 0.0)
    a, b = _clock_time(clock, 0.0), _clock_time(clock, logged)
    if a is None or b is None or not clock.zone:
        return ""
    shown = (60 * (b.hour - a.hour) + b.minute - a.minute) % 1440       # minutes between the HH:MM shown
    fmt = "%H:%M" if shown == round(logged / 60.0) % 1440 else "%H:%M:%S"
    dur = number(s.duration_s)
    own = f" ({hm(logged)})" if dur is not None and hm(logged) != hm(dur) else ""
    return f"logged {a:{fmt}}–{b:{fmt}}{own} in {clock.zone}"


def pause_words(clock) -> str:
    """The log's pauses (the clock's, left out of the duration) with their clock times,
    "paused 09:03–09:33 (3 min 20 s into the ride, 30 min)"; '' without one."""
    out = [f"paused {clock_at(clock, a)}–{clock_at(clock, b)} ({_into(a)} into the ride, {hm(b - a)})"
           if clock_at(clock, a) else f"paused {_into(a)} into the ride for {hm(b - a)}"
           for a, b in getattr(clock, "pauses", ())]
    return "; ".join(out)


#: The width a pause left out of the time axis keeps there, as a share of the axis (a marked gap).
PAUSE_SHOWN = 0.03


@dataclass(frozen=True)
class TimeAxis:
    """The figures' time axis without the log's pauses: each pause (the clock's ``pauses``,
    left out of the duration) squeezed to a marked gap of
    :data:`PAUSE_SHOWN` of the axis, so the riding either side keeps its width.

    Attributes
    ----------
    stretches : tuple of (float, float)
        The riding between the pauses, s from the log's start.
    shown_s : float
        The width each pause keeps on the axis, s.
    """

    stretches: tuple
    shown_s: float

    @classmethod
    def of(cls, clock, t: np.ndarray) -> "TimeAxis":
        if t.size == 0:
            return cls(((0.0, 0.0),), 0.0)
        edges = [float(t[0])] + [float(v) for ab in clock.pauses for v in ab] + [float(t[-1])]
        stretches = tuple(zip(edges[::2], edges[1::2]))
        return cls(stretches, PAUSE_SHOWN * max(sum(b - a for a, b in stretches), 1.0))

    @property
    def pauses(self) -> list:
        """(start, end) of each pause, s."""
        return [(a[1], b[0]) for a, b in zip(self.stretches, self.stretches[1:])]

    def x(self, t) -> np.ndarray:
        """Axis position, min, of times ``t`` (s from the log's start); NaN inside a pause."""
        t = np.asarray(t, float)
        out = t.copy()
        for a, b in self.pauses:
            out = np.where((t > a) & (t < b), np.nan, out)
            out = np.where(t >= b, out - (b - a - self.shown_s), out)
        return out / 60.0

    def minutes(self, x) -> np.ndarray:
        """Time into the ride, min, at axis positions ``x`` (min): :meth:`x` undone."""
        x = np.asarray(x, float) * 60.0
        out = x.copy()
        for a, b in self.pauses:
            out = np.where(x >= float(self.x([a])[0]) * 60.0 + self.shown_s, out + (b - a - self.shown_s), out)
        return out / 60.0

    def decorate(self, fig: dict, rows: int) -> None:
        """Shade each pause's gap with its length, and label the ticks and the hover in time
        into the ride (``fig``: :func:`euc_sim.report.figures.time_panels`' plain spec, ``rows`` panels)."""
        if not self.pauses:
            return

        lay = fig["layout"]
        first = fig["data"][0]      # the hover's first line says the time (its title can only say the axis's x)
        first["customdata"] = plain_values(self.minutes(np.array(first["x"], float)))
        first["hovertemplate"] = "at %{customdata:.1f} min: " + (first.get("hovertemplate") or "%{y}")
        axes = [f"xaxis{'' if i == 1 else i}" for i in range(1, rows + 1)]
        for ax in axes:
            lay[ax]["unifiedhovertitle"] = {"text": "into the ride"}
        for a, b in self.pauses:
            x0 = float(self.x([a])[0])
            for i in range(1, rows + 1):
                k = "" if i == 1 else str(i)
                lay["shapes"].append({"type": "rect", "x0": x0, "x1": x0 + self.shown_s / 60.0, "xref": f"x{k}",
                                      "y0": 0, "y1": 1, "yref": f"y{k} domain", "fillcolor": "#9e9e9e",
                                      "opacity": 0.35, "line": {"width": 0}})
            lay["annotations"].append({"x": x0 + self.shown_s / 120.0, "y": 1.0, "yref": "paper",
                                       "yanchor": "bottom", "showarrow": False,
                                       "text": f"pause of {hm(b - a)} left out",
                                       "font": {"size": 11, "color": "#455a64"}})
        ridden = sum(b - a for a, b in self.stretches) / 60.0
        step = next((m for m in (1, 2, 5, 10, 15, 20, 30, 60, 120) if ridden / m <= 10), 240)
        mins = [m for a, b in self.stretches for m in np.arange(np.ceil(a / 60.0 / step) * step, b / 60.0 + 1e-9, step)]
        for ax in axes:
            lay[ax].update(tickmode="array", tickvals=[float(v) for v in self.x(np.array(mins) * 60.0)],
                           ticktext=[f"{m:.0f}" for m in mins])
        lay[axes[-1]]["title"] = {"text": "time into the ride, min (grey: a pause left out)"}
