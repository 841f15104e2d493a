"""``euc-sim simulate --model 3d`` and ``euc-sim render``: the spatial model on the command line."""

from __future__ import annotations

import argparse
import math
from pathlib import Path

from euc_sim import api
from euc_sim.cli.common import parse_params, say
from euc_sim.cli.options import bounded
from euc_sim.errors import InputError
from euc_sim.simulation.lateral import LATERAL_WINDOW, min_duration
from euc_sim.simulation.spatial import PATHS, write_spatial

__all__ = ["simulate_3d_command", "add_render_parser"]


def simulate_3d_command(args: argparse.Namespace, motor) -> int:
    """The ``--model 3d`` branch of ``euc-sim simulate``: ``--maneuver`` names a path."""
    name = args.maneuver or "figure_eight"
    if args.profile or name not in PATHS:
        raise InputError(f"--model 3d: --maneuver must be one of {', '.join(PATHS)}, got "
                         f"{args.profile and '--profile' or repr(name)}")
    for option, value, default in (("--engine", args.engine, "mujoco"), ("--variant", args.variant, "ideal"),
                                   ("--rolling-model", args.rolling_model, "moment")):
        if value != default:
            raise InputError(f"--model 3d has its own contact model: {option} {value!r} does not apply")
    if args.effect:
        raise InputError("--model 3d: --effect is not supported (the 3-D physics has no catalog effects)")
    shortest = min_duration()
    if float(args.duration) < shortest - 1e-9:
        raise InputError(f"--duration: the 3-D model needs at least {shortest:g} s (its tilt is read over "
                         f"two {LATERAL_WINDOW:g} s windows), got {args.duration:g}")
    path = write_spatial(Path(args.out), name, float(args.duration), params=parse_params(args.param),
                         seed=int(args.seed), noise=args.noise, rider_noise=args.rider_noise,
                         motor=motor, rider_delay=args.rider_delay, hide_torques=bool(args.hide_torques))
    say(f"simulate: wrote {path} ({name}, 3-D model, {args.duration:g} s, seed {args.seed})")
    return 0


def _cmd_render(args: argparse.Namespace) -> int:
    out = Path(args.out)
    if out.suffix.lower() not in (".mp4", ".gif", ".png"):
        raise InputError(f"--out must end in .mp4, .gif or .png, got {str(out)!r}")
    if not (math.isfinite(args.fps) and 1 <= args.fps <= 120):
        raise InputError(f"--fps must be in [1, 120], got {args.fps!r}")
    n = api.render(args.recording, out, fps=args.fps, width=args.width, height=args.height,
                   time=args.time, progress=not args.quiet).frames
    say(f"render: wrote {out} ({n} frame{'s' if n != 1 else ''})")
    return 0


def add_render_parser(sub) -> None:
    """Register ``euc-sim render REC --out ride.mp4|ride.gif|frame.png``."""
    p = sub.add_parser("render", help="replay a recording in the 3-D model (offscreen MuJoCo renderer)")
    p.add_argument("recording", metavar="REC.csv", help="a recording with psi, theta, gamma and C (or E) columns")
    p.add_argument("--out", required=True, metavar="ride.mp4", help=".mp4, .gif or .png (one frame)")

    p.add_argument("--fps", type=bounded(1.0, 240.0, unit="Hz"), default=30.0, metavar="HZ",
                   help="frames per second of the video (default 30)")
    p.add_argument("--width", type=bounded(16, 7680, integer=True, unit="px"), default=640, metavar="PX",
                   help="pixels (default 640)")
    p.add_argument("--height", type=bounded(16, 4320, integer=True, unit="px"), default=480, metavar="PX",
                   help="pixels (default 480)")
    p.add_argument("--time", type=bounded(0.0, 86_400.0, unit="s"), default=None, metavar="S",
                   help="with .png: the time of the frame, s (default: middle)")
    p.add_argument("--quiet", action="store_true", help="no progress bar (shown on stderr by default)")
    p.set_defaults(func=_cmd_render)
