"""euc-sim: longitudinal and pitch dynamics of an electric unicycle with a human rider.

The paper implemented is "Experimental Model Identification of the Longitudinal
Dynamics of an Electric Unicycle with a Human Rider"; equation numbers in the code
refer to it.  Signs and file formats follow CONTRACT.md.
"""

import os as _os

# Headless offscreen rendering (euc-sim render): MuJoCo picks its OpenGL backend when
# it is first imported; without a display, EGL is the one that works.
if not _os.environ.get("DISPLAY") and not _os.environ.get("WAYLAND_DISPLAY"):
    _os.environ.setdefault("MUJOCO_GL", "egl")

from euc_sim.model.parameters import Params, TABLE3  # noqa: E402

__all__ = ["Params", "TABLE3"]
__version__ = "0.1.0"
