"""ffrf_advisor: which FFRF inertia terms a flexible body needs, and the proof."""
__version__ = "0.1.0"


def version_line() -> str:
    """What ``ffrf-advisor --version`` prints."""
    return f"ffrf-advisor {__version__}"
