"""Scripts that print measured numbers; run each from the repository root as ``python -m benchmarks.NAME`` (some import ``tests``)."""
