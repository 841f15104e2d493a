"""A ride log as the wheel wrote it: readers, measured channels, the maker's spec, sanity, systematics."""
