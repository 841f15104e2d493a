"""The ``euc-sim`` command line.

Each subcommand is a ``_cmd_NAME(args) -> int`` registered in :func:`build_parser`.  Bad
input (:class:`euc_sim.errors.InputError`, an argparse error, an ``OSError`` about a path)
is one line naming the culprit and exit 2; any other exception is a bug: one line with
where its traceback was written, exit 1.  Outputs are written atomically and checked
before anything runs (:func:`euc_sim.cli.common.check_outputs`).
"""

from __future__ import annotations

import argparse
import os
import signal
import sys
import threading
import warnings
from typing import Sequence

import numpy as np

from euc_sim import __version__, api
from euc_sim.cli.common import (EXIT_FAIL, EXIT_OK, EXIT_USAGE, UsageError, check_outputs, internal_error_report,
                                 parse_params, record_outputs, say)
from euc_sim.cli.design import add_commands as add_design_commands
from euc_sim.cli.diagnose import add_commands as add_diagnose_commands
from euc_sim.cli.identify import add_identify_parser, add_torques_parser
from euc_sim.cli.options import BoundsHelpFormatter, bounded
from euc_sim.cli.ride import add_ride_parser
from euc_sim.cli.rides import add_rides_parser
from euc_sim.cli.sim import add_commands as add_sim_commands
from euc_sim.cli.spatial import add_render_parser
from euc_sim.errors import InputError
from euc_sim.io import check_writable, write_json
from euc_sim.model import analytic
from euc_sim.model.mujoco_model import EucMujoco, load_model


class OneLineParser(argparse.ArgumentParser):
    """argparse with its errors on one line and a pointer to ``--help`` (not the whole usage),
    and every bounded option's range in ``--help``."""

    def __init__(self, *args, **kwargs):
        kwargs.setdefault("formatter_class", BoundsHelpFormatter)
        super().__init__(*args, **kwargs)

    def error(self, message: str):
        first = message.splitlines()[0] if message else "invalid arguments"
        self.exit(EXIT_USAGE, f"{self.prog}: error: {first} (see {self.prog} --help)\n")


# --- crosscheck ---------------------------------------------------------------------
def _cmd_crosscheck(args: argparse.Namespace) -> int:
    if args.json:
        check_writable(args.json)
    if args.mjcf is not None:
        load_model(mjcf=args.mjcf)          # fail early on a bad file
    res = api.crosscheck(args.samples, params=parse_params(args.param) if args.param else None, mjcf=args.mjcf,
                         progress=lambda s: say(f"crosscheck: {s} ..."))
    width = max(len(c.name) for c in res.checks)
    print(f"{'check':<{width}}  {'worst':>10}  {'bound':>8}  ok")
    for c in res.checks:
        print(f"{c.name:<{width}}  {c.value:10.2e}  {c.bound:8.0e}  {'yes' if c.ok else 'NO'}")
        if c.detail:
            print(f"{'':<{width}}    {c.detail}")
    print("all bounds hold" if res.ok else "BOUND BROKEN: see the rows marked NO")
    if args.json:
        write_json(args.json, res.to_json())
    return EXIT_OK if res.ok else EXIT_FAIL


# --- dynamics --------------------------------------------------------------------------
def _parse_vector(text: str, n: int, option: str):
    parts = [s for s in text.replace(";", ",").split(",") if s.strip()]
    if len(parts) != n:
        raise UsageError(f"{option} expects {n} comma-separated numbers, got {text!r}")
    try:
        v = np.array([float(s) for s in parts])
    except ValueError:
        raise UsageError(f"{option} expects numbers, got {text!r}") from None
    if not np.all(np.isfinite(v)):
        raise UsageError(f"{option} must be finite, got {text!r}")
    return v


def _cmd_dynamics(args: argparse.Namespace) -> int:
    p = parse_params(args.param)
    q = _parse_vector(args.q, 3, "--q (x, gamma, phi)")
    qd = _parse_vector(args.qd, 3, "--qd (x_d, gamma_d, phi_d)")
    M_d, M_h = _parse_vector(args.torques, 2, "--torques (M_d, M_h)")
    qdd = analytic.forward_dynamics(p, q, qd, M_d, M_h)
    sim = EucMujoco(p, "ideal", args.mjcf)
    gen = sim.inverse(q, qd, qdd)
    out = {
        "q": q, "qd": qd, "M_d": M_d, "M_h": M_h,
        "qdd_analytic": qdd,
        "generalized_force_mujoco_inverse": gen,
        "generalized_force_eq8": analytic.inverse_dynamics(p, q, qd, qdd),
        "M_d1": float(analytic.driving_torque_1(p, q, qd, qdd)),
        "M_d2": float(analytic.driving_torque_2(p, q, qd, qdd)),
        "M_h_row3": float(analytic.rider_torque(p, q, qd, qdd)),
    }
    np.set_printoptions(precision=6, suppress=False)
    print(f"q̈ = (ẍ, γ̈, φ̈) = {qdd} (m/s², rad/s², rad/s²)")
    print(f"mj_inverse, mapped: {gen}   eq. (8): {out['generalized_force_eq8']}")
    print(f"M_d,1 = {out['M_d1']:.9g} N·m, M_d,2 = {out['M_d2']:.9g} N·m, M_h = {out['M_h_row3']:.9g} N·m")
    if args.json:
        write_json(args.json, out)
    return EXIT_OK


