"""Reduced-order FFRF simulator: right-hand sides for any term set of the catalogue, integrators (theory sections 5, 10)."""
