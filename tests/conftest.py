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
