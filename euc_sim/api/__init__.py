"""The public API of euc-sim: the functions a script calls and the typed results they return.

Each function returns a frozen dataclass with ``to_json()`` giving the JSON object the
matching ``euc-sim`` command writes (CONTRACT.md).  ``import euc_sim`` re-exports all
of them; the command line parses its arguments and calls these.
"""

from euc_sim.api.functions import (analyse_ride, crosscheck, diagnose, identify, read_recording, read_ride,
                                   render, simulate, write_recording)
from euc_sim.api.results import (Crosscheck, CrosscheckRow, Diagnosis, Identification, Recording, Rendering,
                                 RideAnalysis)
from euc_sim.rides.source.ride import Ride

__all__ = ["simulate", "write_recording", "read_recording", "identify", "diagnose", "read_ride",
           "analyse_ride", "render", "crosscheck",
           "Recording", "Identification", "Diagnosis", "Ride", "RideAnalysis", "Rendering", "Crosscheck",
           "CrosscheckRow"]
