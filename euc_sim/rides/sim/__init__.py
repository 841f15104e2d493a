"""The closed loop along a real ride's speed: tracking, the learned plan, steps, reading, figure."""
