"""CalculiX eigenvalues checked against every copy the run wrote, and rigid modes told by their shape.

A frequency step writes each eigenvalue three times: the .dat's EIGENVALUE column, its frequency columns
(omega = sqrt(lambda) for lambda >= 0, else the imaginary part sqrt(-lambda); f = omega / 2 pi) and the
.frd's result-block header (f). One damaged digit in one copy is an error naming both places, never a
changed body.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..consistency import check_frequencies, check_mode_numbers
from ..errors import BodyFileError
from ..fe.modal import N_RIGID
from .calculix_deck import text_lines
from .rigid_modes import rigid_modes_of

TITLE = "E I G E N V A L U E   O U T P U T"
DAT_DIGITS = 7  # E14.7 columns of the .dat
FRD_DIGITS = 6  # the .frd header prints f with at least 6 significant digits (E12.5, or more for f >= 1000)
ZERO = 1e-6  # |lambda| / largest |lambda| below which a frequency is zero to a 7-digit print of the largest


def _row(path: Path, parts: list[str]) -> list[float]:
    try:
        values = [float(p) for p in parts[1:5]]
    except ValueError:
        raise BodyFileError(path, "EIGENVALUE OUTPUT", "numbers in E14.7 columns",
                            repr(" ".join(parts)[:60])) from None
    if len(values) < 4 or not np.all(np.isfinite(values)):
        raise BodyFileError(path, "EIGENVALUE OUTPUT", "a mode number and four finite numbers per row",
                            repr(" ".join(parts)[:60]))
    return values


def dat_table(path: Path) -> np.ndarray | None:
    """Rows (lambda, omega, f, imaginary omega) of the .dat's first eigenvalue table, or None; the mode
    numbers must count 1, 2, 3 ... and each row's frequency columns must be its eigenvalue's (to 7 digits):
    omega / 2 pi = f = sqrt(lambda) / 2 pi for lambda >= 0, the imaginary part sqrt(-lambda) else."""
    if not path.is_file():
        return None
    lines = list(text_lines(path))
    start = next((k for k, line in enumerate(lines) if TITLE in line), None)
    if start is None:
        return None
    rows, numbers = [], []
    for line in lines[start + 1:]:
        parts = line.split()
        if rows and not parts:
            break
        if parts and parts[0].isdigit():
            numbers.append(int(parts[0]))
            rows.append(_row(path, parts))
    check_mode_numbers(path, "EIGENVALUE OUTPUT mode numbers", numbers, first=1)
    table = np.array(rows).reshape(-1, 4)
    lam, omega, f, imag = table.T
    for column, values in (("FREQUENCY (RAD/TIME)", omega / (2 * np.pi)), ("FREQUENCY (CYCLES/TIME)", f),
                           ("IMAGINARY PART (RAD/TIME)", imag / (2 * np.pi))):  # -lambda for the imaginary part
        check_frequencies(path, (f"EIGENVALUE OUTPUT {column}", "its EIGENVALUE column"), values,
                          lam if column[0] == "F" else -lam, DAT_DIGITS)
    return table


def dat_eigenvalues(path: Path) -> np.ndarray | None:
    """The eigenvalue column of the .dat's table 'E I G E N V A L U E   O U T P U T', or None."""
    table = dat_table(path)
    return None if table is None else table[:, 0]


def eigenvalues(frd, modes: list[int], dat: Path) -> tuple[np.ndarray, str]:
    """Eigenvalues of ``modes`` with their source: the .dat's (7 digits) where it is beside the .frd, checked
    against the .frd's frequencies f = sqrt(max(lambda, 0)) / 2 pi to 6 digits; else the .frd's."""
    f_frd = np.array([frd.frequencies[m] for m in modes])
    table = dat_table(dat)
    if table is None:
        return _ascending(frd.path, (2 * np.pi * f_frd) ** 2, modes), "eigenvalues from .frd frequencies (6 digits)"
    if len(table) != max(modes):
        raise BodyFileError(dat, "eigenvalues", f"as many as the modes of {frd.path.name} ({max(modes)})",
                            f"{len(table)} (a cut .frd or another run's .dat)")
    lam = table[np.array(modes) - 1, 0]
    check_frequencies(frd.path, ("100C frequency", dat.name), f_frd, lam, FRD_DIGITS)
    return _ascending(dat, lam, modes), "eigenvalues from .dat (7 digits), checked against the .frd's frequencies"


def _ascending(path, lam: np.ndarray, modes: list[int]) -> np.ndarray:
    """CalculiX writes the eigenvalues in ascending order: one out of it (a damaged exponent) is an error."""
    floor = ZERO * np.abs(lam).max()  # zero frequencies (rigid modes) come in any order of their round-off
    down = np.flatnonzero(np.diff(lam) < -floor)
    if down.size:
        k = int(down[0])
        raise BodyFileError(path, "eigenvalues", "eigenvalues in ascending order, as CalculiX writes them",
                            f"mode {modes[k]}: {lam[k]:.7g} before mode {modes[k + 1]}: {lam[k + 1]:.7g}")
    return lam


def rigid_by_shape(points: np.ndarray, Phi: np.ndarray, lam: np.ndarray, modes: list[int], path,
                   free: bool = False) -> tuple:
    """Modes to drop (mask) and notes (io.rigid_modes): six rigid modes for a ``free`` run (its deck holds no
    support), any count with a warning otherwise."""
    support = "the deck holds no *BOUNDARY, spring, dashpot nor gap: a free body" if free else "the deck's supports"
    return rigid_modes_of(path, points, Phi, lam, N_RIGID if free else None, support, "DISP", modes)
