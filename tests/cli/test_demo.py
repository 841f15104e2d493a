"""`euc-sim demo`, the README's main job, end to end on its embedded defaults."""

import json

from euc_sim.cli import main
def test_demo_writes_its_pages_and_finds_the_concealed_effect(tmp_path, capsys):
    out = tmp_path / "demo"
    assert main(["demo", "--out-dir", str(out)]) == 0
    index = (out / "index.md").read_text()
    assert "h identified with both models" in index and "the paper, measured" in index
    assert (out / "identification.png").stat().st_size > 10_000
    assert len(list((out / "recordings").glob("*.csv"))) == 14
    truth = json.loads((out / "concealed" / "concealed.truth.json").read_text())
    found = json.loads((out / "concealed" / "diagnosis.json").read_text())
    (name, t), = truth["effects"].items()
    assert found["effects"] and found["effects"][0]["name"] == name
    estimate = found["effects"][0]["estimate"]
    assert abs(estimate - t["value"]) < 0.25 * abs(t["value"])
    assert (out / "concealed" / "report" / "index.md").exists()
    assert "demo" in capsys.readouterr().err          # progress was shown


def test_the_seed_draws_the_concealed_effect_too():
    import numpy as np

    from euc_sim.cli.demo import CONCEALABLE, draw_concealed_effect
    drawn = {draw_concealed_effect(np.random.default_rng([s, 5]))[0] for s in range(1, 9)}
    assert drawn == set(CONCEALABLE)
    assert draw_concealed_effect(np.random.default_rng([3, 5])) == \
        draw_concealed_effect(np.random.default_rng([3, 5]))
