"""A parsed Nastran SOL 103 run (the data the Nastran modules share, below them all)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class NastranModes:
    """A parsed SOL 103 run, in basic coordinates, before any requirement on it."""

    grids: np.ndarray        # (n,) grid ids
    points: np.ndarray       # (n, 3)
    eigenvalues: np.ndarray  # (nm,)
    generalized_mass: np.ndarray  # (nm,)
    T: np.ndarray            # (n, 3, nm) translations
    R: np.ndarray            # (n, 3, nm) rotations
    sigma_max: np.ndarray | None  # (nm,) the largest of stress_nodal
    element_types: dict[str, int]
    stress_nodal: np.ndarray | None = None  # (n, nm) von Mises averaged at the grids
    rigid_expected: int | None = None  # rigid modes the run's constraints give (None: not known)
    constraints: str = "constraints not known"
