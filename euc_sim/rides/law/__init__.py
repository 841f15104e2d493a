"""The wheel's own balance law, read from pitch and motor torque, and its report."""
