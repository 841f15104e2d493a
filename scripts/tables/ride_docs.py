"""Regenerate ``docs/ride/`` (the real rides' page linked from the README).

Usage (from the repository root, with ``../shared`` beside it)::

    python scripts/tables/ride_docs.py

Runs ``euc-sim ride`` on the two shared WheelLog rides (fit on the first, test on
the second) into ``docs/ride/``: ``index.md``, the figures and ``ride.json`` (which
names files relative to itself, no machine path); a file of ``docs/ride/`` the run does not
write is removed (``git rm`` it).  The CSV tables and ``index.html`` it also writes are not
tracked (``.gitignore``).  This is the only command that should write into
``docs/ride/``; try ``euc-sim ride`` yourself with ``--report runs/ride``.
"""

from __future__ import annotations

import json
import os
import sys
import tempfile
from pathlib import Path

from euc_sim.cli import main as euc_sim
from euc_sim.cli.common import MANIFEST
from euc_sim.io import write_json

ROOT = Path(__file__).resolve().parents[2]
SHARED = ROOT.parent / "shared" / "data" / "wheellog"
RIDES = ("2020_05_16_08_02_06.csv", "2020_05_28_07_52_00.csv")


def main() -> int:
    if not SHARED.is_dir():
        print(f"ride_docs: {SHARED} not found (the shared ride logs sit beside the repository)",
              file=sys.stderr)
        return 2
    out = ROOT / "docs" / "ride"
    # euc-sim writes a --report folder only when new or its own, and never a --json inside it:
    # the report goes to a new folder, then its files (and the JSON, which names them from
    # beside them) replace docs/ride's
    with tempfile.TemporaryDirectory(prefix=".ride-docs-", dir=out.parent) as tmp:
        stage = Path(tmp)
        code = euc_sim(["ride", str(SHARED / RIDES[0]), "--compare", str(SHARED / RIDES[1]),
                        "--report", str(stage / "ride"), "--json", str(stage / "ride.json"), "--simulate"])
        if code:
            return code
        rep = json.loads((stage / "ride.json").read_text(encoding="utf-8"))
        rep["report_dir"] = "."
        out.mkdir(exist_ok=True)
        written = {f.name for f in (stage / "ride").iterdir()} | {"ride.json"}
        for f in out.iterdir():         # a file the page no longer writes (a dropped figure) goes
            if f.is_file() and f.name not in written:
                f.unlink()
        for f in sorted((stage / "ride").iterdir()):
            if f.name != MANIFEST:
                os.replace(f, out / f.name)
        write_json(out / "ride.json", rep)
    return 0


if __name__ == "__main__":
    sys.exit(main())
