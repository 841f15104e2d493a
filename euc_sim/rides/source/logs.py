"""Readers for electric-unicycle telemetry logs (WheelLog, EUC World, DarknessBot CSV).

Every layout is read by column name, never by position, into one
:class:`~euc_sim.rides.source.ride.Ride`: a table in SI units (t from the first sample
in s, m/s, rad, m), the reader's notes (``warnings``), what it changed in the data
(``repairs``) and the channels found missing (``absent``).  :data:`LAYOUTS` gives each
layout's columns and units; EUC World and DarknessBot come from third-party parsers
(best effort).

Bad input (no time or speed column, a non-numeric cell, an unreadable time stamp, an
empty file, a column named twice, more than :data:`~euc_sim.rides.source.bounds.MAX_ROWS`
rows, values out of physical range beyond a few) is a :class:`LogFormatError` naming
file, column and line.  Repeated stamps are averaged, backward time sorted, a truncated
last line dropped, out-of-range values dropped or emptied
(:mod:`~euc_sim.rides.source.bounds`), all-zero or empty optional channels reported
absent; each is a note, also issued as a :class:`RideLogWarning` unless told not to.
"""

from __future__ import annotations

import csv
import io
import itertools
import math
import warnings as _warnings
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import Mapping

import numpy as np
import pandas as pd

from euc_sim.errors import BadInputFile
from euc_sim.rides.source.bounds import MAX_ROWS, bound_channel, speed_sign
from euc_sim.rides.source.counters import log_counters
from euc_sim.rides.source.gaps import GAP_POLICY
from euc_sim.rides.source.ride import CHANNEL_UNITS, Ride

__all__ = [
    "LogFormatError", "RideLogWarning", "Ride", "Channel", "LAYOUTS", "CHANNEL_UNITS",
    "read_log", "detect_layout",
]

KMH = 1.0 / 3.6            # km/h -> m/s
DEG = math.pi / 180.0       # degree -> rad
KM = 1000.0                 # km -> m
#: Intervals shorter than this, s, are counted as near-repeated time stamps (kept).
NEAR_REPEAT = 0.02
#: Cells read as empty (any case, after stripping), besides the empty string.
_EMPTY = ("nan", "null", "none")


class LogFormatError(BadInputFile):
    """A log file that cannot be read; the message names file, column and line (1-based, header = 1)."""

    def __init__(self, path, message: str, column: str | None = None, line: int | None = None):
        self.path = str(path)
        self.column = column
        self.line = line
        where = []
        if column is not None:
            where.append(f"column {column!r}")
        if line is not None:
            where.append(f"line {line}")
        loc = (", ".join(where) + ": ") if where else ""
        super().__init__(f"{self.path}: {loc}{message}")


class RideLogWarning(UserWarning):
    """Something the reader did to a log (merged, sorted, dropped, found absent)."""


@dataclass(frozen=True)
class Channel:
    """Where a canonical channel comes from: ``columns`` (first present wins), ``scale`` to SI."""

    columns: tuple[str, ...]
    scale: float = 1.0


_GPS = ("latitude", "longitude", "gps_speed", "gps_alt", "gps_heading", "gps_distance")


@dataclass(frozen=True)
class Layout:
    """A log layout: how its time stamp is built and where each channel lives."""

    name: str
    time_columns: tuple[str, ...]           # joined with a space, then parsed
    time_formats: tuple[str | None, ...]    # tried in order; None = ISO 8601
    speed: Channel
    channels: Mapping[str, Channel]
    source: str


