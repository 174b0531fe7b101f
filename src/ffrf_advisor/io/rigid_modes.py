"""Rigid modes of a modal run told by their shape, for every reader (theory 4; issue 49).

A mode is rigid when its translations lie in the span of the six rigid motions of the nodes (the part outside
below RIGID_SHAPE), never by its eigenvalue alone. Its eigenvalue must then be zero, and a mode whose shape is not
rigid must not be: "zero" is below ZERO_SHARE of the median eigenvalue of the run's flexible shapes, a scale of the
run itself. A share of the largest eigenvalue would call the lowest bending mode of a run that spans three decades
of frequency zero (1e-6 of the largest is 1e-3 of its frequency); the median stays near the body's own frequencies,
and one damaged eigenvalue does not move it.
"""
from __future__ import annotations

import numpy as np

from ..errors import BodyFileError
from ..fe.modal import N_RIGID, rigid_modes

RIGID_SHAPE = 1e-3  # part outside the rigid motions: 1.3e-6 for CalculiX's rigid modes at 6 digits, 2.6e-8 in binary,
# float32 OP2 and .rst about 1e-7; flexible modes 0.94-1
ZERO_SHARE = 1e-8  # of the median flexible eigenvalue: a frequency 1e-4 of the median flexible frequency; a rigid
# mode's round-off is far below it (7 printed digits of the largest: 1e-7 of it, squared in frequency)


def outside_rigid(points: np.ndarray, T: np.ndarray) -> np.ndarray:
    """Per mode, the relative part of its translations T (n, 3, nm) outside the span of the rigid motions."""
    R = rigid_modes((points - points.mean(axis=0)) / max(float(np.ptp(points, axis=0).max()), 1e-300))
    S = T.reshape(-1, T.shape[2])
    return np.linalg.norm(S - R @ np.linalg.lstsq(R, S, rcond=None)[0], axis=0) \
        / np.maximum(np.linalg.norm(S, axis=0), 1e-300)


def rigid_modes_of(path, points: np.ndarray, T: np.ndarray, lam: np.ndarray, expected: int | None,
                   constraints: str, field: str = "DISP", numbers=None) -> tuple[np.ndarray, list[str]]:
    """Which modes are rigid and notes naming them: a rigid shape with a frequency, a zero frequency of a shape
    that is not rigid (a mechanism) and a count other than ``expected`` (the run's constraints) are errors naming
    ``field`` (the modes' record in the format's words) and the mode (``numbers``: the file's, else 1, 2, ...); a
    count other than six is a warning."""
    numbers = list(range(1, len(lam) + 1)) if numbers is None else list(numbers)
    outside = outside_rigid(points, T)
    shape = outside < RIGID_SHAPE
    lam = np.abs(np.asarray(lam, float))
    scale = float(np.median(lam[~shape])) if (~shape).any() else 0.0
    zero = lam <= ZERO_SHARE * scale
    for bad, expects in ((shape & ~zero, "a zero frequency for a rigid-body shape"),
                         (zero & ~shape, "a rigid-body shape at zero frequency (not a mechanism)")):
        if bad.any():
            k = int(np.argmax(bad))
            raise BodyFileError(path, field, expects, f"mode {numbers[k]}: eigenvalue {lam[k]:.7g} (the flexible "
                                f"modes' median {scale:.7g}), part of its shape outside the rigid motions "
                                f"{outside[k]:.2g} (the shape or eigenvalue is damaged, or parts are not connected)")
    count = int(shape.sum())
    named = ", ".join(str(numbers[k]) for k in np.flatnonzero(shape)) or "none"
    if expected is not None and count != expected:
        raise BodyFileError(path, field, f"{expected} rigid modes ({constraints})", f"{count} (modes {named}): a "
                            "rigid mode's shape or eigenvalue is damaged, or the run did not select those constraints")
    notes = [f"rigid modes (shapes spanned by rigid motions) dropped: {named} ({constraints})"]
    if count != N_RIGID:
        notes.append(f"warning: {count} rigid modes instead of six (modes {named}): the run is "
                     + ("constrained" if count < N_RIGID else "not connected (a mechanism)"))
    return shape, notes
