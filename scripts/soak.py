"""Soak the command line: N random valid command lines and N random malformed inputs.

Every run is one ``euc-sim`` process in its own empty folder (its working directory,
with ``TMPDIR`` pointed at a folder of its own), and is sorted by what it did:

- **finished**: exit 0 (or ``stability``'s exit 1 for an unstable loop, a verdict);
- **refused**: exit 2 with one line ``euc-sim CMD: error: ...`` (progress lines aside);
- **internal**: exit 1 with the line ``euc-sim CMD: internal error: ...``;
- **crash**: anything else: a traceback, a signal, another code, a refusal on more
  than one line, or no end within the time limit;
- **leftovers** (counted across the others): a file the run should not have left:
  a temporary or probe file, ``MUJOCO_LOG.TXT``, anything in its ``TMPDIR``, any new
  file after a refusal, or any file but the named outputs after a finish.

Inputs (a few short recordings and a WheelLog-layout log) are made once, then copied
into each run's folder.  Every draw comes from ``--seed``::

    nice python scripts/soak.py --valid 60 --malformed 60 --workers 2 --json soak.json

Progress goes to a terminal only; the counts go to stdout (and ``--json``).
"""

from __future__ import annotations

import argparse
import json
import os
import random
import re
import shutil
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import asdict, dataclass, field
from pathlib import Path

#: Recordings made once: name -> the ``simulate`` options that make it (short, seeded).
POOL = {
    "decel.csv": ["--maneuver", "deceleration", "--duration", "5", "--seed", "1"],
    "stopgo.csv": ["--maneuver", "stop_and_go", "--duration", "5", "--seed", "2"],
    "circle.csv": ["--model", "3d", "--maneuver", "circle", "--duration", "5", "--seed", "3"],
}
PLANAR_MANEUVERS = ("constant_speed", "acceleration", "deceleration", "stop_and_go")
PATHS_3D = ("straight", "circle", "u_turn", "slalom", "figure_eight")
#: Seconds a run may take before it counts as a crash (hung).
TIME_LIMIT = 300.0
BAD_NUMBERS = ("nan", "inf", "-inf", "-1", "0", "1e300", "-1e300", "1e9", "x", "", "1,2", "0x10")


@dataclass
class Run:
    """One command line, what it may write, and what became of it."""

    kind: str                     # "valid" or "malformed"
    argv: list[str]
    outputs: list[str] = field(default_factory=list)      # names it may leave after exit 0
    inputs: list[str] = field(default_factory=list)       # pool files copied in first
    edit: dict = field(default_factory=dict)              # how an input is spoilt (malformed)
    outcome: str = ""
    code: int | None = None
    seconds: float = 0.0
    leftovers: list[str] = field(default_factory=list)
    last_line: str = ""


# --- the inputs ----------------------------------------------------------------------
def make_pool(folder: Path, env: dict) -> None:
    """Simulate the pool's recordings and write the WheelLog-layout log into ``folder``."""
    for name, opts in POOL.items():
        if not (folder / name).exists():
            _euc(["simulate", *opts, "--out", str(folder / name)], folder, env, check=True)
    if not (folder / "LOG.csv").exists():
        wheellog(folder / "LOG.csv", random.Random(0))


def wheellog(path: Path, rng: random.Random, n: int = 900) -> Path:
    """A WheelLog-layout ride, 3 min at 5 Hz, its odometer counting what its speed says."""
    import numpy as np
    import pandas as pd

    g = np.random.default_rng(rng.randrange(2**32))
    t = np.arange(n) * 0.2
    v = 20.0 + 6.0 * np.sin(t / 9.0) + 3.0 * np.sin(t / 2.3)
    dist = np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) / 3.6 * 0.2)])
    stamp = pd.Timestamp("2021-06-01 10:00:00") + pd.to_timedelta(t, unit="s")
    current = 6.0 + 0.4 * np.gradient(v, 0.2) + 0.3 * g.standard_normal(n)
    pd.DataFrame({
        "date": stamp.strftime("%Y-%m-%d"), "time": stamp.strftime("%H:%M:%S.%f").str[:-3],
        "speed": np.round(v, 2), "voltage": np.round(82.0 - t / 200.0, 2), "current": np.round(current, 2),
        "power": np.round((82.0 - t / 200.0) * current, 2), "battery_level": 90,
        "distance": np.floor(dist), "totaldistance": 1000 + np.floor(dist), "system_temp": 30,
        "cpu_temp": 0, "tilt": 0.0, "roll": 0.0, "mode": 0, "alert": "",
    }).to_csv(path, index=False)
    return path


