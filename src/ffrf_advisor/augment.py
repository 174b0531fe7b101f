"""Residual vectors: add the static centrifugal deflections to a body's modes (theory sections 11 and 4).

The static deflections ``u_k`` of unit spin about the chosen principal axes
join the kept modes; the enlarged basis is brought back to the form of
theory section 1 (``transform.to_section1_form``: rigid parts removed,
reduced eigenproblem, mass-normalised, CoM principal frame), and the
invariants, modal stresses and the static centrifugal response are
recomputed, and so is the geometric stiffness. The new "modes" above the kept ones are pseudo-modes that
carry the static widening.
"""
from __future__ import annotations

import numpy as np

from .centrifugal import static_centrifugal
from .body import FlexibleBody
from .errors import FFRFError
from .fe.assembly import full_mass, stiffness_matrix
from .fe_body import fe_body, with_centrifugal_response
from .fe.mesh import Mesh
from .fe.stress import modal_von_mises
from .transform import to_section1_form


def parse_axes(text: str) -> tuple[int, ...]:
    """'1,2,3' -> (1, 2, 3): distinct principal axes."""
    try:
        axes = tuple(int(x) for x in text.split(","))
    except ValueError:
        axes = ()
    if not axes or len(set(axes)) != len(axes) or any(k not in (1, 2, 3) for k in axes):
        raise FFRFError(f"--axes {text!r}: expected distinct principal axes from 1, 2, 3, e.g. 1,2,3")
    return axes


def augment(body: FlexibleBody, axes=(1, 2, 3), source: str = "BODY") -> FlexibleBody:
    """``body`` with the static centrifugal deflections about ``axes`` (1-based) as residual vectors."""
    fe = _checked_fe(body, source)
    _, U = static_centrifugal(fe, fe.material)
    note = (f"augmented: static centrifugal deflections about principal axes {', '.join(map(str, axes))} "
            f"added as residual vectors (theory 11)")
    return with_residual_vectors(body, U[:, [k - 1 for k in axes]], note)


def _checked_fe(body: FlexibleBody, source: str):
    """The body's FE data, refused by name without nodal data or material."""
    fe = body.fe
    if fe is None:
        raise FFRFError(f"{source}: modes/Phi: expected nodal FE data (mesh, mass, modes), got invariants only")
    if fe.material is None:
        raise FFRFError(f"{source}: material: expected the body's material (E, nu, rho) to assemble K and "
                        "recover stresses (bodies written by `sample` or `augment` carry it)")
    return fe


def with_residual_vectors(body: FlexibleBody, U: np.ndarray, note: str, source: str = "BODY") -> FlexibleBody:
    """``body``'s modes and the displacement fields U (3n, r) as one basis in the form of theory section 1,
    with invariants, modal stresses, the static centrifugal response and G recomputed; ``note`` (what was
    added and why) goes to the provenance with the mode counts."""
    fe = _checked_fe(body, source)
    n, nf = fe.mesh.n_nodes, body.nf
    R = U / np.sqrt(np.einsum("ik,ik->k", U, full_mass(fe.Ms) @ U))  # unit M-norm, like the mass-normalised modes
    Psi = np.column_stack([fe.Phi.reshape(3 * n, nf), R])
    K = fe.K if fe.K is not None else stiffness_matrix(fe.mesh, fe.material)
    tr = to_section1_form(fe.mesh.points, fe.Ms, K, Psi)
    mesh = Mesh(tr.points, dict(fe.mesh.cells))
    stress = modal_von_mises(mesh, fe.material, tr.Phi)
    note += f"; basis to section 1 form, {nf} + {R.shape[1]} -> {tr.Phi.shape[2]} modes"
    new = fe_body(body.name, mesh, fe.Ms, tr.Phi, tr.eigenvalues, body.provenance.with_note(note), fe.K, stress,
                  fe.material, body.units)
    return with_centrifugal_response(new)
