"""The simulated rider calibrated on a ride log: settings, response surface, fit and its step."""
