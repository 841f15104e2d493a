"""``euc-sim rides DIR_OR_FILES... --report DIR --json F``: many rides of one wheel (registered by
:func:`add_rides_parser`)."""

from __future__ import annotations

import argparse
import os
import stat
import sys
from pathlib import Path

from euc_sim.cli.common import check_report_folder, say, seed
from euc_sim.cli.options import bounded, workers
from euc_sim.errors import BadInputFile, InputError
from euc_sim.io import check_writable, file_kind, shown, write_json
from euc_sim.rides.request import BOUNDS
from euc_sim.rides.source.spec import wheel_spec

__all__ = ["add_rides_parser", "find_logs", "run_rides"]


def _is_log(path: Path) -> bool:
    """A CSV whose header a ride-log layout recognises."""
    from euc_sim.rides.source.logs import LogFormatError, detect_layout  # deferred: loads euc_sim.rides.source.bounds (0.01 s)

    try:
        with open(path, encoding="utf-8") as fh:
            header = [c.strip() for c in fh.readline().strip().split(",")]
        detect_layout(header, path)
        return True
    except (LogFormatError, OSError, UnicodeDecodeError):
        return False


def _regular(path: Path) -> Path:
    """``path`` if it is a regular file (a FIFO would hang the reader, a device be read without end)."""

    mode = os.stat(path).st_mode
    if not stat.S_ISREG(mode):
        raise BadInputFile(f"{shown(path)} is a {file_kind(mode)}, not a ride log (a regular file)")
    return path


def find_logs(items) -> list[Path]:
    """The log files named and the ride logs under each folder named (FileNotFoundError; InputError for a folder
    without logs or a special file)."""
    out: list[Path] = []
    for item in items:
        p = Path(item)
        if p.is_dir():
            found = [f for f in sorted(p.rglob("*.csv")) if not f.is_dir() and _is_log(_regular(f))]
            if not found:
                raise InputError(f"{p}: no ride log (WheelLog, EUC World, DarknessBot CSV) in this folder")
            out.extend(found)
        elif p.exists():
            out.append(_regular(p))
        else:
            raise FileNotFoundError(f"{p}: no such file or folder")
    return list(dict.fromkeys(out))


def _entry(job: tuple):
    """:func:`euc_sim.rides.logbook.history.ride_entry` of ``(path, pack, n_boot, seed)`` (picklable for the pool)."""
    from euc_sim.rides.logbook.history import ride_entry  # deferred: loads scipy (1.1 s)

    return ride_entry(*job)


def run_rides(paths, pack=None, n_boot: int = 100, seed: int = 0, workers: int = 1, say=None):
    """The :class:`euc_sim.rides.logbook.history.RideHistory` of the logs ``paths``."""
    from euc_sim.rides.logbook.history import ride_history  # deferred: loads scipy (1.1 s)

    jobs = [(p, pack, n_boot, seed) for p in paths]
    if workers > 1 and len(jobs) > 1:
        from concurrent.futures import ProcessPoolExecutor  # deferred: loads multiprocessing (0.02 s)

        with ProcessPoolExecutor(max_workers=min(workers, len(jobs))) as ex:
            entries = list(ex.map(_entry, jobs))
    else:
        entries = []
        for j in jobs:
            if say:
                say(f"rides: reading {j[0]}")
            entries.append(_entry(j))
    for e in entries:
        for line in e.repairs:          # each repair of the reader, one line, whatever --quiet
            sys.stderr.write(f"euc-sim rides: note: {Path(e.path).name}: {line}\n")
    return ride_history(entries)


def _cmd_rides(args: argparse.Namespace) -> int:
    pack = None
    if args.wheel:
        from euc_sim.rides.drive.battery import pack_spec  # deferred: loads euc_sim.rides.drive.battery (0.003 s), not loaded by --help

        pack = pack_spec(wheel_spec(args.wheel))
    paths = find_logs(args.logs)
    if args.json:
        check_writable(args.json)
    if args.report:
        check_report_folder(args.report, ("index.html",))
    hist = run_rides(paths, pack, args.n_boot, args.seed, args.workers, None if args.quiet else say)
    if args.report:
        from euc_sim.report.html import write_page  # deferred: loads plotly (0.05 s)
        from euc_sim.report.ride.history_page import history_page  # deferred: loads scipy, plotly (1.2 s)

        title = f"Rides of {pack.name}" if pack and pack.name else "Rides of one wheel"
        write_page(args.report, history_page(hist, title))
    if args.json:
        from euc_sim.report.ride.contract import history_json  # deferred: loads the balance fit (0.3 s)

        write_json(args.json, history_json(hist))
    from euc_sim.report.ride.terminal import history_lines  # deferred: loads pandas, scipy, plotly (1.5 s)

    for line in history_lines(hist, verdicts=pack is not None):
        print(line)
    return 0


def add_rides_parser(sub) -> None:
    """Register ``rides`` on the subparsers ``sub``."""
    p = sub.add_parser("rides", help="many ride logs of one wheel: battery resistance over time, Wh/km by speed")
    p.add_argument("logs", nargs="+", metavar="DIR_OR_FILE", help="ride logs, or folders searched for them")
    p.add_argument("--report", metavar="DIR", help="write DIR/index.html")
    p.add_argument("--json", metavar="F", help="write the rides' history as one JSON object")
    p.add_argument("--wheel", metavar="NAME|SPEC.csv",
                   help="the wheel: a shipped wheel's name (v9, lynx, ...) or a specification file "
                        "(battery architecture, cells): each ride's resistance against the pack's expected one")
    p.add_argument("--n-boot", type=bounded(*BOUNDS["n_boot"]), default=100, metavar="N",
                   help="bootstrap replicates of each resistance: the intervals are bootstrap percentiles "
                        "(default 100)")
    p.add_argument("--seed", type=seed, default=0, metavar="N", help="seed of every random draw (default 0)")
    p.add_argument("--workers", type=workers(), default=1, metavar="N", help="processes reading the logs (default 1)")
    p.add_argument("--quiet", action="store_true", help="no progress lines on stderr")
    p.set_defaults(func=_cmd_rides)
