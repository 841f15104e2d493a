"""Real rides: log readers, the longitudinal balance, the ride simulation and the ride page."""
