"""Verification of advice by simulation: scenes, error measures, term-set comparison, stability, sweeps (theory section 10)."""
