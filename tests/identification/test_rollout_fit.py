"""h by the simulation error of MuJoCo rollouts (issue 22): a twin experiment with known h."""

from __future__ import annotations

import numpy as np
import pytest

from euc_sim.identification.rollout_fit import RolloutError, fit_rollout
from euc_sim.model.parameters import TABLE3
from idsim import H_TWIN, twin_recording


def test_twin_noise_free_recovers_h_from_a_wrong_start():
    df, kin = twin_recording("none")
    fit = fit_rollout(df, kin, TABLE3, h0=0.45)
    assert fit.windows == 4
    assert fit.h == pytest.approx(H_TWIN, abs=1e-3)
    assert fit.h_ci95[0] <= fit.h <= fit.h_ci95[1] and not fit.at_bound
    assert fit.correlation.shape == (1 + 6 * 4, 1 + 6 * 4)
    assert np.allclose(np.diag(fit.correlation), 1.0)


def test_twin_with_paper_noise_interval_holds_h():
    df, kin = twin_recording("paper")
    fit = fit_rollout(df, kin, TABLE3, h0=0.6)
    assert fit.h_ci95[0] <= H_TWIN <= fit.h_ci95[1]
    assert fit.h_ci95[1] - fit.h_ci95[0] < 0.05
    assert fit.rms[2] == pytest.approx(np.radians(0.5), rel=0.25)     # the residual is the noise


def test_bound_is_reported():
    df, kin = twin_recording("none")
    fit = fit_rollout(df, kin, TABLE3, h0=0.45, bounds=(0.3, 0.5))
    assert fit.at_bound == ["h"] and fit.h == pytest.approx(0.5)


def test_needs_both_torques():
    df, kin = twin_recording("none")
    with pytest.raises(RolloutError, match="M_h"):
        fit_rollout(df.drop(columns=["M_h"]), kin, TABLE3, h0=0.6)


def test_cli_rollout(tmp_path, capsys):
    import json

    from euc_sim.cli import main
    from euc_sim.io import write_recording

    df, _ = twin_recording("paper")
    good = write_recording(df, tmp_path / "twin.csv", {"params": {"m": TABLE3.m}})
    code = main(["identify", str(good), "--method", "rollout", "--n-boot", "60",
                 "--noise-replicates", "10", "--json", str(tmp_path / "o.json")])
    assert code == 0
    m = json.loads((tmp_path / "o.json").read_text())["models"]["3dof"]
    r = m["rollout"]
    assert set(r) >= {"h", "h_ci95", "seconds", "windows", "at_bound"} and r["windows"] == 4
    assert r["h_ci95"][0] <= H_TWIN <= r["h_ci95"][1] and m["at_bound"] == []
    bad = write_recording(df.drop(columns=["M_h"]), tmp_path / "no_mh.csv", {})
    capsys.readouterr()
    assert main(["identify", str(bad), "--method", "rollout"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "no_mh.csv" in err and "M_h" in err
