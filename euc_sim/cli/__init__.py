"""The ``euc-sim`` command line: one module per command group, shared helpers in :mod:`euc_sim.cli.common`."""

from euc_sim.cli.app import main

__all__ = ["main"]