def build_parser() -> argparse.ArgumentParser:
    parser = OneLineParser(
        prog="euc-sim",
        description="Electric-unicycle-with-rider simulation, identification and diagnosis.",
        epilog="Outputs are written atomically, never over an input, a device or a FIFO; a symbolic "
               "link is written through to its target, whose mode is kept. A --report DIR (demo's "
               "--out-dir) must be new, empty or hold only what euc-sim wrote there "
               "(listed in DIR/.euc-sim-manifest.json).")
    parser.add_argument("--version", action="version", version=f"euc-sim {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)

    p = sub.add_parser("crosscheck", help="prove the MuJoCo model against the analytic equations")
    p.add_argument("--json", metavar="FILE", help="write the figures and bounds as JSON")
    p.add_argument("--samples", type=bounded(1, 100_000, integer=True), default=2500, metavar="N",
                   help="random states per parameter set (4 sets; default 2500; memory and time "
                        "grow with it)")
    p.add_argument("--param", action="append", metavar="NAME=VALUE",
                   help="check one user parameter set instead of the built-in four")
    p.add_argument("--mjcf", metavar="FILE", help="MJCF file (default mjcf/euc_planar.xml)")
    p.set_defaults(func=_cmd_crosscheck)

    p = sub.add_parser("dynamics", help="evaluate both models at one state: accelerations and torques")
    p.add_argument("--q", required=True, metavar="X,GAMMA,PHI", help="m, rad, rad")
    p.add_argument("--qd", default="0,0,0", metavar="XD,GD,PD", help="m/s, rad/s, rad/s")
    p.add_argument("--torques", default="0,0", metavar="M_D,M_H", help="N·m")
    p.add_argument("--param", action="append", metavar="NAME=VALUE", help="override a Table 3 value")
    p.add_argument("--mjcf", metavar="FILE", help="MJCF file (default mjcf/euc_planar.xml)")
    p.add_argument("--json", metavar="FILE", help="write the figures as JSON")
    p.set_defaults(func=_cmd_dynamics)

    add_sim_commands(sub)
    add_torques_parser(sub)
    add_identify_parser(sub)
    add_diagnose_commands(sub)
    add_ride_parser(sub)
    add_rides_parser(sub)
    add_render_parser(sub)
    add_design_commands(sub)
    return parser


#: Exit code when the reader of stdout went away: 128 + SIGPIPE, what a shell reports
#: for ``cat`` in ``cat big | head -1``.
EXIT_BROKEN_PIPE = 141


def _one_line_warning(message, category, filename, lineno, line=None) -> str:
    return f"euc-sim: warning: {message}\n"


def _terminated(signum, frame):
    """SIGTERM handled like Ctrl-C: unwinds, so temporary files and workers are cleaned up."""
    raise KeyboardInterrupt("SIGTERM")


def _first_line(exc: BaseException) -> str:
    text = str(exc).strip()
    return text.splitlines()[0] if text else type(exc).__name__


def _os_message(exc: OSError) -> str:
    """One line naming the path: ``cannot write out.csv: File too large`` rather than ``[Errno 27] ...``."""
    text = _first_line(exc)
    if exc.filename is None:
        return text
    reason = exc.strerror or text
    names = f"{exc.filename}" + (f" -> {exc.filename2}" if exc.filename2 else "")
    return reason if str(exc.filename) in reason else f"{names}: {reason}"


def _internal_error(args, exc: BaseException) -> int:
    where = internal_error_report(args, exc)
    tail = f"; the traceback is in {where}" if where else "; no file could take the traceback"
    print(f"euc-sim {args.command}: internal error: {type(exc).__name__}: {_first_line(exc)}{tail}",
          file=sys.stderr)
    return EXIT_FAIL


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of ``euc-sim``; returns the exit code (130 on Ctrl-C, 143 on SIGTERM)."""
    parser = build_parser()
    args = parser.parse_args(argv)
    previous = warnings.formatwarning
    warnings.formatwarning = _one_line_warning     # for people: no source paths
    on_term = None
    if threading.current_thread() is threading.main_thread():
        on_term = signal.signal(signal.SIGTERM, _terminated)
    folders = []
    try:
        folders = check_outputs(args)
        return int(args.func(args))
    except BrokenPipeError:             # the reader left (| head): stop quietly, as cat does
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())    # no second error when Python flushes stdout
        return EXIT_BROKEN_PIPE
    except InputError as exc:
        print(f"euc-sim {args.command}: error: {_first_line(exc)}", file=sys.stderr)
        return EXIT_USAGE
    except OSError as exc:             # the user's file system: a path that cannot be read or written
        print(f"euc-sim {args.command}: error: {_os_message(exc)}", file=sys.stderr)
        return EXIT_USAGE
    except KeyboardInterrupt as exc:
        term = str(exc) in ("SIGTERM", f"signal {int(signal.SIGTERM)}")   # ours, simulation.runner's
        print(f"euc-sim {args.command}: interrupted{' (SIGTERM)' if term else ''}", file=sys.stderr)
        return 143 if term else 130
    except Exception as exc:           # anything else is euc-sim's own fault
        return _internal_error(args, exc)
    finally:
        record_outputs(folders)
        warnings.formatwarning = previous
        if on_term is not None:
            signal.signal(signal.SIGTERM, on_term)


if __name__ == "__main__":
    sys.exit(main())
