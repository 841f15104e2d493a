"""Concealed firmware laws of the blind study, smoke size.

scripts/tables/blind_laws.py draws a law, rides it in closed loop, writes it as a real log
and identifies it blind from the CSV and its sidecar; the full study is
``scripts/tables/blind_study.py --laws N`` (docs/controller.md).  Here one short EUC World case:
the files are written without the truth beside the log, the law is read back in its
targets, and the scoring counts it.
"""

from __future__ import annotations

import json

import numpy as np

from blind_laws import law_outcome, law_work, plan_laws, score_laws


def test_plan_draws_laws_in_both_formats_reproducibly():
    a, b = plan_laws(3, 4, 60.0), plan_laws(3, 4, 60.0)
    assert a == b and [c["format"] for c in a] == ["eucworld", "wheellog"] * 2
    for c in a:
        assert 1500 <= c["law"]["Kp"] <= 5000 and 100 <= c["law"]["Kd"] <= 400
        assert 24 / 3.6 <= c["law"]["tiltback_speed"] <= 34 / 3.6 and c["sign"] in (-1, 1)


def test_one_concealed_eucworld_case_identified_blind(tmp_path):
    case = plan_laws(0, 1, 150.0)[0]
    assert case["format"] == "eucworld"
    rec = law_work((case, tmp_path, 0))
    assert "error" not in rec and rec["result"]["law"] is not None
    sidecar = json.loads((tmp_path / "law000.json").read_text())
    assert set(sidecar) == {"k_t"}                                   # no truth beside the log
    oc = law_outcome(rec)
    assert oc["sign_right"]
    assert abs(oc["kp_err"]) <= 0.15 and abs(oc["kd_err"]) <= 0.15
    assert oc["onset_err_kmh"] is not None and abs(oc["onset_err_kmh"]) <= 2.0
    s = score_laws([rec])["eucworld"]
    assert s["scored"] == 1 and s["all_within"] == 1.0 and np.isfinite(s["kp_err_worst"])
