"""The ride tests' shared helpers (ridesynth, drivesynth, layoutsynth, summarysynth) import by
name from every subfolder of tests/rides/."""

import sys
from pathlib import Path

sys.path.append(str(Path(__file__).resolve().parent))