# --- valid command lines ---------------------------------------------------------------
def valid_run(rng: random.Random) -> Run:
    """A random command line that should finish (short durations)."""
    kind = rng.choices(["simulate", "simulate3d", "identify", "torques", "diagnose", "stability",
                        "dynamics", "dataset", "ride", "render"],
                       weights=[6, 3, 3, 2, 2, 2, 1, 1, 1, 1])[0]
    return _VALID[kind](rng)


def _simulate(rng):
    from euc_sim.simulation.effects import CATALOG

    argv = ["simulate", "--maneuver", rng.choice(PLANAR_MANEUVERS), "--duration",
            f"{rng.uniform(1.0, 4.0):.2f}", "--seed", str(rng.randrange(10**6)),
            "--engine", rng.choice(["mujoco", "mujoco", "analytic"])]
    planar = [e for e in CATALOG.values() if not e.needs and e.name != "lateral_dynamics"]
    for eff in rng.sample(planar, rng.choice([0, 0, 1, 2])):
        lo, hi = eff.plausible
        argv += ["--effect", f"{eff.name}={rng.uniform(lo, hi):.4g}"]
    return Run("valid", argv + ["--out", "r.csv"], ["r.csv", "r.json", "r.truth.json"])


def _simulate3d(rng):
    argv = ["simulate", "--model", "3d", "--maneuver", rng.choice(PATHS_3D), "--duration",
            f"{rng.uniform(1.5, 4.0):.2f}", "--seed", str(rng.randrange(10**6)), "--out", "r.csv"]
    return Run("valid", argv, ["r.csv", "r.json", "r.truth.json"])


def _identify(rng):
    rec = rng.choice(["decel.csv", "stopgo.csv", "circle.csv"])
    argv = ["identify", rec, "--n-boot", str(rng.choice([0, 50, 100])), "--noise-replicates",
            str(rng.choice([0, 5])), "--seed", str(rng.randrange(1000)), "--json", "o.json"]
    return Run("valid", argv, ["o.json"], [rec])


def _torques(rng):
    rec = rng.choice(["decel.csv", "stopgo.csv", "circle.csv"])
    return Run("valid", ["torques", rec, "--out", "T.csv"], ["T.csv"], [rec])


def _diagnose(rng):
    rec = rng.choice(["decel.csv", "stopgo.csv", "circle.csv"])
    return Run("valid", ["diagnose", rec, "--json", "d.json"], ["d.json"], [rec])


def _stability(rng):
    argv = ["stability", "--speed", f"{rng.uniform(0.0, 8.0):.2f}", "--rider-delay",
            f"{rng.uniform(0.05, 0.3):.3f}", "--json", "s.json"]
    return Run("valid", argv, ["s.json"])


def _dynamics(rng):
    q = ",".join(f"{rng.uniform(-0.1, 0.1):.3f}" for _ in range(3))
    return Run("valid", ["dynamics", f"--q={q}", "--json", "y.json"], ["y.json"])


def _dataset(rng):
    argv = ["dataset", "--out-dir", "D", "--duration", f"{rng.uniform(1.0, 2.0):.2f}", "--seed",
            str(rng.randrange(1000)), "--workers", rng.choice(["1", "2"]), "--quiet"]
    return Run("valid", argv, ["D"])


def _ride(rng):
    return Run("valid", ["ride", "LOG.csv", "--no-simulate", "--quiet", "--n-boot", "50",
                         "--json", "ride.json"], ["ride.json"], ["LOG.csv"])


