"""Test-session setup: headless OpenGL for MuJoCo's offscreen renderer.

MuJoCo chooses its OpenGL backend when first imported; whichever test module imports
it first, EGL must already be chosen where there is no display (as ``euc_sim`` does).
"""

import os

if not os.environ.get("DISPLAY") and not os.environ.get("WAYLAND_DISPLAY"):
    os.environ.setdefault("MUJOCO_GL", "egl")

import sys
from pathlib import Path

# helpers shared by every test folder (figcheck) import by name
sys.path.append(str(Path(__file__).resolve().parent))
