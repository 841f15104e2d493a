"""``.gitignore`` covers what the README's example commands write in the repository root
(issue 19, item 14), and hides no file the repository tracks."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

#: Files the README's and docs' commands write when run in the repository root.
WRITTEN = ["crosscheck.json", "out.json", "id.json", "figure_eight.csv", "figure_eight.json",
           "figure_eight.truth.json", "circle.csv", "slalom.truth.json", "eight.csv",
           "straight3d.csv", "decel.csv", "rmse.png", "rmse-torques.png", "rmse-torques-circle.png",
           "ride.mp4", "ride.gif", "runs/decel.csv", "runs/ride/index.md", "euc-sim-demo/index.md",
           "blind/t00.csv", "bs/summary.json", "bs1000/summary.json", "b7/t00.csv", "roc/s7/t00.csv",
           "fs/t00.csv", "v9.json", "fast.csv"]


def _git(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(["git", *args], cwd=ROOT, capture_output=True, text=True)


@pytest.fixture(scope="module")
def in_git():
    if shutil.which("git") is None or _git("rev-parse", "--is-inside-work-tree").stdout.strip() != "true":
        pytest.skip("not a git checkout")


def test_what_readme_commands_write_is_ignored(in_git):
    proc = _git("check-ignore", "--no-index", *WRITTEN)
    ignored = set(proc.stdout.split())
    assert ignored == set(WRITTEN), sorted(set(WRITTEN) - ignored)


def test_no_tracked_file_is_ignored(in_git):
    assert _git("ls-files", "--cached", "--ignored", "--exclude-standard").stdout.split() == []


def test_sources_and_figures_are_not_ignored(in_git):
    kept = ["euc_sim/rides/source/ride.py", "tests/rides/ridesynth.py", "docs/figures/figure_eight_3d.png",
            "docs/figures/design.png", "scripts/tables/blind_study.py", "mjcf/euc_3d.xml"]
    assert _git("check-ignore", "--no-index", *kept).stdout.split() == []
