"""Simulation: maneuvers, the closed-loop engines, the effect catalog as physics, motion capture, datasets and loop stability."""
