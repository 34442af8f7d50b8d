"""Solving a step: Newton's method on the incremental potential, and its linear systems (the
block-tree Cholesky, and the coupled solve where bodies touch each other)."""
