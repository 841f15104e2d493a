"""The wheel's longitudinal balance of a ride: design, bounded fit, held-out selection, verdict."""
