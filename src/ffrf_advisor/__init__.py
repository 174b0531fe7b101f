"""ffrf_advisor: which FFRF inertia terms a flexible body needs, and the proof."""
__version__ = "0.1.0"