def _render(rng):
    return Run("valid", ["render", "circle.csv", "--out", "f.png", "--quiet"], ["f.png"], ["circle.csv"])


_VALID = {"simulate": _simulate, "simulate3d": _simulate3d, "identify": _identify, "torques": _torques,
          "diagnose": _diagnose, "stability": _stability, "dynamics": _dynamics, "dataset": _dataset,
          "ride": _ride, "render": _render}


# --- malformed inputs -------------------------------------------------------------------
def malformed_run(rng: random.Random) -> Run:
    """A random command line on a spoilt input, a bad option, or an output that is an input."""
    kind = rng.choice(["csv", "csv", "sidecar", "option", "option", "same", "path", "log", "name", "special"])
    return _MALFORMED[kind](rng)


def _reader(rng, rec: str) -> tuple[list[str], list[str]]:
    """A command that reads ``rec``, and its outputs."""
    cmd = rng.choice(["torques", "identify", "diagnose", "render"])
    if cmd == "torques":
        return ["torques", rec, "--out", "T.csv"], ["T.csv"]
    if cmd == "identify":
        return ["identify", rec, "--n-boot", "50", "--noise-replicates", "0", "--json", "o.json"], ["o.json"]
    if cmd == "diagnose":
        return ["diagnose", rec, "--no-resimulate", "--json", "d.json"], ["d.json"]
    return ["render", rec, "--out", "f.png", "--quiet"], ["f.png"]


def _bad_csv(rng):
    rec = rng.choice(["decel.csv", "stopgo.csv", "circle.csv"])
    edit = {"file": rec, "how": rng.choice(["drop", "nan", "text", "header", "truncate", "bytes",
                                            "dup", "scale", "empty", "latin1", "shuffle"]),
            "column": rng.choice(["t", "x", "gamma", "phi", "M_d", "psi", "C_X", "G_Z"]),
            "seed": rng.randrange(10**6)}
    argv, outs = _reader(rng, rec)
    return Run("malformed", argv, outs, [rec], edit)


def _bad_sidecar(rng):
    rec = rng.choice(["decel.csv", "stopgo.csv", "circle.csv"])
    junk = rng.choice(['[1, 2]', '"text"', '{"params": [1]}', '{"params": {"m": "heavy"}}',
                       '{"params": {"h": 1e300}}', '{"maneuver": "stop_and_go", "maneuver_options": [1]}',
                       '{"maneuver": "stop_and_go", "maneuver_options": {"cycles": 1e9}}',
                       '{"maneuver": "deceleration", "maneuver_options": "fast"}', '{"d_CE": "far"}',
                       '{', '\xff\xfe'])
    argv, outs = _reader(rng, rec)
    if argv[0] == "diagnose" and rng.random() < 0.5:
        argv.remove("--no-resimulate")
    return Run("malformed", argv, outs, [rec], {"file": rec, "how": "sidecar", "text": junk})


