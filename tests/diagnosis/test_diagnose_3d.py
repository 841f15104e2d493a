"""``euc-sim diagnose`` on a 3-D recording with its default options, re-simulation included."""

import json
import math

from euc_sim.cli.app import main


def test_diagnose_3d_slalom_default_path_resimulates(tmp_path):
    rec = tmp_path / "slalom.csv"
    assert main(["simulate", "--model", "3d", "--maneuver", "slalom", "--duration", "8",
                 "--seed", "4", "--out", str(rec)]) == 0
    out = tmp_path / "slalom.diag.json"
    assert main(["diagnose", str(rec), "--json", str(out)]) == 0
    res = json.loads(out.read_text())
    assert "lateral_dynamics" in [e["name"] for e in res["effects"]]
    sim = res["resimulation"]
    assert sim["done"] is True and "lateral_dynamics" in sim["effects_injected"]
    for run in ("nominal", "augmented"):          # before and after, each a finished run
        assert "error" not in sim[run]
        assert all(math.isfinite(sim[run][k]) and sim[run][k] >= 0
                   for k in ("rmse_phi", "rmse_gamma", "rmse_speed"))
