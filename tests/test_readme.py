"""The README is a guide: under 150 lines, every ``euc-sim`` command it shows runs, shortened,
and writes what it claims, and its Python snippet parses and uses only the public API.

Extraction rule (one rule, kept here):

* every line of a fenced code block (```...```) of README.md whose first word is
  ``euc-sim`` is a command (one command per line; a trailing ``\\`` joins the next line);
* every inline code span (`...`) starting with ``euc-sim `` inside a **table row** (a line
  starting with ``|``) is a command as well.

Inline code in prose (``euc-sim <cmd> --help``, ``euc-sim ride --wheel ... --json``) is
description, not a command, and is not extracted.

Each extracted command must be a key of ``SHORTENED``, the reviewed mapping from the README's
command to the one the test runs (shorter durations, fewer bootstrap replicates, no
re-simulation). A README command missing from the mapping fails the test, so the README cannot
drift away from what is run; a mapping entry the README no longer shows fails too.

The shortened commands run in the order of ``SHORTENED`` (a command that reads another's output
comes after it), as ``python -m euc_sim.cli ...`` in a subprocess with a temporary folder as
working directory. Each must exit 0, and every file it names with ``--out``, ``--json``,
``--out-dir`` (and ``--report DIR``: the files of :data:`REPORT_FILES`; ``simulate --out
NAME.csv``: ``NAME.json`` and ``NAME.truth.json``) must exist afterwards. ``../shared`` is
resolved relative to the repository root; commands reading it are skipped when it is absent
(their dependants too).
"""
from __future__ import annotations

import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
SHARED = ROOT.parent / "shared"

_WL = "../shared/data/wheellog/"

#: README command -> the command the test runs, in the order they run.
SHORTENED: dict[str, str] = {
    "euc-sim crosscheck --json runs/crosscheck.json":
        "euc-sim crosscheck --json runs/crosscheck.json",
    "euc-sim dynamics --q 0,0.05,0.1 --torques 20,10":
        "euc-sim dynamics --q 0,0.05,0.1 --torques 20,10",
    "euc-sim simulate --maneuver deceleration --duration 15 --seed 1 --out runs/decel.csv":
        "euc-sim simulate --maneuver deceleration --duration 8 --seed 1 --out runs/decel.csv",
    "euc-sim simulate --model 3d --maneuver figure_eight --duration 30 --seed 1 "
    "--out runs/figure_eight.csv":
        "euc-sim simulate --model 3d --maneuver figure_eight --duration 3 --seed 1 "
        "--out runs/figure_eight.csv",
    "euc-sim dataset --out-dir runs/dataset --seed 0 --workers 2":
        "euc-sim dataset --out-dir runs/dataset --seed 0 --workers 1 --duration 3 --quiet",
    "euc-sim design --maneuvers constant_speed,acceleration,deceleration,stop_and_go --rides 40 "
    "--duration 15 --json runs/design.json --report runs/design":
        "euc-sim design --maneuvers acceleration,stop_and_go --rides 4 --duration 6 "
        "--json runs/design.json --report runs/design --quiet",
    "euc-sim render runs/figure_eight.csv --out runs/ride.mp4":
        "euc-sim render runs/figure_eight.csv --out runs/ride.mp4 --fps 10 --width 160 "
        "--height 120 --quiet",
    "euc-sim stability --json runs/stability.json":
        "euc-sim stability --json runs/stability.json",
    "euc-sim torques runs/decel.csv --h 0.6 --out runs/torques.csv":
        "euc-sim torques runs/decel.csv --h 0.6 --out runs/torques.csv",
    "euc-sim identify runs/decel.csv --json runs/identify.json --report runs/identify":
        "euc-sim identify runs/decel.csv --json runs/identify.json --report runs/identify "
        "--n-boot 20 --noise-replicates 5",
    "euc-sim simulate --maneuver stop_and_go --duration 20 --seed 3 "
    "--effect aerodynamic_drag=0.3 --out runs/hidden.csv":
        "euc-sim simulate --maneuver stop_and_go --duration 10 --seed 3 "
        "--effect aerodynamic_drag=0.3 --out runs/hidden.csv",
    "euc-sim diagnose runs/hidden.csv --json runs/diagnose.json --report runs/diagnose":
        "euc-sim diagnose runs/hidden.csv --json runs/diagnose.json --report runs/diagnose "
        "--no-resimulate --quiet",
    "euc-sim demo --out-dir runs/demo":
        "euc-sim demo --out-dir runs/demo",
    f"euc-sim ride {_WL}2020_05_16_08_02_06.csv --compare {_WL}2020_05_28_07_52_00.csv "
    "--report runs/ride --json runs/ride.json":
        f"euc-sim ride {_WL}2020_05_16_08_02_06.csv --compare {_WL}2020_05_28_07_52_00.csv "
        "--report runs/ride --json runs/ride.json --n-boot 10 --no-simulate --quiet",
}

_FENCE = re.compile(r"^```")
_INLINE = re.compile(r"`(euc-sim [^`]+)`")


