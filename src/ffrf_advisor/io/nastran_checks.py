"""A Nastran SOL 103 run's redundant numbers and its rigid modes (issue 49): the mode ids of the eigenvector and
eigenvalue (LAMA) tables, the eigenvalues both carry, and the rigid modes told by their shape, their count
against the run's SPC and SUPORT cards. ``rigid_modes_of`` serves the ANSYS reader too.

The shape test is CalculiX's (calculix_modes.RIGID_SHAPE), but a zero frequency is fe.modal.rigid_eigenvalues'
(|lambda| below 1e-10 of the largest, or f below 0.01 Hz), not 1e-6 of the largest: a Nastran or MAPDL run may
span more than three decades of frequency (all 42 modes of the test's clamped frame do), and its lowest bending
modes are not zero.
"""
from __future__ import annotations

import numpy as np

from ..consistency import check_frequencies, check_mode_numbers
from ..errors import BodyFileError
from ..fe.modal import N_RIGID, rigid_eigenvalues, rigid_modes
from .calculix_modes import RIGID_SHAPE
from .nastran_modes import NastranModes

OP2_DIGITS = 7  # the OP2 holds eigenvalues in float32 (24-bit mantissa: 7 significant digits)


def check_tables(path, ev, table) -> None:
    """Mode ids of the eigenvectors (and of the LAMA table, if there is one) count 1, 2, 3 ...; the eigenvalues
    of the vectors' headers and the LAMA table, and the LAMA's RADIANS / 2 pi and CYCLES, agree to float32
    (compared as f = sqrt(|lambda|) / 2 pi: a rigid mode's round-off has either sign)."""
    check_mode_numbers(path, "eigenvector mode ids", np.asarray(ev.modes).ravel(), first=1)
    if table is None:
        return
    check_mode_numbers(path, "eigenvalue table (LAMA) mode ids", np.asarray(table.mode).ravel(), first=1)
    lama = np.abs(np.asarray(table.eigenvalues, float))
    check_frequencies(path, ("eigenvalue table (LAMA)", "the eigenvectors' headers"),
                      np.sqrt(lama) / (2 * np.pi), np.abs(np.asarray(ev.eigns, float)), OP2_DIGITS)
    for column, f in (("RADIANS", np.asarray(table.radians, float) / (2 * np.pi)),
                      ("CYCLES", np.asarray(table.cycles, float))):  # Nastran's of sqrt(|lambda|), as its own files
        check_frequencies(path, (f"eigenvalue table (LAMA) {column}", "its EIGENVALUE column"), f, lama, OP2_DIGITS)


def constraints(m) -> tuple[int | None, str]:
    """The rigid-mode count the model's constraints give and their description: six without SPC (SPC, SPC1,
    SPCADD or a grid's PS), the DOFs of its SUPORT / SUPORT1 cards with them, None (not known) with SPC alone."""
    spc = bool(m.spcs or m.spcadds or any(getattr(g, "ps", "") for g in m.nodes.values()))
    suport = [*m.suport, *m.suport1.values()]
    dofs = sum(len(str(c)) for card in suport for c in card.Cs)
    if not spc:
        return N_RIGID, "no SPC, SPC1, SPCADD nor grid PS in the model: a free run"
    if suport:
        return dofs, f"SPC with SUPORT on {dofs} DOFs"
    return None, "SPC in the model"


def rigid(path, run: NastranModes) -> tuple[np.ndarray, list[str]]:
    """Which modes of ``run`` are rigid and notes naming them (``rigid_modes_of`` with its constraints)."""
    return rigid_modes_of(path, run.points, run.T, run.eigenvalues, run.rigid_expected, run.constraints)


def rigid_modes_of(path, points: np.ndarray, T: np.ndarray, lam: np.ndarray, expected: int | None,
                   constraints: str, field: str = "DISP") -> tuple[np.ndarray, list[str]]:
    """Which modes are rigid and notes naming them. A mode is rigid when its translations T (n, 3, nm) lie in the
    span of the six rigid motions of the nodes (theory 4: the part outside below RIGID_SHAPE), never by its
    eigenvalue alone; a rigid shape with a frequency, a zero frequency of a shape that is not rigid (a mechanism)
    and a count other than ``expected`` (the constraints') are errors naming ``field`` (the modes' record in the
    format's words); a count other than six a warning."""
    R = rigid_modes((points - points.mean(axis=0)) / max(float(np.ptp(points, axis=0).max()), 1e-300))
    S = T.reshape(-1, T.shape[2])
    outside = np.linalg.norm(S - R @ np.linalg.lstsq(R, S, rcond=None)[0], axis=0) \
        / np.maximum(np.linalg.norm(S, axis=0), 1e-300)
    shape, zero = outside < RIGID_SHAPE, rigid_eigenvalues(lam)
    for bad, expects in ((shape & ~zero, "a zero frequency for a rigid-body shape"),
                         (zero & ~shape, "a rigid-body shape at zero frequency (not a mechanism)")):
        if bad.any():
            k = int(np.argmax(bad))
            raise BodyFileError(path, field, expects, f"mode {k + 1}: eigenvalue {lam[k]:.7g}, part of its shape "
                                f"outside the rigid motions {outside[k]:.2g} (the shape or eigenvalue is damaged)")
    count, named = int(shape.sum()), ", ".join(str(k + 1) for k in np.flatnonzero(shape)) or "none"
    if expected is not None and count != expected:
        raise BodyFileError(path, field, f"{expected} rigid modes ({constraints})", f"{count} (modes {named}): a "
                            "rigid mode's shape or eigenvalue is damaged, or the run did not select those constraints")
    notes = [f"rigid modes (shapes spanned by rigid motions) dropped: {named} ({constraints})"]
    if count != N_RIGID:
        notes.append(f"warning: {count} rigid modes instead of six (modes {named}): the run is "
                     + ("constrained" if count < N_RIGID else "not connected (a mechanism)"))
    return shape, notes