LAYOUTS: dict[str, Layout] = {
    "wheellog": Layout(
        name="wheellog",
        time_columns=("date", "time"),
        time_formats=(None,),
        speed=Channel(("speed",), KMH),
        channels={
            "voltage": Channel(("voltage",)), "current": Channel(("current",)),
            "power": Channel(("power",)), "phase_current": Channel(("phase_current",)),
            "torque": Channel(("torque",)), "pwm": Channel(("pwm",)),
            "battery": Channel(("battery_level",)), "distance": Channel(("distance",)),
            "total_distance": Channel(("totaldistance",)),
            "temperature": Channel(("system_temp",)),
            "temperature2": Channel(("temp2", "cpu_temp")),
            "tilt": Channel(("tilt",), DEG), "roll": Channel(("roll",), DEG),
            "latitude": Channel(("latitude",)), "longitude": Channel(("longitude",)),
            "gps_speed": Channel(("gps_speed",), KMH), "gps_alt": Channel(("gps_alt",)),
            "gps_heading": Channel(("gps_heading",), DEG),
            "gps_distance": Channel(("gps_distance",)),
        },
        source="WheelLog Android app, LoggingService (Wheellog/Wheellog.Android)",
    ),
    "eucworld": Layout(
        name="eucworld",
        time_columns=("datetime",),
        time_formats=(None,),
        speed=Channel(("speed",), KMH),
        channels={
            "voltage": Channel(("voltage",)), "current": Channel(("current",)),
            "power": Channel(("power",)), "phase_current": Channel(("current_phase",)),
            "pwm": Channel(("pwm",)), "safety_margin": Channel(("safety_margin",)),
            "battery": Channel(("battery",)),
            "distance": Channel(("distance",), KM),
            "total_distance": Channel(("distance_total",), KM),
            "temperature": Channel(("temp",)), "temperature2": Channel(("temp_motor",)),
            "tilt": Channel(("tilt",), DEG), "roll": Channel(("roll",), DEG),
            "latitude": Channel(("gps_lat",)), "longitude": Channel(("gps_lon",)),
            "gps_speed": Channel(("gps_speed",), KMH), "gps_alt": Channel(("gps_alt",)),
            "gps_heading": Channel(("gps_bearing",), DEG),
            "gps_distance": Channel(("gps_distance",), KM),
        },
        source="EUC World CSV export, as read by third-party parsers (unofficial)",
    ),
    "darknessbot": Layout(
        name="darknessbot",
        time_columns=("Date",),
        time_formats=(None, "%d.%m.%Y %H:%M:%S.%f", "%d.%m.%Y %H:%M:%S"),
        speed=Channel(("Speed",), KMH),
        channels={
            "voltage": Channel(("Voltage",)), "current": Channel(("Current",)),
            "power": Channel(("Power",)), "pwm": Channel(("PWM",)),
            "battery": Channel(("Battery level",)),
            "total_distance": Channel(("Total mileage",), KM),
            "temperature": Channel(("Temperature",)),
            "tilt": Channel(("Pitch",), DEG), "roll": Channel(("Roll",), DEG),
            "latitude": Channel(("Latitude",)), "longitude": Channel(("Longitude",)),
            "gps_speed": Channel(("GPS Speed", "GPS speed"), KMH),
            "gps_alt": Channel(("Altitude",)),
        },
        source="DarknessBot CSV export, as read by third-party parsers (unofficial)",
    ),
}


def detect_layout(columns, path="<log>") -> Layout:
    """The layout whose signature columns are all among ``columns``; LogFormatError naming the missing one."""
    cols = set(columns)
    if {"date", "time"} <= cols or "speed" in cols and ("date" in cols or "time" in cols):
        lay = LAYOUTS["wheellog"]
    elif "datetime" in cols:
        lay = LAYOUTS["eucworld"]
    elif "Date" in cols or "Speed" in cols:
        lay = LAYOUTS["darknessbot"]
    elif "speed" in cols:
        raise LogFormatError(
            path, "missing required time column: expected 'date' and 'time' (WheelLog) "
            "or 'datetime' (EUC World)", column="time")
    else:
        shown = ", ".join(list(columns)[:6])
        raise LogFormatError(
            path, f"not a recognised EUC log: no speed column (expected 'speed' or 'Speed'); "
            f"header starts {shown!r}", column="speed")
    for col in lay.time_columns + lay.speed.columns:
        if col not in cols:
            raise LogFormatError(path, f"missing required column for the {lay.name} layout "
                                       f"(found {len(cols)} columns)", column=col)
    return lay


def _numeric(raw: pd.Series, column: str, path, required: bool) -> np.ndarray:
    """A column as floats (empty cells NaN); the first non-numeric cell is a LogFormatError."""
    if raw.dtype.kind in "iuf":
        vals = raw.to_numpy(dtype=float)
        empty = np.isnan(vals)
        s = None
    else:
        s = raw.astype(str).str.strip()
        empty = (s.eq("") | s.str.lower().isin(_EMPTY)).to_numpy()
        conv = pd.to_numeric(s.where(~empty), errors="coerce")
        bad = conv.isna().to_numpy() & ~empty
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise LogFormatError(path, f"expected a number, got {s.iloc[i]!r} "
                                       f"({int(bad.sum())} such cell(s) in this column)",
                                 column=column, line=i + 2)
        vals = conv.to_numpy(dtype=float)
    if required and empty.any():
        i = int(np.flatnonzero(empty)[0])
        raise LogFormatError(path, f"empty cell in a required column "
                                   f"({int(empty.sum())} such cell(s))", column=column, line=i + 2)
    return vals


