"""The rider's numbers of a ride: distance, time, speed, energy, battery, clock, mass check."""
