"""Real rides, one subpackage per idea, layered (docs/architecture.md#rides-by-idea); the pipeline on top."""