def readme_commands(text: str) -> list[str]:
    """The ``euc-sim`` commands of a README text, by the module's extraction rule."""
    commands: list[str] = []
    in_block = False
    pending = ""
    for line in text.splitlines():
        if _FENCE.match(line.strip()):
            in_block = not in_block
            pending = ""
            continue
        if in_block:
            stripped = (pending + " " + line.strip()).strip() if pending else line.strip()
            if stripped.endswith("\\"):
                pending = stripped[:-1].strip()
                continue
            pending = ""
            if stripped.split(" ", 1)[0] == "euc-sim":
                commands.append(" ".join(stripped.split()))
        elif line.lstrip().startswith("|"):
            commands.extend(" ".join(m.split()) for m in _INLINE.findall(line))
    return commands


#: What ``--report DIR`` writes into DIR, per command (the README says so).
REPORT_FILES = {"identify": ("identify.png", "identify-torques.png"),
                "design": ("design.png",), "diagnose": ("index.html", "index.md"), "ride": ("index.html", "index.md")}


def _written(argv: list[str]) -> list[str]:
    """The files a command claims to write: --out, --json, the folder of --out-dir and what
    --report DIR holds (:data:`REPORT_FILES`)."""
    out = []
    for flag, value in zip(argv, argv[1:]):
        if flag in ("--out", "--json", "--out-dir"):
            out.append(value)
        elif flag == "--report":
            out += [str(Path(value) / f) for f in REPORT_FILES[argv[0]]]
        if argv[0] == "simulate" and flag == "--out":      # the README: NAME.json, NAME.truth.json
            out += [str(Path(value).with_suffix(".json")),
                    str(Path(value).with_suffix(".truth.json"))]
    return out


def test_extraction_rule():
    text = ("x `euc-sim prose --no`\n| a | `euc-sim table --x 1` |\n```bash\n"
            "euc-sim a \\\n  --b 1\n# euc-sim comment\necho euc-sim\n```\n")
    assert readme_commands(text) == ["euc-sim table --x 1", "euc-sim a --b 1"]


#: The public API the README's Python snippet may use (``euc_sim/__init__.py`` exports them).
API = {"simulate", "write_recording", "read_recording", "identify", "diagnose", "read_ride",
       "analyse_ride", "render"}


def test_readme_is_short_and_links_only_existing_docs():
    text = README.read_text(encoding="utf-8")
    assert len(text.splitlines()) < 150
    links = re.findall(r"\]\((docs/[^)#]+)", text)
    assert len(links) >= 10
    missing = [link for link in links if not (ROOT / link).exists()]
    assert not missing, f"README links to missing files: {missing}"


def _python_blocks(text: str) -> list[str]:
    return re.findall(r"```python\n(.*?)```", text, flags=re.S)


def test_readme_python_uses_the_public_api():
    import ast

    blocks = _python_blocks(README.read_text(encoding="utf-8"))
    assert blocks, "the README shows the Python API"
    used = set()
    for block in blocks:
        for node in ast.walk(ast.parse(block)):        # it parses
            if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) \
                    and node.value.id == "euc_sim":
                used.add(node.attr)
    assert used and used <= API, sorted(used - API)
    import euc_sim

    if hasattr(euc_sim, "simulate"):                   # the API is there: every name the README uses
        assert all(callable(getattr(euc_sim, name)) for name in used)


def test_every_readme_command_is_mapped():
    shown = readme_commands(README.read_text(encoding="utf-8"))
    assert len(shown) >= 12
    missing = [c for c in shown if c not in SHORTENED]
    assert not missing, f"README commands without a shortened form in SHORTENED: {missing}"
    stale = [c for c in SHORTENED if c not in shown]
    assert not stale, f"SHORTENED entries the README no longer shows: {stale}"
    for full, short in SHORTENED.items():
        assert short.split()[:2] == full.split()[:2], (full, short)


def test_readme_commands_run(tmp_path):
    env = dict(os.environ, PYTHONPATH=str(ROOT), MUJOCO_GL=os.environ.get("MUJOCO_GL", "egl"))
    skipped: list[str] = []
    for full, short in SHORTENED.items():
        argv = shlex.split(short)[1:]
        if any(a.startswith("../shared") for a in argv) and not SHARED.is_dir():
            skipped.append(short)
            continue
        if any(a in _written(shlex.split(s)[1:]) for s in skipped for a in argv):
            skipped.append(short)      # reads the output of a skipped command
            continue
        argv = [str(SHARED / a[len("../shared/"):]) if a.startswith("../shared/") else a
                for a in argv]
        p = subprocess.run([sys.executable, "-m", "euc_sim.cli", *argv], cwd=tmp_path, env=env,
                           capture_output=True, text=True, timeout=300)
        assert p.returncode == 0, f"{short}\nexit {p.returncode}\n{p.stderr[-2000:]}"
        for f in _written(argv):
            assert (tmp_path / f).exists(), f"{short}: {f} was not written"
    if skipped:
        pytest.skip(f"../shared absent: skipped {len(skipped)} commands")
