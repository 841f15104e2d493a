"""euc-sim: longitudinal and pitch dynamics of an electric unicycle with a human rider.

The paper implemented is "Experimental Model Identification of the Longitudinal
Dynamics of an Electric Unicycle with a Human Rider"; equation numbers in the code
refer to it.  Signs and file formats follow CONTRACT.md.

The API (each returns a typed result with ``to_json()``)::

    rec = euc_sim.simulate("deceleration", duration=15, seed=1)   # -> Recording
    euc_sim.write_recording(rec, "brake.csv")                      # CSV + sidecar
    fit = euc_sim.identify(["brake.csv"])                          # -> Identification (h, m)
    found = euc_sim.diagnose("brake.csv")                          # -> Diagnosis
    ride = euc_sim.analyse_ride("wheellog.csv")                    # -> RideAnalysis

``read_recording``, ``read_ride``, ``render`` and ``crosscheck`` complete it; every
function's docstring has a short example.
"""

import os as _os

# Headless offscreen rendering (euc-sim render): MuJoCo picks its OpenGL backend when
# it is first imported; without a display, EGL is the one that works.
if not _os.environ.get("DISPLAY") and not _os.environ.get("WAYLAND_DISPLAY"):
    _os.environ.setdefault("MUJOCO_GL", "egl")

from euc_sim.model.parameters import Params, TABLE3  # noqa: E402

#: The API's names, imported from :mod:`euc_sim.api` on first use (``import euc_sim`` stays fast).
_API = ("simulate", "write_recording", "read_recording", "identify", "diagnose", "read_ride",
        "analyse_ride", "render", "crosscheck", "Recording", "Identification", "Diagnosis", "Ride",
        "RideAnalysis", "Rendering", "Crosscheck")

__all__ = [*_API, "Params", "TABLE3"]
__version__ = "0.1.0"


def __getattr__(name: str):
    if name in _API:
        from euc_sim import api  # deferred: loads numpy, pandas (0.6 s); `import euc_sim` takes 0.03 s

        return getattr(api, name)
    raise AttributeError(f"module 'euc_sim' has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(_API))
