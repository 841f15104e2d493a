"""A ride read once, on its grids: signals, battery power, the law's rows, speed profile, stops, bands."""
