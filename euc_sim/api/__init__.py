"""The public API of euc-sim: functions a script calls and the typed results they return.

Each result's ``to_json()`` gives the JSON object the matching ``euc-sim`` command writes (CONTRACT.md).
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