_OPTIONS = [  # (command line before the option, option, outputs)
    (["simulate", "--duration", "1", "--out", "r.csv"], "--duration", ["r.csv", "r.json", "r.truth.json"]),
    (["simulate", "--duration", "1", "--out", "r.csv"], "--rider-delay", ["r.csv", "r.json", "r.truth.json"]),
    (["simulate", "--duration", "1", "--out", "r.csv"], "--rider-noise", ["r.csv", "r.json", "r.truth.json"]),
    (["simulate", "--duration", "1", "--out", "r.csv"], "--seed", ["r.csv", "r.json", "r.truth.json"]),
    (["simulate", "--duration", "1", "--out", "r.csv"], "--effect", ["r.csv", "r.json", "r.truth.json"]),
    (["simulate", "--duration", "1", "--out", "r.csv"], "--param", ["r.csv", "r.json", "r.truth.json"]),
    (["stability"], "--speed", []), (["stability"], "--rider-delay", []), (["stability"], "--param", []),
    (["dynamics"], "--q", []),
    (["identify", "decel.csv", "--json", "o.json"], "--n-boot", ["o.json"]),
    (["identify", "decel.csv", "--n-boot", "50", "--json", "o.json"], "--noise-replicates", ["o.json"]),
    (["identify", "decel.csv", "--n-boot", "50", "--json", "o.json"], "--order", ["o.json"]),
    (["identify", "decel.csv", "--n-boot", "50", "--json", "o.json"], "--window", ["o.json"]),
    (["identify", "decel.csv", "--n-boot", "50", "--json", "o.json"], "--h-max", ["o.json"]),
    (["torques", "decel.csv", "--out", "T.csv"], "--term-sigma", ["T.csv"]),
    (["ride", "LOG.csv", "--no-simulate", "--quiet", "--json", "ride.json"], "--mass", ["ride.json"]),
    (["ride", "LOG.csv", "--no-simulate", "--quiet", "--json", "ride.json"], "--n-boot", ["ride.json"]),
    (["ride", "LOG.csv", "--no-simulate", "--quiet", "--json", "ride.json"], "--efficiency", ["ride.json"]),
    (["render", "circle.csv", "--out", "f.png", "--quiet"], "--fps", ["f.png"]),
    (["design", "--json", "g.json"], "--rides", ["g.json"]),
    (["dataset", "--out-dir", "D", "--quiet"], "--workers", ["D"]),
    (["dataset", "--out-dir", "D", "--quiet"], "--scheduler", ["D"]),
]


def _bad_option(rng):
    head, option, outs = rng.choice(_OPTIONS)
    value = rng.choice(BAD_NUMBERS)
    if option in ("--effect", "--param"):
        value = rng.choice(["aerodynamic_drag=1e300", "rolling_resistance=nan", "nothing=1", "m=1e300",
                            "h=-1", "R", "=3", "road_slope=x"])
    elif option == "--q":
        value = rng.choice(["1,2", "nan,0,0", "a,b,c", "1e300,0,0", ""])
    elif option == "--scheduler":
        value = rng.choice(["a:b", "tcp://", "http://x", "nowhere"])
    if option == "--duration" and value in ("1e9", "1e300"):
        value = "-5"                   # a valid but hour-long run is not a malformed input
    inputs = [a for a in head if a.endswith(".csv") and a in (*POOL, "LOG.csv")]
    return Run("malformed", head + [option, value], outs, inputs)


def _same_file(rng):
    case = rng.choice([
        (["torques", "decel.csv", "--out", "decel.csv"], ["decel.csv"]),
        (["identify", "decel.csv", "--json", "decel.csv"], ["decel.csv"]),
        (["identify", "decel.csv", "--json", "decel.json"], ["decel.csv"]),
        (["identify", "decel.csv", "--json", "decel.truth.json"], ["decel.csv"]),
        (["diagnose", "decel.csv", "--json", "decel.csv"], ["decel.csv"]),
        (["diagnose", "decel.csv", "--json", "decel.json"], ["decel.csv"]),
        (["ride", "LOG.csv", "--json", "LOG.csv"], ["LOG.csv"]),
        (["simulate", "--duration", "1", "--profile", "decel.csv", "--out", "decel.csv"], ["decel.csv"]),
    ])
    return Run("malformed", case[0], [], case[1])


def _bad_path(rng):
    case = rng.choice([
        (["torques", "missing.csv", "--out", "T.csv"], []),
        (["identify", ".", "--json", "o.json"], []),
        (["torques", "decel.csv", "--out", "decel.json/T.csv"], ["decel.csv"]),
        (["torques", "decel.csv", "--out", "."], ["decel.csv"]),
        (["simulate", "--duration", "1", "--out", "r.txt"], []),
        (["render", "decel.csv", "--out", "r.docx"], ["decel.csv"]),
        (["ride", "missing.csv", "--json", "r.json"], []),
        (["simulate", "--duration", "1", "--out", "r.csv"], ["foreign:r.json"]),
    ])
    return Run("malformed", case[0], [], [i for i in case[1] if not i.startswith("foreign:")],
               {"foreign": [i[8:] for i in case[1] if i.startswith("foreign:")]})


