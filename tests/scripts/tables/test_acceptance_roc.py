"""scripts/tables/acceptance_roc.py: which first-step candidate a different acceptance rule would judge."""

from __future__ import annotations

import sys

import acceptance_roc as roc


def _history(reason: str, accepted: bool, chosen: str) -> list[dict]:
    trials = [{"name": "cog_height_drift", "bic": 2.0, "t": 3.1, "cv_gain": 0.27},
              {"name": "lateral_dynamics", "bic": 14.0, "t": 1.3, "cv_gain": 0.01},
              {"name": "road_slope", "bic": 15.0}]
    return [{"trials": [{"name": None, "bic": 12.0}]},
            {"trials": trials, "chosen": chosen, "accepted": accepted, "reason": reason}]


def test_a_trial_refused_only_by_the_thresholds_is_the_one_judged():
    h = _history("cog_height_drift: |θ|/se 3.1 < 4 | lateral_dynamics: BIC drop -2.0 < 10; "
                 "held-out RMSE gain 1.0% < 8%; |θ|/se 1.3 < 4", False, "lateral_dynamics")
    fs = roc.first_step(h)
    assert fs["name"] == "cog_height_drift" and fs["bic_drop"] == 10.0 and not fs["accepted"]
    assert roc.passes(fs, 10.0, 3.0, 0.05) and not roc.passes(fs, 10.0, 4.0, 0.05)


def test_a_trial_refused_on_physics_is_skipped():
    h = _history("cog_height_drift: |θ|/se 3.1 < 4; h drift 1.13 m peak to peak is beyond physical range "
                 "(> 0.6 m) | lateral_dynamics: BIC drop -2.0 < 10", False, "lateral_dynamics")
    fs = roc.first_step(h)
    assert fs["name"] == "lateral_dynamics" and fs["bic_drop"] == -2.0


def test_an_accepted_trial_after_a_physics_refusal():
    h = _history("accepted (refused before it: cog_height_drift: estimate has the wrong sign for this physics)",
                 True, "lateral_dynamics")
    fs = roc.first_step(h)
    assert fs["name"] == "lateral_dynamics" and fs["accepted"]
    assert roc.first_step(h[:1])["name"] is None


def test_a_missing_folder_is_one_line_and_exit_2(tmp_path, capsys):
    assert roc.main(["--nulls", str(tmp_path / "nowhere")]) == 2
    assert "nowhere: no such folder" in capsys.readouterr().err
    assert roc.main(["--nulls", str(tmp_path)]) == 2       # a folder with nothing diagnosed in it
