"""docs/effects.md: the effect catalog's reference, written from its records.

One row per record of :data:`euc_sim.model.catalog.CATALOG` (the records live in
:mod:`euc_sim.simulation.effects`): its CONTRACT name, symbol and unit, where the
simulator applies it and the values an injection may take, its term in a ride's energy
balance with the plausible range and that range's source, how a log conceals it, whether
two rides' difference in it can be named, and the page's words.  Nothing in the page is
written by hand: `tests/scripts/tables/test_effect_catalog.py` fails when the records and
the page disagree.

Usage::

    python scripts/tables/effect_catalog.py [--out docs/effects.md]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

DOC = Path(__file__).resolve().parents[2] / "docs" / "effects.md"


def _num(x: float) -> str:
    return f"{x:g}"


def _range(r, unit: str) -> str:
    return f"{_num(r[0])} … {_num(r[1])}" + ("" if unit in ("1", "") else f" {unit}")


def _cell(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ")


def rows() -> list[str]:
    """The table's Markdown rows, one per record, in the catalog's order."""
    import euc_sim.simulation.effects  # noqa: F401  (registers the package's records)
    from euc_sim.model.catalog import CATALOG

    out = ["| effect | symbol, unit | simulator: applied as, values | ride balance: term, plausible (source) "
           "| concealed in a log as | difference between rides | page |",
           "|---|---|---|---|---|---|---|"]
    for e in CATALOG:
        sim = f"{e.kind}, {_range(e.bounds, e.unit)}" if e.kind is not None else "–"
        b = e.balance
        bal = "–" if b is None else (f"{b.meaning} ({b.symbol}, {b.unit}); {_range(b.plausible, b.unit)} "
                                      f"({b.source})")
        con = "–" if e.conceal is None else f"{e.conceal.mechanism.replace('_', ' ')} ({e.conceal.unit})"
        c = e.compare
        cmp_ = "–" if c is None else ("named" if c.named else "a nuisance, never named") + (
            " (a ratio)" if c.ratio else "")
        words = "–" if e.words is None else e.words.label
        out.append("| " + " | ".join(_cell(s) for s in (
            f"`{e.name}`", f"{e.symbol}, {e.unit}", sim, bal, con, cmp_, words)) + " |")
    return out


def page() -> str:
    """The whole of docs/effects.md."""
    return "\n".join([
        "# The effect catalog",
        "",
        "Every physical effect the package knows is one record (`euc_sim/model/catalog.py`, the",
        "records in `euc_sim/simulation/effects.py`); the simulator, the diagnosis, the ride balance,",
        "the concealed logs, the comparison of two rides and the pages read it. This page is written",
        "from the records by `python scripts/tables/effect_catalog.py`; how to add one: the",
        "catalog module's docstring, \"Adding an effect\".",
        "",
        *rows(),
        "",
        "Simulator kinds: `external` acts on the EUC–rider system from outside, `internal` between",
        "its bodies, `parameter` through a model parameter, `measurement` on the recording. A",
        "difference \"named\" is tested between two rides and said on the page when the test names it",
        "([concealed.md](concealed.md)); a nuisance is fitted and never named.",
        "",
    ])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=DOC, help=f"the page to write (default {DOC})")
    args = ap.parse_args(argv)
    from euc_sim.io import atomic_write

    atomic_write(args.out, lambda tmp: Path(tmp).write_text(page()))
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