def _times(frame: pd.DataFrame, lay: Layout, path) -> tuple[pd.Series, float | None]:
    """Parse the time stamp columns (UTC where they carry a zone) and the first stamp's zone,
    s east of UTC (None without one); the first unparsable stamp is an error."""
    text = frame[lay.time_columns[0]].astype(str).str.strip()
    for col in lay.time_columns[1:]:
        text = text + " " + frame[col].astype(str).str.strip()
    best = None
    for fmt in lay.time_formats:
        try:
            parsed = pd.to_datetime(text, format=fmt if fmt else "ISO8601", errors="coerce")
        except (ValueError, TypeError):
            continue
        if best is None or parsed.notna().sum() > best.notna().sum():
            best = parsed
        if best.notna().all():
            break
    if best is None or best.isna().any():
        i = 0 if best is None else int(np.flatnonzero(best.isna().to_numpy())[0])
        col = "+".join(lay.time_columns)
        raise LogFormatError(path, f"cannot read the time stamp {text.iloc[i]!r} "
                                   f"(expected e.g. '2020-05-16 08:02:10.002')",
                             column=col, line=i + 2)
    offset = None
    if getattr(best.dt, "tz", None) is not None:
        offset = best.iloc[0].utcoffset().total_seconds() if len(best) else None
        best = best.dt.tz_convert("UTC").dt.tz_localize(None)
    return best, offset


def _sampling_summary(t: np.ndarray, gap_warn: float) -> str | None:
    dt = np.diff(t)
    if dt.size == 0:
        return None
    med = float(np.median(dt))
    lo, hi = float(dt.min()), float(dt.max())
    n_gap = int((dt > gap_warn).sum())
    n_near = int((dt < NEAR_REPEAT).sum())
    if hi - lo <= 0.05 * max(med, 1e-9) and n_gap == 0:
        return None
    return (f"irregular sampling: intervals {lo:.3f}-{hi:.3f} s (median {med:.3f} s, "
            f"about {1 / med if med > 0 else float('nan'):.1f} Hz); "
            f"{n_gap} gap(s) longer than {gap_warn:g} s; {n_near} interval(s) shorter than "
            f"{NEAR_REPEAT * 1000:.0f} ms (near-repeats, kept)")


def _check_header(path: Path, header: list[str]) -> None:
    """A column named twice is an error (which one is the data is unknown)."""
    names = [h.strip() for h in header]
    twice = next((c for i, c in enumerate(names) if c and c in names[:i]), None)
    if twice is not None:
        where = [i + 1 for i, c in enumerate(names) if c == twice]
        raise LogFormatError(path, f"the header names this column twice (columns "
                                   f"{' and '.join(map(str, where))}); which is the data is "
                                   f"unknown", column=twice, line=1)


def _check_field_counts(path: Path, data: bytes, text: str, n_head: int) -> None:
    """A row with more non-empty fields than the header is an error (commas counted at once; only longer lines split)."""
    if '"' in text:
        rows = enumerate(csv.reader(io.StringIO(text)), start=1)
    else:
        arr = np.frombuffer(data, np.uint8)
        nl = np.flatnonzero(arr == 10)
        starts, ends = np.r_[0, nl + 1], np.r_[nl, arr.size]
        commas = np.flatnonzero(arr == 44)
        n = np.searchsorted(commas, ends) - np.searchsorted(commas, starts)
        over = np.flatnonzero(n >= n_head)
        lines = text.split("\n") if over.size else []
        rows = ((i + 1, next(csv.reader([lines[i]]), [])) for i in over if i < len(lines))
    for line, row in rows:
        if line > 1 and len(row) > n_head and any(f.strip() for f in row[n_head:]):
            raise LogFormatError(path, f"{len(row)} fields, but the header has {n_head}", line=line)


class _Repairs(list):
    """The reader's repairs; each is also a note, in the order the reader met it."""

    def __init__(self, notes: list[str]):
        super().__init__()
        self.notes = notes

    def append(self, text: str) -> None:
        super().append(text)
        self.notes.append(text)


def _read_bytes(path: Path) -> bytes:
    """The file's bytes, read once; more than :data:`MAX_ROWS` rows (newlines) is refused before
    anything is parsed (the rest then only counted, a megabyte at a time)."""
    chunks, n = [], -1                      # the header's line
    with open(path, "rb") as fh:
        while chunk := fh.read(1 << 20):
            n += chunk.count(b"\n")
            if n <= MAX_ROWS:
                chunks.append(chunk)
    if n > MAX_ROWS:
        raise LogFormatError(path, f"{n} rows, more than the {MAX_ROWS} a log may have (ten times the "
                                   f"longest ride at the fastest logger's rate); split the log")
    return b"".join(chunks)


