"""Many rides of one wheel: the battery over time, consumption by speed, the page."""
