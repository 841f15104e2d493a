"""euc-sim: longitudinal and pitch dynamics of an electric unicycle with a human rider.

The paper implemented is "Experimental Model Identification of the Longitudinal
Dynamics of an Electric Unicycle with a Human Rider"; equation numbers in the code
refer to it.  Signs and file formats follow CONTRACT.md.
"""

from euc_sim.model.parameters import Params, TABLE3

__all__ = ["Params", "TABLE3"]
__version__ = "0.1.0"