def _bad_log(rng):
    edit = {"file": "LOG.csv", "how": rng.choice(["drop", "nan", "text", "header", "truncate", "bytes",
                                                  "scale", "empty", "mph", "shuffle"]),
            "column": rng.choice(["speed", "voltage", "current", "date", "time", "totaldistance"]),
            "seed": rng.randrange(10**6)}
    return Run("malformed", ["ride", "LOG.csv", "--no-simulate", "--quiet", "--n-boot", "50",
                             "--json", "ride.json"], ["ride.json"], ["LOG.csv"], edit)


#: File names a user may give: a Markdown link, quotes, a newline, a leading dash, 244 and
#: 260 bytes (over NAME_MAX), non-ASCII.
HOSTILE_NAMES = ("[x](javascript:alert(1)).csv", "it's \"quoted\" <b>.csv", "new\nline.csv", "-dash.csv",
                 "x" * 240 + ".csv", "été 日本 🚲.csv", "é" * 128 + ".csv")


def _hostile_name(rng):
    """A pool input renamed to a hostile name, or an output given one."""
    name = rng.choice(HOSTILE_NAMES)
    arg = name if not name.startswith("-") or rng.random() < 0.5 else "./" + name
    if rng.random() < 0.5:                  # the input so named (its sidecars follow it)
        cmd = rng.choice(["torques", "diagnose", "ride"])
        pool_name = "LOG.csv" if cmd == "ride" else rng.choice(["decel.csv", "stopgo.csv"])
        argv = {"torques": ["torques", arg, "--out", "T.csv"],
                "diagnose": ["diagnose", arg, "--no-resimulate", "--quiet", "--json", "d.json"],
                "ride": ["ride", arg, "--no-simulate", "--quiet", "--n-boot", "10", "--json", "ride.json"]}[cmd]
        fits = len(name.encode()) + len(".truth.json") <= 255          # else it names no file
        return Run("malformed", argv, [argv[-1]], [pool_name], {"rename": {pool_name: name}} if fits else {})
    out = name.replace(".csv", ".json")
    cmd = rng.choice(["torques", "dynamics", "ride"])
    argv = {"torques": ["torques", "decel.csv", "--out", name.replace(".csv", ".T.csv")],
            "dynamics": ["dynamics", "--q", "0,0.05,0", "--json", out],
            "ride": ["ride", "LOG.csv", "--no-simulate", "--quiet", "--n-boot", "10", "--json", out]}[cmd]
    if argv[-1].startswith("-"):
        argv[-2:] = [f"{argv[-2]}={argv[-1]}"]       # --out=-x.csv: the one way to name it
    outs = [argv[-1].split("=", 1)[-1]]
    return Run("malformed", argv, outs, [a for a in argv if a in (*POOL, "LOG.csv")])


#: Special files: (command line, pool inputs, what :func:`spoil` makes).
SPECIAL = [
    (["torques", "pipe.csv", "--out", "T.csv"], [], {"fifo": ["pipe.csv"]}),
    (["torques", "decel.csv", "--out", "pipe.csv"], ["decel.csv"], {"fifo": ["pipe.csv"]}),
    (["ride", "LOG.csv", "--no-simulate", "--quiet", "--json", "pipe.json"], ["LOG.csv"], {"fifo": ["pipe.json"]}),
    (["rides", "logs", "--quiet", "--n-boot", "10", "--json", "r.json"], ["LOG.csv"],
     {"folder": "logs", "fifo": ["logs/stuck.csv"]}),
    (["rides", "logs", "--quiet", "--n-boot", "10", "--json", "logs/LOG.csv"], ["LOG.csv"], {"folder": "logs"}),
    (["torques", "away.csv", "--out", "T.csv"], ["decel.csv"], {"outside": {"away.csv": "decel.csv"}}),
    (["torques", "decel.csv", "--out", "away.csv"], ["decel.csv"], {"outside": {"away.csv": "stopgo.csv"}}),
    (["identify", "decel.csv", "--n-boot", "0", "--noise-replicates", "0", "--json", "away.json"], ["decel.csv"],
     {"hard": {"decel.csv": "away.json"}}),
    (["diagnose", "decel.csv", "--no-resimulate", "--quiet", "--report", "."], ["decel.csv"], {}),
    (["ride", "LOG.csv", "--no-simulate", "--quiet", "--report", "rep", "--json", "rep/index.html"], ["LOG.csv"], {}),
    (["ride", "LOG.csv", "--no-simulate", "--quiet", "--report", "rep"], ["LOG.csv"], {"mine": ["rep/index.md"]}),
]


