"""Road to battery: the energy balance, the blind total mass, rotating inertia, PWM, grade, battery."""
