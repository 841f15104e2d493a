"""The public API (:mod:`euc_sim.api`): every docstring example runs, every function
returns its typed result, and ``to_json()`` gives CONTRACT's keys."""

from __future__ import annotations

import dataclasses
import doctest
import json
import subprocess
import sys

import pytest

import euc_sim
from euc_sim.api import functions, results

CONTRACT_DIAGNOSIS = {"recording", "nominal_rmse", "effects", "unexplained", "windows"}
CONTRACT_MODEL = {"h", "h_ci95", "rmse", "identifiable"}


@pytest.mark.parametrize("module", [functions, results], ids=lambda m: m.__name__)
def test_docstring_examples_run(module):
    failed, attempted = doctest.testmod(module, optionflags=doctest.ELLIPSIS)
    assert failed == 0
    assert attempted > 0 or module is results


def test_every_function_has_an_example():
    for name in functions.__all__:
        doc = getattr(functions, name).__doc__
        assert "Examples" in doc and ">>> " in doc, name


def test_help_lists_the_api():
    text = subprocess.run([sys.executable, "-c", "import euc_sim; help(euc_sim)"], capture_output=True,
                          text=True, check=True, env={"PAGER": "cat", "TERM": "dumb"}).stdout
    for name in ("simulate", "write_recording", "read_recording", "identify", "diagnose", "read_ride",
                 "analyse_ride", "render", "crosscheck", "Diagnosis", "RideAnalysis"):
        assert f"{name}(" in text or f"class {name}" in text, name


def test_import_does_not_load_the_heavy_packages():
    code = "import sys, euc_sim; print(sorted(m for m in ('mujoco', 'pandas', 'scipy', 'euc_sim.api') if m in sys.modules))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


@pytest.fixture(scope="module")
def braking(tmp_path_factory):
    rec = euc_sim.simulate("stop_and_go", duration=12.0, seed=3, effects={"road_slope": 0.05}, hide_torques=True)
    path = tmp_path_factory.mktemp("api") / "slope.csv"
    euc_sim.write_recording(rec, path)
    return rec, path


def test_results_are_frozen_dataclasses(braking):
    rec, path = braking
    assert isinstance(rec, euc_sim.Recording) and dataclasses.is_dataclass(rec)
    with pytest.raises(dataclasses.FrozenInstanceError):
        rec.name = "other"
    back = euc_sim.read_recording(path)
    assert back.truth is None and back.meta["maneuver"] == "stop_and_go"
    assert list(back.data.columns) == list(rec.data.columns)


def test_identify_gives_contract_models(braking):
    _, path = braking
    fit = euc_sim.identify([path], n_boot=60, n_noise=0)
    assert isinstance(fit, euc_sim.Identification)
    js = fit.to_json()
    json.dumps(js)
    assert js["recordings"] == [str(path)]
    for m in ("3dof", "2dof"):
        assert CONTRACT_MODEL <= set(js["models"][m])
        assert js["models"][m]["h"] == pytest.approx(fit.models[m].h)
    assert CONTRACT_MODEL <= set(js["per_recording"][0]["models"]["3dof"])


def test_diagnosis_json_is_the_pipelines_without_private_keys(braking):
    from euc_sim.diagnosis import pipeline

    _, path = braking
    d = euc_sim.diagnose(path, resimulate=False)
    raw = pipeline.diagnose(path, resimulate=False)
    js = d.to_json()
    assert isinstance(d, euc_sim.Diagnosis)
    assert CONTRACT_DIAGNOSIS <= set(js)
    assert not any(k.startswith("_") for k in js)
    from euc_sim.io import to_jsonable
    # the same object, key for key and in the same order, as the CLI writes
    assert json.dumps(js) == json.dumps(to_jsonable(pipeline.json_view(raw)))
    assert d.effects[0]["name"] == "road_slope"
    assert "residual_nominal" in d.series and "_series" in d.as_result()


def test_crosscheck_json_is_contracts():
    res = euc_sim.crosscheck(samples=5)
    js = res.to_json()
    assert set(js) == {"ok", "checks"} and js["ok"] is res.ok
    assert {"name", "value", "bound", "ok"} <= set(js["checks"][0])


def test_bad_input_names_the_parameter():
    with pytest.raises(ValueError, match="maneuver"):
        euc_sim.simulate("wheelie", duration=1.0)
    with pytest.raises(ValueError, match="h"):
        euc_sim.simulate("constant_speed", duration=1.0, params={"h": 50.0})
    with pytest.raises(ValueError, match="no recordings"):
        euc_sim.identify([])
