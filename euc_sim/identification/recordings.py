"""Reading and validating recordings (CONTRACT.md, "A recording").

A CSV or Parquet file, one sample a row, SI units and radians, with an optional sidecar
``NAME.json``; ``NAME.truth.json`` is never read here.  Every problem is a
:class:`RecordingError` whose one-line message names the file, the column and the row
(1-based data row).
"""

from __future__ import annotations

import json
import math
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from euc_sim.errors import BadInputFile
from euc_sim.model.parameters import Params, check_plausible

__all__ = [
    "RecordingError", "RecordingWarning", "STATE_COLUMNS", "ANGLE_COLUMNS",
    "read_recording", "read_sidecar", "params_from_meta", "validate_recording",
    "check_time", "check_finite", "check_angles", "check_magnitudes", "check_length", "is_mocap",
]

#: The generalized coordinates every state-level recording carries.
STATE_COLUMNS = ("t", "x", "gamma", "phi")
#: Columns holding angles, rad.
ANGLE_COLUMNS = ("gamma", "phi", "psi", "theta")
#: Largest |pitch, lean or tilt|, rad: beyond it (0.52, i.e. 0.52° if in degrees) the column looks like degrees.
PITCH_LIMIT = math.radians(30.0)
#: Plausible sample period of a recording, s: 10 kHz to 10 Hz (milliseconds and sample indices fall outside).
SAMPLE_PERIOD_RANGE = (1e-4, 0.1)
#: Largest plausible |value| of a column, in its SI unit: positions (m), torques (N·m).
MAGNITUDE_LIMITS = {"x": 1e5, "M_d": 1e4, "M_h": 1e4}
#: Largest plausible |coordinate| of a motion-capture column, m.
MOCAP_LIMIT = 1e5
#: Longest run of missing samples that is interpolated (with a warning), samples.
MAX_GAP = 5


class RecordingError(BadInputFile):
    """A recording that cannot be used; the one-line message names file, column, row."""


class RecordingWarning(UserWarning):
    """Something was repaired (short gaps interpolated); the message says how much."""


def is_mocap(df: pd.DataFrame) -> bool:
    """True when the frame carries motion-capture columns instead of x and phi."""
    return "phi" not in df.columns and {"G_X", "G_Z", "gamma", "psi", "theta"} <= set(df.columns)


def read_sidecar(path: str | Path) -> dict[str, Any]:
    """The metadata in ``NAME.json`` beside ``NAME.csv``; ``{}`` when there is none (RecordingError when not a
    JSON object)."""
    path = Path(path)
    if not path.name or path.is_dir():
        raise RecordingError(f"{path}: is a folder, expected a recording file (.csv or .parquet)")
    side = path.with_suffix(".json")
    if side.name.endswith(".truth.json") or not side.is_file():
        return {}
    try:
        meta = json.loads(side.read_text(encoding="utf-8"))
    except UnicodeDecodeError as exc:
        raise RecordingError(f"{side}: sidecar is not UTF-8 text (byte {exc.start}: "
                             f"{exc.object[exc.start:exc.start + 1]!r})") from None
    except (OSError, ValueError, RecursionError) as exc:
        raise RecordingError(f"{side}: sidecar is not valid JSON ({exc})") from None
    if not isinstance(meta, dict):
        raise RecordingError(f"{side}: sidecar must hold a JSON object, got {type(meta).__name__}")
    params = meta.get("params")
    if params is not None and not isinstance(params, dict):
        raise RecordingError(f"{side}: \"params\" must be an object {{NAME: value}}, "
                             f"got {type(params).__name__}")
    for name, value in (params or {}).items():
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise RecordingError(f"{side}: \"params\".{name} must be a number, got {value!r}")
    if meta.get("d_CE") is not None and (isinstance(meta["d_CE"], bool)
                                         or not isinstance(meta["d_CE"], (int, float))):
        raise RecordingError(f"{side}: \"d_CE\" must be a number (m), got {meta['d_CE']!r}")
    _check_maneuver_options(side, meta.get("maneuver_options"))
    return meta


def _check_maneuver_options(side: Path, opts) -> None:
    """``maneuver_options``: an object of finite numbers or null (the maneuver's default; the
    maneuver checks their ranges)."""
    if opts is None:
        return
    if not isinstance(opts, dict):
        raise RecordingError(f"{side}: \"maneuver_options\" must be an object {{NAME: value}}, "
                             f"got {type(opts).__name__}")
    for name, value in opts.items():
        if value is None:
            continue
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise RecordingError(f"{side}: \"maneuver_options\".{name} must be a finite number or null, "
                                 f"got {value!r}")


