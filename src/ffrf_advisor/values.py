"""The one rule for a number read from outside (config files, body files' keys and attributes): a real
number, never a boolean, a string or a nested object (``"I1": true`` is not a mass of 1)."""
from __future__ import annotations

import math
import numbers


def is_number(value, integer: bool = False) -> bool:
    """``value`` is a finite real number (a whole one with ``integer``): Python's or numpy's, not a bool."""
    if isinstance(value, bool) or type(value).__name__ == "bool_" or not isinstance(value, numbers.Real):
        return False
    if integer:
        return isinstance(value, numbers.Integral)
    return math.isfinite(value)
