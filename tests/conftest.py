"""Test-session setup: headless OpenGL for MuJoCo's offscreen renderer.

MuJoCo chooses its OpenGL backend when first imported; whichever test module imports
it first, EGL must already be chosen where there is no display (as ``euc_sim`` does).
"""

import os

if not os.environ.get("DISPLAY") and not os.environ.get("WAYLAND_DISPLAY"):
    os.environ.setdefault("MUJOCO_GL", "egl")

import sys
from pathlib import Path

# helpers shared by every test folder (figcheck) import by name, and so do the modules of the
# table scripts and studies the tests check (blind_study, soak, band_halves, ...)
ROOT = Path(__file__).resolve().parents[1]
sys.path += [str(ROOT / "tests"), str(ROOT / "scripts"), str(ROOT / "scripts" / "tables"), str(ROOT / "studies")]


import pytest  # noqa: E402


def _ride_result(tmp, compare: bool):
    import warnings

    from ridesynth import synth_log

    from euc_sim.rides.pipeline import ride_pipeline
    from euc_sim.rides.request import ride_request

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        other = synth_log(tmp / "other.csv", seed=4) if compare else None
        return ride_pipeline(ride_request(synth_log(tmp / "fit.csv", seed=3), other, n_boot=10, simulate=False))


@pytest.fixture(scope="session")
def ride_result(tmp_path_factory):
    """The typed result of ``euc-sim ride`` on a synthetic log (:class:`~euc_sim.rides.result.RideResult`):
    the renderers' tests replace its parts."""
    return _ride_result(tmp_path_factory.mktemp("ride"), False)


@pytest.fixture(scope="session")
def compared_result(tmp_path_factory):
    """The same with a second synthetic ride compared (differences, the compared ride's numbers)."""
    return _ride_result(tmp_path_factory.mktemp("compared"), True)