def params_from_meta(meta: dict[str, Any], source: str | Path = "sidecar") -> Params:
    """Table 3 overridden by ``meta["params"]`` (RecordingError naming the sidecar and the parameter)."""
    values = meta.get("params") or {}
    if not isinstance(values, dict):
        raise RecordingError(f"{source}: \"params\" must be an object {{NAME: value}}, "
                             f"got {type(values).__name__}")
    try:
        return check_plausible(Params.from_mapping(values), values)
    except (ValueError, TypeError) as exc:
        raise RecordingError(f"{source}: {exc}") from None


def _first_row(mask: np.ndarray) -> int:
    """1-based data row of the first True."""
    return int(np.flatnonzero(mask)[0]) + 1


def check_time(df: pd.DataFrame, name: str) -> None:
    """Strictly increasing, finite time (RecordingError naming the first row where it is not)."""
    t = df["t"].to_numpy(dtype=float)
    bad = ~np.isfinite(t)
    if bad.any():
        raise RecordingError(f"{name}: column 't' row {_first_row(bad)}: time must be finite, "
                             f"got {float(t[bad][0])!r}")
    dt = np.diff(t)
    if len(dt) and (dt > 0).all():
        period = float(np.median(dt))
        lo, hi = SAMPLE_PERIOD_RANGE
        if not lo <= period <= hi:
            guess = (" (sample indices?)" if period == 1.0 else
                     " (milliseconds?)" if lo <= 1e-3 * period <= hi else "")
            raise RecordingError(f"{name}: column 't' row 2: sample period {period:.4g}{guess}; "
                                 f"time must be in seconds with a period of {lo:g}-{hi:g} s")
    if (dt <= 0).any():
        i = int(np.flatnonzero(dt <= 0)[0]) + 1
        what = "duplicate" if dt[i - 1] == 0 else "decreasing"
        raise RecordingError(f"{name}: column 't' row {i + 1}: {what} time {float(t[i]):g} s after "
                             f"{float(t[i - 1]):g} s; time must be strictly increasing")
    if len(dt) and (dt.max() > 1.5 * np.median(dt) * 1.0001 + 1e-12):
        i = int(np.argmax(dt)) + 1
        raise RecordingError(f"{name}: column 't' row {i + 1}: time step {dt[i - 1]:.4g} s "
                             f"is uneven (median {np.median(dt):.4g} s); resample the recording "
                             f"to a uniform rate")


def check_finite(df: pd.DataFrame, name: str, columns) -> pd.DataFrame:
    """Interpolate runs of NaN/inf up to :data:`MAX_GAP` samples in ``columns`` (with a RecordingWarning), refuse
    longer ones or gaps at an end; returns a new frame."""
    out = df.copy()
    repaired = 0
    for col in columns:
        y = out[col].to_numpy(dtype=float, copy=True)
        bad = ~np.isfinite(y)
        if not bad.any():
            continue
        edges = np.diff(np.concatenate([[0], bad.astype(int), [0]]))
        starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
        for s, e in zip(starts, ends):
            if e - s > MAX_GAP or s == 0 or e == len(y):
                where = "at the start" if s == 0 else "at the end" if e == len(y) else "long"
                raise RecordingError(
                    f"{name}: column {col!r} row {s + 1}: {e - s} missing or non-finite "
                    f"value(s) ({where} gap; at most {MAX_GAP} inside the recording are "
                    f"interpolated)")
        idx = np.arange(len(y))
        y[bad] = np.interp(idx[bad], idx[~bad], y[~bad])
        out[col] = y
        repaired += int(bad.sum())
    if repaired:
        warnings.warn(f"{name}: interpolated {repaired} missing or non-finite sample(s)",
                      RecordingWarning, stacklevel=2)
    return out


def check_angles(df: pd.DataFrame, name: str) -> None:
    """Refuse angle columns that look like degrees: ``gamma``, ``phi``, ``theta`` beyond :data:`PITCH_LIMIT`,
    ``psi`` stepping over 1 rad a sample."""
    for col in ("gamma", "phi", "theta"):
        if col in df.columns:
            y = df[col].to_numpy(dtype=float)
            bad = np.abs(y) > PITCH_LIMIT
            if bad.any():
                raise RecordingError(
                    f"{name}: column {col!r} row {_first_row(bad)}: {y[bad][0]:.4g} looks like "
                    f"degrees (expected |angle| <= {PITCH_LIMIT:.2f} rad, i.e. "
                    f"{math.degrees(PITCH_LIMIT):.0f}°); angles must be in radians")
    if "psi" in df.columns:
        step = np.abs(np.diff(df["psi"].to_numpy(dtype=float)))
        bad = step > 1.0
        if bad.any():
            i = int(np.flatnonzero(bad)[0]) + 1
            raise RecordingError(f"{name}: column 'psi' row {i + 1}: yaw jumps by {step[i - 1]:.4g} "
                                 f"in one sample; angles must be in radians and unwrapped")


