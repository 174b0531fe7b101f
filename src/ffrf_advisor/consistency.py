"""Cross-checks of a body's redundant numbers and the bounds they must meet (issue 49, parts 1-2), on every read
with FE data: ``checked(body, path)``; readers call it, or the pieces for what only they see (mode numbers, two
copies of the frequencies). A disagreement beyond the source's precision is a one-line error naming both places.
"""
from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from .body import FlexibleBody
from .errors import BodyFileError
from .stress_bound import peak_stress

STORED = 1e-5     # Rayleigh quotients with a stored K: ARPACK's modes match to 2e-9, the toolkit's to 4e-7
ASSEMBLED = 0.5   # with K assembled from the material: another code's element (incompatible modes, reduced
# integration) may stiffen a coarse mesh's bending by tens of %; measured 8e-4 on the shipped plate, 3e-7 on
# CalculiX C3D20. The damage (eigenvalues x0.25) gives 3.
STRESS_SPREAD = 3.0  # file / recomputed peak stress: 1 +- 3e-5 for CalculiX C3D20 (6 digits), 1 +- 1e-10 for
# the toolkit's own; other codes extrapolate from integration points to nodes (reduced integration): generous


def precision(digits: int | None, floor: float) -> float:
    """Relative agreement two copies of a number with ``digits`` significant digits must reach: 10^(2 - digits)
    (one unit in the last place of each, and a sum of them), at least ``floor``."""
    return floor if digits is None else max(floor, 10.0 ** (2 - digits))


def check_eigenvalues(body: FlexibleBody, path, assemble: bool = True) -> None:
    """Stored eigenvalues against the Rayleigh quotients of the modes with the stored or (``assemble``) assembled K
    (theory 2): the stale-mode check of ``diff`` (``revision.rayleigh_mismatch``) on every read."""
    from .revision import rayleigh_mismatch  # revision imports the analysis: only where FE data are read
    if body.fe.K is None and not assemble:
        return
    mismatch = rayleigh_mismatch(body)
    if mismatch is None:
        return
    stored = body.fe.K is not None
    tol = precision(body.provenance.digits, STORED if stored else ASSEMBLED)
    if not mismatch <= tol:
        where = "the stored stiffness K" if stored else "K assembled from the material"
        raise BodyFileError(path, "eigenvalues", f"the Rayleigh quotients phi^T K phi / phi^T M phi of the modes "
                            f"with {where} within {tol:.0e}", f"a relative difference of {mismatch:.3g} (the "
                            "eigenvalues or the modes, stiffness or material are damaged or stale)")


def check_stress(body: FlexibleBody, path) -> None:
    """Each mode's peak nodal stress within the bound its strain energy lambda_p / 2 allows (all modes first), then
    within a factor STRESS_SPREAD of the stress recomputed there from the modes and the material (``stress_bound``).
    """
    fe = body.fe
    peak = None if fe is None else peak_stress(fe, body.eigenvalues)
    if peak is None:
        return
    material = f"E={fe.material.E:g}, nu={fe.material.nu:g}"
    over = np.flatnonzero(peak.sigma > peak.bound)
    if over.size:
        p = over[0]
        raise BodyFileError(path, "modal stress", f"at most {peak.bound[p]:.4g}, what the mode's strain energy "
                            f"lambda/2 = {body.eigenvalues[p] / 2:.4g} allows in the cells at that node with "
                            f"{material} (docs/advice.md)", _peak(body, peak, p))
    again = peak.recomputed
    off = np.flatnonzero(np.isfinite(again) & ~((again / STRESS_SPREAD <= peak.sigma)
                                                & (peak.sigma <= again * STRESS_SPREAD)))
    if off.size:
        p = off[0]
        raise BodyFileError(path, "modal stress", f"the stress recomputed there from the modes and {material}, "
                            f"{again[p]:.4g}, within a factor {STRESS_SPREAD:g}", _peak(body, peak, p))


def _peak(body: FlexibleBody, peak, p: int) -> str:
    return (f"mode {p + 1}'s von Mises stress {peak.sigma[p]:.4g} {body.units.stress} per unit q at node index "
            f"{peak.node[p]} (from 0)")


def check_sigma_max(body: FlexibleBody, path) -> None:
    """The modes' largest stresses (``sigma_max``) are the maxima of their nodal stresses, to the source's precision
    (a second copy, such as a file's stress/max beside stress/nodal)."""
    fe = body.fe
    if fe is None or fe.stress_nodal is None or body.sigma_max is None:
        return
    nodal = fe.stress_nodal.max(axis=0)
    error = np.abs(body.sigma_max - nodal) / np.maximum(nodal, np.finfo(float).tiny)
    p = int(np.argmax(error))
    if not error[p] <= precision(body.provenance.digits, 1e-12):  # 1e-12: copies of one double, unit conversions
        raise BodyFileError(path, "modal stress maximum", f"the largest nodal von Mises stress of mode {p + 1}, "
                            f"{nodal[p]:.6g}", f"{body.sigma_max[p]:.6g}")


def checked(body: FlexibleBody, path, assemble: bool = True) -> FlexibleBody:
    """``body`` once its eigenvalues agree with its stiffness and its modal stresses with their bound and its
    material (theory 2, 6; docs/advice.md); else a one-line error naming both places. ``assemble``: without a
    stored K, assemble one from the material (a native file's own writer checked its modes so, and its
    checksums guard them since: there the assembly, seconds on a large body, is left out)."""
    if body.fe is not None:
        check_eigenvalues(body, path, assemble)
        check_sigma_max(body, path)
        check_stress(body, path)
    return body


def check_mode_numbers(path, field: str, numbers: Sequence[int], first: int | None = None) -> None:
    """Mode numbers unique and consecutive, from ``first`` where given (a damaged key files a mode under another
    number), in the order read."""
    got = [int(n) for n in numbers]
    start = got[0] if first is None and got else first
    if not got or got != list(range(start, start + len(got))):
        expected = "unique consecutive mode numbers" + ("" if first is None else f" from {first}")
        raise BodyFileError(path, field, expected, ", ".join(map(str, got[:10])) + (" ..." if len(got) > 10 else ""))


def check_frequencies(path, where: tuple[str, str], frequencies_hz, eigenvalues, digits: int | None) -> None:
    """Two copies of the modes' frequencies agree: f [Hz] = sqrt(lambda) / (2 pi), to the precision of the
    coarser (``digits``; None: double precision, 1e-9 for repr-printed numbers and one square root)."""
    f = np.asarray(frequencies_hz, float).ravel()
    lam = np.asarray(eigenvalues, float).ravel()
    if f.shape != lam.shape:
        raise BodyFileError(path, where[0], f"one frequency per eigenvalue of {where[1]} ({lam.size})", str(f.size))
    expected = np.sqrt(np.clip(lam, 0, None)) / (2 * np.pi)
    error = np.abs(f - expected) / np.maximum(np.abs(expected), np.finfo(float).tiny)
    worst = int(np.argmax(error)) if error.size else 0
    if error.size and not error[worst] <= precision(digits, 1e-9):
        raise BodyFileError(path, where[0], f"sqrt(lambda) / (2 pi) of {where[1]}, {expected[worst]:.7g} Hz for "
                            f"mode {worst + 1}", f"{f[worst]:.7g} Hz")
