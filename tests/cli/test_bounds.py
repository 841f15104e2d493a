"""Every numeric option and every ride-log channel has a bound, checked before any work.

Bad values give exit 2 and one line naming the option (or the file and column) and the
bound; ``--help`` states each option's range.  Repairs of a log (merged stamps, re-sorted
rows, a dropped line, dropped out-of-range cells) are each one line on stderr.
"""

from __future__ import annotations

import argparse
import re

import pytest

from euc_sim.cli import main
from euc_sim.cli.app import build_parser
from euc_sim.cli.options import DeprecatedOption


def _commands() -> dict[str, argparse.ArgumentParser]:
    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    return dict(sub.choices)


def _numeric_options():
    from euc_sim.cli.common import seed

    for command, parser in _commands().items():
        for action in parser._actions:
            if isinstance(action, DeprecatedOption) or action.type in (None, str, seed):
                continue
            yield command, parser, action


def test_every_numeric_option_is_bounded_and_says_its_range_in_help():
    unbounded, unsaid = [], []
    for command, parser, action in _numeric_options():
        span = getattr(action.type, "span", None)
        if span is None:
            unbounded.append(f"{command} {action.option_strings[0]}")
            continue
        formatter = parser._get_formatter()
        formatter.add_argument(action)
        if span not in " ".join(formatter.format_help().split()):
            unsaid.append(f"{command} {action.option_strings[0]}")
    assert not unbounded, "numeric options without a bound: " + ", ".join(unbounded)
    assert not unsaid, "bounded options whose --help hides the range: " + ", ".join(unsaid)


def _refused(argv, pattern, capsys) -> str:
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and re.search(pattern, err[0]), err
    return err[0]


@pytest.mark.parametrize("argv, pattern", [
    (["simulate", "--out", "o.csv", "--duration", "1e300"], r"--duration: .*\[0\.1, 3600\] s, got 1e300"),
    (["simulate", "--out", "o.csv", "--duration", "1e6"], r"--duration: .*\[0\.1, 3600\] s"),
    (["simulate", "--out", "o.csv", "--duration", "1e-9"], r"--duration: .*\[0\.1, 3600\] s"),
    (["simulate", "--out", "o.csv", "--rider-noise", "1e300"], r"--rider-noise: .*\[0, 100\] N·m"),
    (["crosscheck", "--samples", "100000000"], r"--samples: .*\[1, 100000\]"),
    (["stability", "--kp", "1e300"], r"--kp: .*\[0, 100000\] N·m/rad"),
    (["design", "--rides", "100000000"], r"--rides: .*\[3, 10000\]"),
    (["dataset", "--out-dir", "d", "--workers", "1000"], r"--workers: .*\[1, \d+\] \(this machine's cores\)"),
    (["ride", "x.csv", "--mass", "1e300"], r"--mass: .*\[35, 350\] kg"),
    (["render", "r.csv", "--out", "r.png", "--width", "100000"], r"--width: .*\[16, 7680\] px"),
])
def test_option_out_of_bounds_is_refused_naming_the_bound(argv, pattern, capsys):
    _refused(argv, pattern, capsys)


@pytest.mark.parametrize("argv, pattern", [
    (["--effect", "sensor_time_offset=1e6"], r"effect sensor_time_offset: expected a value in \[-0\.3, 0\.3\] s, got 1e6"),
    (["--effect", "cog_height_drift=10"], r"effect cog_height_drift: expected a value in \[-0\.6, 0\.6\] m, got 10"),
    (["--effect", "cog_height_drift=0.6", "--param", "h=0.3", "--duration", "12"],
     r"cog_height_drift=0\.6 m takes h from 0\.3 m down to .*; h must stay at least 0\.05 m"),
])
def test_effect_size_out_of_its_bound_is_refused(argv, pattern, tmp_path, capsys):
    out = tmp_path / "o.csv"
    assert main(["simulate", "--out", str(out), "--duration", "1", *argv]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and re.search(pattern, err[0]), err
    assert not out.exists()


def test_effect_bounds_are_in_help():
    from euc_sim.simulation.effects import CATALOG

    text = " ".join(_commands()["simulate"].format_help().split())
    for e in CATALOG.values():
        assert f"{e.name} [{e.bounds[0]:g}, {e.bounds[1]:g}]" in text
        assert e.bounds[0] <= e.plausible[0] <= e.plausible[1] <= e.bounds[1], e.name
