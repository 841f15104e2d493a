"""h by ``mujoco.sysid`` (issue 22, item 3): the twin of test_rollout_fit, and the missing extra."""

from __future__ import annotations

import numpy as np
import pytest

from euc_sim.identification import sysid_fit
from euc_sim.identification.rollout_fit import RolloutError
from euc_sim.model.parameters import TABLE3
from idsim import H_TWIN, twin_recording


needs_extra = pytest.mark.skipif(not sysid_fit.sysid_available(),
                                 reason="the mujoco[sysid] extra is not installed")


@needs_extra
def test_twin_noise_free_recovers_h_from_a_wrong_start():
    df, kin = twin_recording("none")
    fit = sysid_fit.fit_sysid(df, kin, TABLE3, h0=0.45)
    assert fit.windows == 4
    assert fit.h == pytest.approx(H_TWIN, abs=1e-3)
    assert fit.h_ci95[0] <= fit.h <= fit.h_ci95[1] and not fit.at_bound
    assert fit.correlation.shape == (1 + 6 * 4, 1 + 6 * 4)
    assert np.allclose(np.diag(fit.correlation), 1.0)


@needs_extra
def test_twin_with_paper_noise_agrees_with_our_rollout():
    from euc_sim.identification.rollout_fit import fit_rollout

    df, kin = twin_recording("paper")
    fit = sysid_fit.fit_sysid(df, kin, TABLE3, h0=0.6)
    ours = fit_rollout(df, kin, TABLE3, h0=0.6)
    assert fit.h_ci95[0] <= H_TWIN <= fit.h_ci95[1]
    assert fit.h == pytest.approx(ours.h, abs=1e-4)            # the same problem, the same optimum
    w, w_ours = fit.h_ci95[1] - fit.h_ci95[0], ours.h_ci95[1] - ours.h_ci95[0]
    assert w == pytest.approx(w_ours, rel=0.05)                # t against normal quantile, same JᵀJ
    assert fit.rms[2] == pytest.approx(np.radians(0.5), rel=0.25)


@needs_extra
def test_bound_is_reported():
    df, kin = twin_recording("none")
    fit = sysid_fit.fit_sysid(df, kin, TABLE3, h0=0.45, bounds=(0.3, 0.5))
    assert fit.at_bound == ["h"] and fit.h == pytest.approx(0.5)


def test_needs_both_torques_or_the_extra():
    df, kin = twin_recording("none")
    msg = "M_h" if sysid_fit.sysid_available() else r"mujoco\[sysid\]"
    with pytest.raises(RolloutError, match=msg):
        sysid_fit.fit_sysid(df.drop(columns=["M_h"]), kin, TABLE3, h0=0.6)


def test_cli_without_the_extra_says_so_in_one_line(monkeypatch, capsys, tmp_path):
    from euc_sim.cli import main

    df, _ = twin_recording("none")
    path = tmp_path / "rec.csv"
    df.to_csv(path, index=False)
    monkeypatch.setattr(sysid_fit, "sysid_available", lambda: False)
    before = set(tmp_path.rglob("*"))
    assert main(["identify", str(path), "--method", "sysid"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "mujoco[sysid]" in err and "euc-sim[sysid]" in err, err
    assert set(tmp_path.rglob("*")) == before


@needs_extra
def test_cli_sysid_writes_its_entry_and_figure(tmp_path, capsys):
    import json

    from euc_sim.cli import main
    from euc_sim.io import write_recording

    df, _ = twin_recording("paper")
    good = write_recording(df, tmp_path / "twin.csv", {"params": {"m": TABLE3.m}})
    code = main(["identify", str(good), "--method", "sysid", "--n-boot", "20",
                 "--noise-replicates", "5", "--json", str(tmp_path / "o.json"),
                 "--report", str(tmp_path / "rep")])
    assert code == 0
    out = json.loads((tmp_path / "o.json").read_text())
    m = out["models"]["3dof"]
    assert "rollout" not in m and m["sysid"]["windows"] == 4
    assert m["sysid"]["h_ci95"][0] <= H_TWIN <= m["sysid"]["h_ci95"][1] and m["at_bound"] == []
    fig = tmp_path / "rep" / "identify-sysid.png"
    assert fig.is_file() and str(fig) in out["figures"]
    assert "mujoco.sysid h = " in capsys.readouterr().out


def test_a_really_missing_extra_is_detected(tmp_path):
    """mujoco.sysid swallows its missing dependencies; hide absl-py and plotly for real."""
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    code = ("import sys; sys.modules['absl'] = None; sys.modules['plotly'] = None\n"
            "from euc_sim.identification.sysid_fit import sysid_available\n"
            "print(sysid_available())")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=tmp_path,
                         env={"PYTHONPATH": str(root), "PATH": ""}, check=True)
    assert out.stdout.strip() == "False", out.stderr
