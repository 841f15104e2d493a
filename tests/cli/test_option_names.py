"""One option name per idea across every command; old names deprecated; choices shown in --help.

Every subcommand's argparse parser is read (nothing runs): within a group of synonyms only
the canonical name may appear, old names only as :class:`euc_sim.cli.options.DeprecatedOption`
(hidden from ``--help``, a one-line note on stderr); every option with a fixed set of values
shows all of them in its ``--help`` line, and no string option hides behind a bare
placeholder such as ``NOISE``.
"""

from __future__ import annotations

import argparse
import re

import pytest

from euc_sim.cli import main
from euc_sim.cli.app import build_parser
from euc_sim.cli.options import DeprecatedOption

#: Synonym groups: (canonical names, other names for the same idea).
SYNONYMS = [
    ({"workers"}, {"jobs", "threads", "processes", "procs"}),
    ({"quiet"}, {"no-progress", "silent"}),
    ({"n-boot"}, {"bootstrap", "boot"}),
    ({"report"}, {"plot", "figure", "fig"}),
    ({"effect"}, {"effects"}),
    ({"out", "out-dir"}, {"output", "outdir", "output-dir"}),
]

#: Placeholders for a value that is not one of a fixed set (a number, a path, a pair).
FREE_FORM = re.compile(r"^([A-Z][A-Z_]*|[A-Z]+=[A-Z]+|[A-Za-z_]*\.[a-z0-9]+|[A-Z·/]+m?|N·m|M/S)$")


def _commands() -> dict[str, argparse.ArgumentParser]:
    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    return dict(sub.choices)


def _options():
    for command, parser in _commands().items():
        for action in parser._actions:
            for opt in action.option_strings:
                if opt.startswith("--"):
                    yield command, parser, action, opt[2:]


def _names(name: str, words: set[str]) -> bool:
    return any(name == w or name.startswith(w + "-") or name.endswith("-" + w) for w in words)


def test_one_name_per_idea():
    wrong = []
    for command, _, action, name in _options():
        for canonical, others in SYNONYMS:
            if _names(name, canonical) or not _names(name, others):
                continue
            if not isinstance(action, DeprecatedOption):
                wrong.append(f"{command} --{name} (use --{sorted(canonical)[0]})")
    assert not wrong, "options that name an idea differently: " + ", ".join(wrong)


def test_out_is_a_file_and_out_dir_a_folder():
    for command, _, action, name in _options():
        if isinstance(action, DeprecatedOption):
            continue
        if name == "out":
            assert action.metavar not in (None, "DIR"), (command, action.metavar)
        if name in ("out-dir", "report"):
            assert action.metavar == "DIR", (command, name, action.metavar)


def test_deprecated_names_are_hidden_and_name_their_replacement():
    seen = set()
    for command, parser, action, name in _options():
        if not isinstance(action, DeprecatedOption):
            continue
        seen.add(name)
        assert action.help == argparse.SUPPRESS, (command, name)
        assert action.replacement.split()[0] in parser._option_string_actions, (command, name)
        assert f"--{name} " not in parser.format_help(), (command, name)
    assert {"no-progress", "out"} <= seen


def _help_line(parser: argparse.ArgumentParser, action: argparse.Action) -> str:
    formatter = parser._get_formatter()
    formatter.add_argument(action)
    return " ".join(formatter.format_help().split())


def _fixed_values() -> dict[tuple[str, str], tuple[str, ...]]:
    """The options whose values come from a fixed set, with the set (from the package)."""
    from euc_sim.identification.design import DESIGN_MANEUVERS
    from euc_sim.model.mujoco_model import VARIANTS
    from euc_sim.simulation.effects import names as effect_names
    from euc_sim.simulation.engine import ENGINES
    from euc_sim.simulation.maneuvers import MANEUVERS
    from euc_sim.simulation.mocap import NOISE_LEVELS
    from euc_sim.simulation.spatial import PATHS

    return {("simulate", "maneuver"): tuple(MANEUVERS) + tuple(PATHS),
            ("simulate", "model"): ("planar", "3d"),
            ("simulate", "noise"): tuple(NOISE_LEVELS), ("dataset", "noise"): tuple(NOISE_LEVELS),
            ("simulate", "engine"): ENGINES, ("dataset", "engine"): ENGINES,
            ("simulate", "variant"): VARIANTS,
            ("simulate", "rolling-model"): ("moment", "contact"),
            ("dataset", "format"): ("csv", "parquet"),
            ("ride", "domain"): ("power", "torque"),
            ("design", "maneuvers"): tuple(DESIGN_MANEUVERS),
            ("design", "effect"): ("all",) + effect_names(),
            ("simulate", "effect"): effect_names(), ("dataset", "effect"): effect_names()}


def test_fixed_values_are_shown_in_help():
    fixed = _fixed_values()
    checked = set()
    for command, parser, action, name in _options():
        if action.help == argparse.SUPPRESS:
            continue
        values = action.choices or fixed.get((command, name))
        if values is None:
            continue
        checked.add((command, name))
        line = _help_line(parser, action)
        missing = [v for v in values if v not in line]
        assert not missing, f"{command} --{name}: --help does not show {missing}: {line}"
    assert set(fixed) <= checked


def test_no_bare_placeholder_for_a_string_option():
    """A string option shows its choices or a placeholder of a free-form value (FILE, DIR, N)."""
    for command, parser, action, name in _options():
        if action.nargs == 0 or action.help == argparse.SUPPRESS or action.choices:
            continue
        if action.type is None:
            assert action.metavar is not None, f"{command} --{name} shows --{name} {name.upper()}"
        if action.metavar is not None and not action.metavar.startswith("{"):
            assert FREE_FORM.match(action.metavar) or "," in action.metavar or "|" in action.metavar \
                or "[" in action.metavar, (command, name, action.metavar)


@pytest.mark.parametrize("old, argv, dest, value", [
    ("--no-progress", ["dataset", "--out-dir", "D", "--no-progress"], "quiet", True),
    ("--out", ["dataset", "--out", "D"], "out_dir", "D"),
])
def test_old_names_still_work_with_one_line_note(old, argv, dest, value, capsys):
    args = build_parser().parse_args(argv)
    assert getattr(args, dest) == value
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and err[0].startswith(f"euc-sim: {old} is deprecated; "), err


def test_dataset_needs_a_folder_and_takes_one_name_for_it(capsys):
    with pytest.raises(SystemExit):
        build_parser().parse_args(["dataset"])
    assert "--out-dir" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        build_parser().parse_args(["dataset", "--out-dir", "A", "--out", "B"])
    assert "not allowed with" in capsys.readouterr().err
