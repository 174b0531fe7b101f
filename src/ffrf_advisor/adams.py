"""Adams-style inertia invariants I1..I9 <-> the shape integrals of theory section 3.

Definitions and mapping: docs/adams_invariants.md sections 1.2 and 3
(Adams sign convention: I8_j = sum m s~ Phi_j~, I9_jk = sum m Phi_j~ Phi_k~).
With C_j[k, l] = Ibar_kl[j] and D_ij[k, l] = Sbar_kl[i, j]:
I8_j = C_j^T - tr(C_j) E, I9_ij = D_ij^T - tr(D_ij) E, I7 = tr(C0) E - C0.
"""
from __future__ import annotations

import numpy as np

from .invariants import EPS, RotaryIntegrals, ShapeIntegrals

SIGNS = ("adams", "mbdyn")  # MBDyn stores I8 with the opposite sign


def _minus_trace(A: np.ndarray, axes: str) -> np.ndarray:
    """A^T - tr(A) E for stacks of 3x3 blocks A[k, l, ...]: docs/adams_invariants.md section 3.2's map, both
    directions up to 1/2."""
    tr = np.einsum(f"kk{axes}->{axes}", A)
    E = np.eye(3).reshape((3, 3) + (1,) * len(axes))
    return np.swapaxes(A, 0, 1) - tr * E


def to_adams(J: ShapeIntegrals, I8_sign: str = "adams") -> dict[str, np.ndarray]:
    """I1..I9 of the shape integrals J (I5 and I9 only when Sbar is known). With nodal rotary inertia
    (theory 3b) I4, I6 and I7 include it, and the rotary parts are given apart as
    ``nodal_rotary_inertia_sum``, ``rotary_I4`` and ``rotary_I6`` (I5, I8, I9 are translational)."""
    inv = {
        "I1": np.array(J.mass),
        "I2": J.first_moment,
        "I3": J.mode_sum,
        "I4": J.mean_axis_residual(),
        "I7": J.I0(),
        "I8": np.moveaxis(_minus_trace(J.Ibar, "j"), 2, 0) * (1 if I8_sign == "adams" else -1),  # (j, k, l)
    }
    if J.Sbar is not None:
        inv["I5"] = np.einsum("abc,bcji->jai", EPS, J.Sbar)  # I5_j[:, i] = sum m Phi_j x Phi_i
        inv["I6"] = J.modal_mass()
        inv["I9"] = np.moveaxis(_minus_trace(J.Sbar, "ij"), (2, 3), (0, 1))  # (i, j, k, l)
    elif J.spin is not None:
        inv["I5"] = np.einsum("aji->jai", J.spin)
    if J.rotary is not None:
        inv.update(nodal_rotary_inertia_sum=J.rotary.J, rotary_I4=J.rotary.mean_axis, rotary_I6=J.rotary.modal_mass)
    return inv


def from_adams(inv: dict[str, np.ndarray], nf: int, I8_sign: str = "adams") -> ShapeIntegrals:
    """Shape integrals from I1, I2, I7, I8 and optional I3, I5, I9 (docs/adams_invariants.md section 3.3).

    I_kl = 1/2 tr(I7') delta_kl - I7'[k, l], so that I0 = I7 exactly, with I7' = I7 less the
    ``nodal_rotary_inertia_sum`` when the file gives it (then carried as the rotary sums of theory 3b with
    ``rotary_I4`` and ``rotary_I6``), else I7 (rotary inertia folded into I). Without I9, Sbar is unknown;
    with I5 then W3 is still known (``spin``).
    """
    rotary = _rotary(inv, nf)
    I7 = inv["I7"] - (0.0 if rotary is None else rotary.J)
    C = np.moveaxis(inv["I8"] * (1 if I8_sign == "adams" else -1), 0, 2)  # I8[k, l, j]
    Ibar = np.swapaxes(C, 0, 1) - 0.5 * np.einsum("kkj->j", C) * np.eye(3)[:, :, None]
    Sbar = spin = None
    if "I9" in inv:
        D = np.moveaxis(inv["I9"], (0, 1), (2, 3))  # I9[k, l, i, j]
        Sbar = np.swapaxes(D, 0, 1) - 0.5 * np.einsum("kkij->ij", D) * np.eye(3)[:, :, None, None]
    elif "I5" in inv:
        spin = np.einsum("jai->aji", inv["I5"])  # W3[k, j, i] = I5_j[k, i]
    return ShapeIntegrals(
        mass=float(inv["I1"]),
        first_moment=inv["I2"],
        I=0.5 * np.trace(I7) * np.eye(3) - I7,
        Ibar=Ibar,
        Sbar=Sbar,
        mode_sum=inv.get("I3", np.zeros((3, nf))),
        spin=spin,
        rotary=rotary,
    )


def _rotary(inv: dict[str, np.ndarray], nf: int) -> RotaryIntegrals | None:
    """The rotary sums of theory 3b from the file's nodal_rotary_inertia_sum, rotary_I4, rotary_I6 (absent
    parts zero); None without the first."""
    if "nodal_rotary_inertia_sum" not in inv:
        return None
    return RotaryIntegrals(inv["nodal_rotary_inertia_sum"], inv.get("rotary_I4", np.zeros((3, nf))),
                           inv.get("rotary_I6", np.zeros((nf, nf))))


def w3_from_I9(I9: np.ndarray) -> np.ndarray:
    """W3 (3, nf, nf) from I9 alone: v = axial(I9_ji - I9_ij), W3[k, j, i] = v_k (docs/adams_invariants.md
    section 3.3)."""
    A = np.swapaxes(I9, 0, 1) - I9  # A[i, j] = I9_ji - I9_ij
    v = -0.5 * np.einsum("kab,ijab->kij", EPS, A)  # skew(v)_ab = -eps_abk v_k
    return np.swapaxes(v, 1, 2)