def _special(rng):
    """A FIFO, a symbolic link to a file outside, a hard link, a folder with a FIFO, a report folder
    holding the user's file, an output inside the report folder."""
    argv, inputs, edit = rng.choice(SPECIAL)
    outs = [a for a in argv if a in ("T.csv", "r.json", "away.csv", "away.json")]
    return Run("malformed", list(argv), outs, list(inputs), dict(edit))


_MALFORMED = {"csv": _bad_csv, "sidecar": _bad_sidecar, "option": _bad_option, "same": _same_file,
              "path": _bad_path, "log": _bad_log, "name": _hostile_name, "special": _special}


def _special_files(folder: Path, edit: dict) -> None:
    """Make ``edit``'s hostile names and special files in ``folder`` (a run's working folder)."""
    for old, new in edit.get("rename", {}).items():
        for p in folder.glob(Path(old).stem + ".*"):      # the sidecars follow the recording
            p.rename(folder / (Path(new).stem + p.name[len(Path(old).stem):]))
    if "folder" in edit:
        sub = folder / edit["folder"]
        sub.mkdir()
        for p in folder.glob("LOG.*"):
            p.rename(sub / p.name)
    for name in edit.get("fifo", []):
        os.mkfifo(folder / name)
    outside = folder.parent / "outside"
    for link, pool_name in edit.get("outside", {}).items():   # a symbolic link to a file outside
        outside.mkdir(exist_ok=True)
        shutil.copy(folder.parent.parent / "pool" / pool_name, outside / link)
        (folder / link).symlink_to(outside / link)
    for src, name in edit.get("hard", {}).items():
        os.link(folder / src, folder / name)
    for name in edit.get("mine", []):
        (folder / name).parent.mkdir(parents=True, exist_ok=True)
        (folder / name).write_text("# the user's own notes\n")


def spoil(folder: Path, edit: dict) -> None:
    """Apply ``edit`` (from the malformed generators) to the copied input in ``folder``."""
    import numpy as np
    import pandas as pd

    for name in edit.get("foreign", []):
        (folder / name).write_text('{"not": "a sidecar of ours"}\n')
    _special_files(folder, edit)
    if "file" not in edit:
        return
    path, how, col = folder / edit["file"], edit["how"], edit.get("column")
    if how == "sidecar":
        path.with_suffix(".json").write_bytes(edit["text"].encode("utf-8", "surrogateescape")
                                              if edit["text"] != "\xff\xfe" else b"\xff\xfe")
        return
    rng = np.random.default_rng(edit["seed"])
    raw = path.read_bytes()
    if how in ("truncate", "bytes", "empty", "latin1"):
        path.write_bytes({"truncate": raw[: int(rng.integers(1, max(2, len(raw))))],
                          "bytes": rng.integers(0, 256, 300, dtype=np.uint8).tobytes(),
                          "empty": b"", "latin1": raw[:200] + "é\xff".encode("latin1") + raw[200:]}[how])
        return
    df = pd.read_csv(path)
    col = col if col in df.columns else df.columns[int(rng.integers(len(df.columns)))]
    i = int(rng.integers(len(df)))
    if how == "drop":
        df = df.drop(columns=col)
    elif how == "nan":
        df[col] = df[col].astype(float) if pd.api.types.is_numeric_dtype(df[col]) else df[col]
        df.loc[i:i + int(rng.integers(1, 50)), col] = np.nan
    elif how == "text":
        df[col] = df[col].astype(object)
        df.loc[i, col] = "abc"
    elif how == "header":
        df = df.head(0)
    elif how == "dup":
        df = pd.concat([df, df.iloc[[i]]]).sort_index()
    elif how == "scale" and pd.api.types.is_numeric_dtype(df[col]):
        df[col] = df[col] * float(rng.choice([1000.0, 57.3, -1.0, 1e-6, 1e250]))
    elif how == "shuffle":
        df = df.sample(frac=1.0, random_state=int(edit["seed"]) % 2**31)
    elif how == "mph" and "speed" in df:
        df["speed"] = (df["speed"] / 1.609344).round(2)
    df.to_csv(path, index=False)