def read_log(path, *, layout: str | None = None, emit_warnings: bool = True) -> Ride:
    """Read an EUC telemetry log (WheelLog, EUC World or DarknessBot CSV).

    Parameters
    ----------
    path : str or path
        The CSV file.
    layout : str, optional
        Force a layout (one of :data:`LAYOUTS`); by default recognised from the header.
    emit_warnings : bool
        Also issue each note as a :class:`RideLogWarning`.

    Returns
    -------
    Ride
        The columns in SI units, what the reader did, the app's own counters.

    Raises
    ------
    LogFormatError
        Bad input, naming file, column and line.
    FileNotFoundError
        When ``path`` does not exist.
    """
    path = Path(path)
    raw = whole = _read_table(path)
    lay = _layout_of(raw, layout, path)
    notes: list[str] = []
    repairs = _Repairs(notes)
    n_read = len(raw)
    speed_col = next(c for c in lay.speed.columns if c in raw.columns)
    raw = _drop_truncated_last(raw, list(lay.time_columns) + [speed_col], repairs)
    stamps, offset = _times(raw, lay, path)
    out, absent, keep = _channels(raw, lay, speed_col, path, notes, repairs)
    table = pd.DataFrame(out)[keep]
    stamps = stamps[keep]
    start = pd.Timestamp(stamps.to_numpy().min())
    table.insert(0, "t", (stamps - start).dt.total_seconds().to_numpy())
    table, n_merged = _time_ordered(table, repairs)
    table["v"] = speed_sign(table["v"].to_numpy(float), table["t"].to_numpy(float), speed_col,
                            partial(LogFormatError, path), repairs)
    summary = _sampling_summary(table["t"].to_numpy(), GAP_POLICY.gap)
    if summary:
        notes.append(summary)
    variant = ""
    if lay.name == "wheellog":
        newcols = {"latitude", "gps_speed", "phase_current", "torque", "pwm"}
        variant = "new" if newcols & set(raw.columns) else "old"
    if emit_warnings:
        for n in notes:
            _warnings.warn(f"{path.name}: {n}", RideLogWarning, stacklevel=2)
    table = table.reset_index(drop=True)
    return Ride(path=str(path), layout=lay.name, variant=variant, data=table, start=start,
                absent=tuple(absent), warnings=tuple(notes), n_rows_read=n_read,
                n_rows_merged=n_merged, repairs=tuple(repairs), counters=log_counters(whole, table),
                utc_offset_s=offset)


def _read_table(path: Path) -> pd.DataFrame:
    """The CSV's cells (numbers where a whole column is numbers, text else; empty cells NaN
    except in the time stamps' columns) with stripped column names, the file read once;
    one-line errors naming the file."""
    if path.is_dir():
        raise LogFormatError(path, "a folder, not a log file (give one CSV file)")
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such file")
    data = _read_bytes(path)
    try:
        text = data.decode("utf-8").removeprefix("\ufeff")
    except UnicodeDecodeError as exc:
        raise LogFormatError(path, f"not a UTF-8 text CSV file ({exc.reason})") from None
    header = next(csv.reader(io.StringIO(text[:text.find("\n") + 1 or None]), skipinitialspace=True), None)
    if header is not None:
        _check_header(path, header)
        _check_field_counts(path, data, text, len(header))
    empty = [""] + ["".join(c) for w in _EMPTY for c in itertools.product(*zip(w, w.upper()))]
    times = {c for lay in LAYOUTS.values() for c in lay.time_columns}     # parsed as text
    # spaces after a comma or at a line's start are skipped; a file without any is read without
    # that check of every field; the time stamps' columns are text as the parser infers them,
    # read again as text only where it read numbers
    spaced = " " in text and (text.startswith(" ") or any(s in text for s in (", ", "\n ", "\r ")))
    read = lambda **dtype: pd.read_csv(                                  # noqa: E731
        io.StringIO(text), keep_default_na=False, skipinitialspace=spaced, index_col=False, low_memory=False,
        na_values={c: empty for c in (header or ()) if c.strip() not in times}, **dtype)
    try:
        raw = read()
        if any(str(raw[c].dtype) != "str" for c in raw.columns if str(c).strip() in times):
            raw = read(dtype={c: str for c in (header or ()) if c.strip() in times})
    except pd.errors.EmptyDataError:
        raise LogFormatError(path, "empty file: expected a header row and data rows") from None
    except pd.errors.ParserError as exc:
        raise LogFormatError(path, f"not a readable CSV table ({str(exc).strip()})") from None
    raw.columns = [str(c).strip() for c in raw.columns]
    if len(raw) == 0:
        raise LogFormatError(path, "header only, no data rows")
    return raw