def check_magnitudes(df: pd.DataFrame, name: str) -> None:
    """Refuse values no ride reaches (1e300 m, 1e6 N·m): a wrong unit or a corrupt file."""
    limits = dict(MAGNITUDE_LIMITS)
    limits.update({c: MOCAP_LIMIT for c in df.columns if str(c).startswith(("C_", "E_", "G_"))})
    for col, limit in limits.items():
        if col in df.columns:
            y = df[col].to_numpy(dtype=float)
            bad = np.abs(y) > limit
            if bad.any():
                raise RecordingError(f"{name}: column {col!r} row {_first_row(bad)}: "
                                     f"{y[bad][0]:.4g} is implausible (expected |value| <= {limit:g} "
                                     f"in SI units)")


def check_length(df: pd.DataFrame, name: str, min_samples: int, why: str = "the smoothing window") -> None:
    """Refuse a recording shorter than ``min_samples`` rows."""
    if len(df) < min_samples:
        raise RecordingError(f"{name}: column 't' row {len(df)}: only {len(df)} samples, "
                             f"too short for {why} (needs at least {min_samples})")


def validate_recording(df: pd.DataFrame, name: str = "recording") -> pd.DataFrame:
    """Check a recording's columns (state ``t, x, gamma, phi`` or motion capture), time, values and angles;
    returns a repaired copy."""
    cols = set(df.columns)
    if "t" not in cols:
        raise RecordingError(f"{name}: column 't' row 0: missing required column 't' "
                             f"(found {', '.join(map(str, df.columns)) or 'none'})")
    if is_mocap(df) or any(c.startswith(("G_", "E_", "C_")) for c in cols) and "phi" not in cols:
        need = ["t", "G_X", "G_Y", "G_Z", "psi", "theta", "gamma"]
        if not {"C_X", "C_Y", "C_Z"} <= cols:
            need += ["E_X", "E_Y", "E_Z"]
    else:
        need = list(STATE_COLUMNS)
    missing = [c for c in need if c not in cols]
    if missing:
        raise RecordingError(f"{name}: column {missing[0]!r} row 0: missing required column(s) "
                             f"{', '.join(missing)}")
    numeric = [c for c in df.columns
               if c in need or c in ANGLE_COLUMNS or c in ("M_d", "M_h")
               or c.startswith(("C_", "E_", "G_"))]
    for c in numeric:
        if (pd.api.types.is_timedelta64_dtype(df[c]) or pd.api.types.is_datetime64_any_dtype(df[c])
                or isinstance(df[c].dtype, pd.CategoricalDtype)):
            raise RecordingError(f"{name}: column {c!r} row 1: expected plain numbers in SI units "
                                 f"(seconds, m, rad), got {df[c].dtype} values")
        if pd.api.types.is_bool_dtype(df[c]):
            raise RecordingError(f"{name}: column {c!r} row 1: expected numbers, got booleans")
        if not pd.api.types.is_numeric_dtype(df[c]):
            conv = pd.to_numeric(df[c], errors="coerce")
            bad = conv.isna() & df[c].notna()
            if bad.any():
                row = _first_row(bad.to_numpy())
                raise RecordingError(f"{name}: column {c!r} row {row}: not a number: "
                                     f"{df[c].iloc[row - 1]!r}")
            df = df.assign(**{c: conv})
    check_time(df, name)
    df = check_finite(df, name, [c for c in numeric if c != "t"])
    check_angles(df, name)
    check_magnitudes(df, name)
    check_length(df, name, 8, "any derivative")
    return df


def read_recording(path: str | Path) -> tuple[pd.DataFrame, dict[str, Any]]:
    """Read and validate a recording (``NAME.csv`` or ``NAME.parquet``) and its sidecar.

    Returns
    -------
    df : pandas.DataFrame
        The validated columns (short gaps, up to :data:`MAX_GAP` samples, interpolated).
    meta : dict
        The sidecar ``NAME.json`` (``{}`` when absent) plus ``"path"``.

    Raises
    ------
    RecordingError, FileNotFoundError
    """
    path = Path(path)
    name = str(path)
    if not path.is_file():
        raise FileNotFoundError(f"{name}: no such recording")
    suffix = path.suffix.lower()
    if suffix not in (".parquet", ".pq", ".csv", ".txt", ""):
        raise RecordingError(f"{name}: unknown recording format {suffix!r}; expected .csv or .parquet")
    try:
        df = pd.read_parquet(path) if suffix in (".parquet", ".pq") else pd.read_csv(path)
    except (ValueError, OSError, pd.errors.ParserError) as exc:
        msg = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise RecordingError(f"{name}: cannot read as {suffix.lstrip('.') or 'csv'}: {msg}") from None
    df.columns = [str(c).strip() for c in df.columns]
    df = validate_recording(df, name)
    return df, dict(read_sidecar(path), path=name)
