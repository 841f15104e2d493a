"""What the energy-balance form lacks: two variants of it, measured like the 5 % rule table.

docs/ride_model.md ("Left, and tried") measures the branch's form: the |v| column
holds C_rr and any loss proportional to speed under a tyre's bound 0.05, and the selected
model predicts worse than the efficiency form's on 34 of 35 comparisons.  Two variants, set
here on the loaded modules only (the package is not changed):

``A``  the |v| column's bound 0.05 → 0.10: one parameter for C_rr + a loss ∝ speed (iron,
       bearings), which battery power cannot separate.  0.10 has no sourced reason: it
       measures how much such a loss would buy, it is not a proposed bound.
``B``  a loss ∝ the inertial power converted, λ·|m_eq·a·v|, λ ∈ [0, 0.5].

Usage::

    nice python studies/energy_form_variants.py A [--only LABEL,LABEL] [--json OUT.json]
"""

from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "scripts" / "tables"))
import balance_heldout as bh  # noqa: E402

import euc_sim.rides.balance.design as des  # noqa: E402
import euc_sim.rides.balance.fit as fit  # noqa: E402


def set_variant(variant: str) -> None:
    """Change the loaded balance model to ``variant`` (``A`` or ``B``; see the module doc)."""
    if variant == "A":
        des.BOUNDS["rolling_resistance"] = (0.0, 0.10)
        des.PLAUSIBLE["rolling_resistance"] = (0.005, 0.10, "1")
    elif variant == "B":
        des.CANDIDATES["conversion_loss"] = ("λ", "1", "loss ∝ |inertial power|", "conv", "W")
        des.BOUNDS["conversion_loss"] = (0.0, 0.5)
        des.PLAUSIBLE["conversion_loss"] = (0.0, 0.5, "1")
        fit._START["conversion_loss"] = 0.0
        orig = des._regressors

        def regressors(sig, L1, fraction):
            cols, cands, aliases, notes = orig(sig, L1, fraction)
            cols["conv"] = np.abs(cols["inertia"])
            return cols, cands + ["conversion_loss"], aliases, notes

        des._regressors = regressors
    else:
        raise SystemExit(f"variant must be A or B, got {variant!r}")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("variant")
    ap.add_argument("--only", default=None, help="comma-separated labels (default: all)")
    ap.add_argument("--json", default=None)
    a = ap.parse_args(argv)
    set_variant(a.variant)
    rows = []
    for case in bh.cases(pair_wheels=("v9",)):
        if a.only and case["label"] not in a.only.split(","):
            continue
        print(f"... {case['label']}", file=sys.stderr, flush=True)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                rows.append(bh.one(case, 10, 0))
            except ValueError as exc:
                rows.append({"label": case["label"], "error": str(exc).splitlines()[0][:120]})
    print(bh.table(rows))
    met = [r for r in rows if r.get("rule_met")]
    print(f"\nrule: {len(met)}/{sum('error' not in r for r in rows)} comparisons")
    if a.json:
        from euc_sim.io import write_json

        write_json(a.json, rows)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