# --- running and sorting ----------------------------------------------------------------
def _euc(argv, cwd: Path, env=None, check=False, timeout=TIME_LIMIT):
    cmd = ["nice", "-n", "10", sys.executable, "-m", "euc_sim.cli", *argv]
    p = subprocess.run(cmd, cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout)
    if check and p.returncode != 0:
        raise RuntimeError(f"{' '.join(argv)}: exit {p.returncode}: {p.stderr[-500:]}")
    return p


def execute(run: Run, pool: Path, scratch: Path, env: dict) -> Run:
    """Run ``run`` in a fresh folder under ``scratch``; fill in its outcome and leftovers."""
    folder = Path(tempfile.mkdtemp(prefix="run-", dir=scratch))
    work, tmp = folder / "work", folder / "tmp"
    work.mkdir()
    tmp.mkdir()
    for name in run.inputs:
        for p in pool.glob(Path(name).stem + ".*"):
            shutil.copy(p, work / p.name)
    spoil(work, run.edit)
    before = {p.relative_to(work): p.stat().st_mtime_ns for p in work.rglob("*")}
    env = {**env, "TMPDIR": str(tmp)}
    t0 = time.monotonic()
    try:
        p = _euc(run.argv, work, env)
        run.code, err = p.returncode, p.stderr
    except subprocess.TimeoutExpired as exc:
        run.code, err = None, (exc.stderr or b"").decode(errors="replace") if isinstance(exc.stderr, bytes) else (exc.stderr or "")
    run.seconds = round(time.monotonic() - t0, 2)
    run.outcome, run.last_line = classify(run, err)
    run.leftovers = leftovers(run, work, tmp, before)
    shutil.rmtree(folder, ignore_errors=True)
    return run


def classify(run: Run, err: str) -> tuple[str, str]:
    """``finished``, ``refused``, ``internal`` or ``crash``, and the line that decided it."""
    lines = [ln for ln in err.strip().splitlines() if ln.strip()]
    said = [ln for ln in lines if not ln.rstrip().endswith("...") and "warning:" not in ln]
    last = said[-1] if said else ""
    cmd = run.argv[0]
    if run.code is None:
        return "crash", f"no end within {TIME_LIMIT:g} s"
    if "Traceback (most recent call last)" in err:
        return "crash", last
    if run.code == 0 or (run.code == 1 and cmd == "stability" and "internal error" not in err):
        return "finished", last
    if run.code == 1 and re.match(rf"euc-sim {cmd}: internal error: .+; the traceback is in ", last):
        return "internal", last
    errors = [ln for ln in said if re.match(r"euc-sim( \w+)?: error: ", ln)]
    if run.code == 2 and len(errors) == 1 and errors[0] == last:
        return "refused", last
    if run.code == 2 and cmd == "dataset" and "recording(s) failed" in err:
        return "finished", last             # falls are named, the rest written: a verdict
    return "crash", f"exit {run.code}: {last}"