def _layout_of(raw: pd.DataFrame, layout: str | None, path: Path):
    """The forced layout, its required columns checked, or the one recognised from the header."""
    if layout is None:
        return detect_layout(raw.columns, path)
    if layout not in LAYOUTS:
        raise ValueError(f"unknown layout {layout!r}; expected one of {', '.join(LAYOUTS)}")
    lay = LAYOUTS[layout]
    for col in lay.time_columns + lay.speed.columns[:1]:
        if col not in raw.columns:
            raise LogFormatError(path, f"missing required column for the {lay.name} layout", column=col)
    return lay


def _drop_truncated_last(raw: pd.DataFrame, required: list[str], notes: list[str]) -> pd.DataFrame:
    """A truncated last line (required cells empty) is dropped, loudly (a note)."""
    last = raw.iloc[-1]
    blank = [c for c in required if pd.isna(last[c]) or not str(last[c]).strip()]
    if blank and len(raw) > 1:
        notes.append(f"dropped the truncated last line {len(raw) + 1} (empty {', '.join(blank)})")
        return raw.iloc[:-1]
    return raw


def _channels(raw: pd.DataFrame, lay, speed_col: str, path: Path, notes: list[str],
              repairs: list[str]) -> tuple[dict[str, np.ndarray], list[str], np.ndarray]:
    """The layout's channels in SI units (``v`` first), the names of the absent ones, and
    the rows to keep (those whose speed is in range; :func:`bound_channel`)."""
    v, keep = bound_channel("v", speed_col, _numeric(raw[speed_col], speed_col, path, required=True)
                            * lay.speed.scale, partial(LogFormatError, path), repairs)
    out = {"v": v}
    absent: list[str] = []
    for name, ch in lay.channels.items():
        col = next((c for c in ch.columns if c in raw.columns), None)
        if col is None:
            absent.append(name)
            continue
        vals, _ = bound_channel(name, col, _numeric(raw[col], col, path, required=False) * ch.scale,
                                partial(LogFormatError, path), repairs)
        finite = np.isfinite(vals)
        if not finite.any():
            absent.append(name)
            if name in ("tilt", "roll") or name in _GPS:
                notes.append(f"{col}: all {len(vals)} cells empty; treated as absent")
            continue
        if np.all(vals[finite] == 0.0) and name != "distance":
            absent.append(name)
            notes.append(f"{col}: all {len(vals)} values are zero (the wheel does not "
                         f"report it); treated as absent")
            continue
        n_empty = int((~finite).sum())
        if n_empty:
            notes.append(f"{col}: {n_empty} of {len(vals)} cells empty (kept as NaN)")
        out[name] = vals
    # tilt/roll with no column at all are worth saying too.
    for name in ("tilt", "roll"):
        if not any(c in raw.columns for c in lay.channels[name].columns):
            notes.append(f"{name}: no such column in this log; treated as absent")
    if "pwm" not in out and "safety_margin" in out:
        # EUC World's safety margin is the headroom left before the motor's voltage
        # limit, % (100 at rest): the duty is its complement.
        out["pwm"] = 100.0 - out["safety_margin"]
        absent = [a for a in absent if a != "pwm"]
        notes.append("pwm: taken as 100 - safety_margin (EUC World's headroom before the "
                     "voltage limit)")
    return out, absent, keep


def _time_ordered(table: pd.DataFrame, notes: list[str]) -> tuple[pd.DataFrame, int]:
    """Rows in time order, repeated time stamps averaged into one row; the number merged."""
    back = int((np.diff(table["t"].to_numpy()) < 0).sum())
    if back:
        notes.append(f"time ran backwards at {back} row(s); rows put in time order")
        table = table.sort_values("t", kind="stable").reset_index(drop=True)
    same = np.diff(table["t"].to_numpy()) == 0          # in time order: a repeat follows its stamp
    n_merged = int(same.sum())
    if n_merged:
        n_stamps = int((same & ~np.r_[False, same[:-1]]).sum())
        table = table.groupby("t", sort=True, as_index=False).mean()
        notes.append(f"repeated time stamps: {n_stamps} time stamp(s) shared by "
                     f"{n_merged + n_stamps} rows; averaged into one row each ({n_merged} rows merged)")
    return table, n_merged