def leftovers(run: Run, work: Path, tmp: Path, before: dict) -> list[str]:
    """Files the run should not have left (see the module docstring)."""
    out = [f"TMPDIR/{p.relative_to(tmp)}" for p in tmp.rglob("*")
           if not (run.outcome == "internal" and "internal-error" in p.name)]
    for p in work.rglob("*"):
        rel = p.relative_to(work)
        top = rel.parts[0]
        changed = rel not in before or (p.is_file() and before[rel] != p.stat().st_mtime_ns)
        if ".tmp-" in p.name or p.name.endswith(".probe") or p.name == "MUJOCO_LOG.TXT":
            out.append(str(rel))
        elif changed and run.outcome == "internal" and "internal-error" in p.name:
            continue
        elif changed and not (run.outcome == "finished" and top in run.outputs):
            out.append(str(rel))
    return sorted(out)


def soak(n_valid: int, n_malformed: int, seed: int, workers: int, progress: bool) -> dict:
    """Draw, run and sort the command lines; the counts and the runs that were not clean."""
    rng = random.Random(seed)
    runs = [valid_run(rng) for _ in range(n_valid)] + [malformed_run(rng) for _ in range(n_malformed)]
    scratch = Path(tempfile.mkdtemp(prefix="euc-soak-"))
    pool = scratch / "pool"
    pool.mkdir()
    # numba's compiled kernels are a cache meant to outlive a run: one for the soak, out of TMPDIR
    env = {**os.environ, "NUMBA_CACHE_DIR": str(scratch / "numba"), "PYTHONWARNINGS": "default"}
    t0 = time.monotonic()
    try:
        make_pool(pool, env)
        done = []
        with ThreadPoolExecutor(max_workers=workers) as ex:
            for run in ex.map(lambda r: execute(r, pool, scratch, env), runs):
                done.append(run)
                if progress:
                    c = _counts(done)
                    sys.stderr.write(f"\rsoak: {len(done)}/{len(runs)} " + " ".join(
                        f"{k} {v}" for k, v in c["all"].items()) + " ")
                    sys.stderr.flush()
        if progress:
            sys.stderr.write("\n")
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    return {"seed": seed, "workers": workers, "valid": n_valid, "malformed": n_malformed,
            "seconds": round(time.monotonic() - t0, 1), "counts": _counts(done),
            "not_clean": [asdict(r) for r in done if r.outcome in ("internal", "crash") or r.leftovers
                          or (r.kind == "valid" and r.outcome != "finished")]}


def _counts(runs: list[Run]) -> dict:
    keys = ("finished", "refused", "internal", "crash")
    out = {}
    for kind in ("valid", "malformed", "all"):
        sel = [r for r in runs if kind == "all" or r.kind == kind]
        out[kind] = {k: sum(r.outcome == k for r in sel) for k in keys}
        out[kind]["leftovers"] = sum(bool(r.leftovers) for r in sel)
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--valid", type=int, default=60, help="valid command lines (default 60)")
    ap.add_argument("--malformed", type=int, default=60, help="malformed inputs (default 60)")
    ap.add_argument("--seed", type=int, default=0, help="seed of every draw (default 0)")
    ap.add_argument("--workers", type=int, default=2, help="runs at once (default 2)")
    ap.add_argument("--json", metavar="F", help="write the counts and the runs that were not clean")
    args = ap.parse_args(argv)
    res = soak(args.valid, args.malformed, args.seed, args.workers, progress=sys.stderr.isatty())
    for kind, c in res["counts"].items():
        print(f"{kind:<10}" + "  ".join(f"{k} {v}" for k, v in c.items()))
    for r in res["not_clean"]:
        print(f"NOT CLEAN [{r['kind']}] {r['outcome']}: euc-sim {' '.join(r['argv'])} {r['edit'] or ''}"
              f"\n    {r['last_line']}" + (f"\n    leftovers: {r['leftovers']}" if r["leftovers"] else ""))
    print(f"{res['valid']} valid + {res['malformed']} malformed runs in {res['seconds']:.0f} s "
          f"(seed {res['seed']}, {res['workers']} at once)")
    if args.json:
        Path(args.json).write_text(json.dumps(res, indent=2) + "\n")
    bad = res["counts"]["all"]
    return 0 if bad["internal"] == bad["crash"] == bad["leftovers"] == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
