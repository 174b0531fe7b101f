"""MBDyn's modal FEM file ``.fem`` (the ``modal`` joint's FE data), written and read (docs/format.md).

Record groups (layout: io.mbdyn_records): 1 header, 2 node labels, 3/4 initial modal coordinates and rates,
5-7 node coordinates, 8 mode shapes (x y z rx ry rz per node), 9/10 modal mass and stiffness, 11 lumped
nodal masses, 12 mass, centre of mass and inertia about it, 13 modal damping, 14-18 MBDyn's invariants
in the definitions of its ``modal.cc`` (adams_invariants.md's I3, I4, I5, I8, I9, I8 of opposite sign),
with the shape integrals and W1, W2, W3 of theory 3 (nodal sums, m -> Ms for a consistent mass):

    Inv3 = sum m Phi_j = mode_sum[:, j]           Inv4 = sum m u~ Phi_j (+ J Phi*_j) = mean_axis_residual[:, j]
    Inv8_j = -sum m u~ Phi_j~                     W1[a, b nf + j] = (Inv8_j + Inv8_j^T)[a, b]
    Inv5_j[:, k] = sum m Phi_j x Phi_k            W3[a nf + j, k] = Inv5_j[a, k]
    Inv9_jk = sum m Phi_j~ Phi_k~                 W2[a nf + j, b nf + k] = -Inv9_jk[a, b]

MBDyn builds the invariants from group 11 by lumped nodal sums and *adds* them to groups 14-18 when both
are present, so the writer gives 12 and 14-18 (the body's own nodal sums, no approximation) and no 11; it
needs an MBDyn that reads groups 14-18. The reader takes the invariants from 12 and 14-18, else computes
them from 11 as MBDyn does (12, when present, replacing the rigid-body part); a coupled modal mass and
stiffness is solved as a generalised eigenproblem and the modes and invariants transformed. Units: the
writer's tag line, else t-mm-N-s assumed (the format has none).
"""
from __future__ import annotations

import os
from dataclasses import replace
from typing import Iterator

import numpy as np
import scipy.sparse as sp

from .. import __version__
from ..adams import from_adams, to_adams
from ..body import FlexibleBody, ModalFE, NodalRotary, NodalSummary, Provenance
from ..checks import TOLERANCES, check_values
from ..errors import FFRFError
from ..fe.mesh import Mesh
from ..invariants import RotaryIntegrals, ShapeIntegrals, largest_squares
from ..units import TMM
from .atomic import atomic_path
from .mbdyn_records import INVARIANT_GROUPS, Records, field, file_rows, parse

PER_LINE = 6  # numbers per line: the format's loose rule, which MBDyn does not need
LUMPED_MODAL_MASS = 0.1  # lumped masses against a consistent model's modal mass: < 0.006 on the samples
STORED_MODAL_MASS = 1e-3  # Inv9 against group 9: one mass matrix gave both (ffinv's I6 tolerance)
SYMMETRY = 1e-10  # relative asymmetry of groups 9, 10, 12 accepted: a symmetric matrix printed pairwise alike


# ---------------------------------------------------------------- writing
def write(body: FlexibleBody, path, overwrite: bool = False) -> None:
    """The body as an MBDyn modal FEM file, numbers in their shortest exact form (round trip exact)."""
    if body.fe is None:
        raise FFRFError(f"{path}: an MBDyn .fem file needs the FE nodes and the mode shapes at them (record groups "
                        f"5-8); {body.name} has invariants only (write .ffinv.json or .ffinv.h5)")
    with atomic_path(path, overwrite) as tmp:
        with open(tmp, "w", encoding="utf-8") as fh:
            fh.writelines(line + "\n" for line in _lines(body))


def _numbers(values) -> Iterator[str]:
    """Lines of at most PER_LINE numbers; repr is the shortest text that reads back to the same double."""
    flat = np.ravel(values).tolist()
    for i in range(0, len(flat), PER_LINE):
        yield " ".join(map(repr, flat[i:i + PER_LINE]))


def _group(g: int, title: str, rows) -> Iterator[str]:
    yield f"** RECORD GROUP {g}, {title}"
    for row in rows:
        yield from _numbers(row)
    yield "**"


def _lines(body: FlexibleBody) -> Iterator[str]:
    fe, nf = body.fe, body.nf
    X, n = fe.mesh.points, fe.mesh.n_nodes
    rot = np.zeros_like(fe.Phi)
    if fe.rotary is not None:
        rot[fe.rotary.nodes] = fe.rotary.Phi
    yield "** MBDyn MODAL DATA FILE"
    yield f"** written by ffrf-advisor {__version__} from body {' '.join(str(body.name).split())[:80]}"
    yield f"** ffrf-advisor: units {body.units}, mass matrix {body.provenance.mass_matrix}"
    yield "** modes mass-normalised: group 9 the identity, 10 the eigenvalues; 12 mass, centre of mass and"
    yield "** inertia about it; 14-18 the invariants by nodal sums with the body's own mass matrix (theory 3)."
    yield "** No group 11 (lumped masses): MBDyn would add their nodal sums to groups 14-18."
    yield "** RECORD GROUP 1, HEADER"
    yield "**   REVISION,  NODE,  NORMAL, ATTACHMENT, CONSTRAINT, REJECTED MODES."
    yield f"REV0 {n} {nf} 0 0 0"
    yield "**"
    yield "** RECORD GROUP 2, FINITE ELEMENT NODE LIST"
    for i in range(0, n, PER_LINE):
        yield " ".join(str(k + 1) for k in range(i, min(n, i + PER_LINE)))
    yield "**"
    yield from _group(3, "INITIAL MODAL DISPLACEMENTS", [np.zeros(nf)])
    yield from _group(4, "INITIAL MODAL VELOCITIES", [np.zeros(nf)])
    for g, axis in ((5, "X"), (6, "Y"), (7, "Z")):
        yield from _group(g, f"NODAL {axis} COORDINATES", [X[:, g - 5]])
    yield "** RECORD GROUP 8, MODE SHAPES"
    for p in range(nf):
        yield f"**    NORMAL MODE SHAPE #  {p + 1}"  # MBDyn wants exactly this one line between modes
        yield from _numbers(np.concatenate([fe.Phi[:, :, p], rot[:, :, p]], axis=1))
    yield "**"
    yield from _group(9, "MODAL MASS MATRIX", np.eye(nf))
    yield from _group(10, "MODAL STIFFNESS MATRIX", np.diag(body.eigenvalues))
    about_com = body.integrals.shifted(body.com).I0()
    yield from _group(12, "GLOBAL INERTIA", [[body.mass], body.com, *about_com])
    inv = to_adams(body.integrals, "mbdyn")
    for g, (key, _) in INVARIANT_GROUPS.items():
        if key in inv:
            yield from _group(g, f"INVARIANT {key[1]}", file_rows(g, inv[key]))
    yield "** END OF FILE"


# ---------------------------------------------------------------- reading
def read(path, load_fe: bool | str = False) -> FlexibleBody:
    """A body from an MBDyn modal FEM file. Its nodal data become ``fe`` (``load_fe`` True) where group 11
    gives the nodal masses, else the nodal summary (theory 6: the modes' largest deflections)."""
    rec = parse(path)
    lam, T, notes = _normal_modes(rec)
    Phi, rot = (a if T is None else a @ T for a in rec.modes())
    if 11 in rec.groups:
        integrals, fe, more = _lumped(rec, Phi, rot)
    else:
        (integrals, more), fe = _stored(rec, T, rot), None
    body = FlexibleBody(name=os.path.basename(str(path)).split(".")[0], integrals=integrals, eigenvalues=lam,
                        units=rec.units or TMM, provenance=_provenance(rec, fe is not None, notes + more),
                        fe=fe if load_fe is True else None)
    return _framed(body, rec.points, Phi)


def _provenance(rec: Records, lumped: bool, notes: list[str]) -> Provenance:
    assumed = [] if rec.units else ["units: none stated (an MBDyn file carries none); t-mm-N-s assumed"]
    unused = [f"{field(g)} not used by the advisor" for g in (3, 4, 13, 19) if np.any(rec.groups.get(g, 0))]
    method = "nodal sums with the lumped masses of record group 11 (theory 3)" if lumped else \
        "invariants of record groups 12, 14-18"
    return Provenance(source=rec.path, mass_matrix="lumped" if lumped else rec.mass_kind or "unknown",
                      method=f"MBDyn modal FEM file: {method}", notes=tuple(assumed + notes + unused))


def _normal_modes(rec: Records) -> tuple[np.ndarray, np.ndarray | None, list[str]]:
    """Eigenvalues and the basis change T (None: none) to mass-normalised normal modes, from groups 9, 10."""
    M, K = rec.groups[9], rec.groups[10]
    if not _coupled(M) and not _coupled(K):  # read as it stands: the eigenvalues bitwise
        m = np.diag(M)
        if not np.all(m > 0):
            rec.fail(9, "positive modal masses (normal modes with mass)", f"{m.min():.6g}")
        if np.all(m == 1):
            return np.diag(K).copy(), None, []
        return np.diag(K) / m, np.diag(1 / np.sqrt(m)), ["modes scaled to unit modal mass (record group 9)"]
    for g, A in ((9, M), (10, K)):
        if np.abs(A - A.T).max() > SYMMETRY * np.abs(A).max():
            rec.fail(g, "a symmetric matrix", f"asymmetry {np.abs(A - A.T).max():.3g}")
    import scipy.linalg as sla  # ~0.1 s of import that the diagonal case does without
    try:
        lam, V = sla.eigh(0.5 * (K + K.T), 0.5 * (M + M.T))
    except (sla.LinAlgError, ValueError):
        rec.fail(9, "a positive definite modal mass matrix (normal modes with mass)", "not positive definite")
    return lam, V, ["record groups 9, 10 coupled: K v = lambda M v solved, the modes and invariants transformed "
                    "to its mass-normalised eigenvectors"]


def _coupled(A: np.ndarray) -> bool:
    return bool(np.any(A != np.diag(np.diag(A))))


def _rigid(rec: Records) -> dict[str, np.ndarray]:
    """I1, I2 and I7 (about the frame origin, by parallel axes) of group 12's mass, CoM and inertia."""
    a = rec.groups[12]
    m, c, J = a[0], a[1:4], a[4:].reshape(3, 3)
    if not m > 0:
        rec.fail(12, "a positive mass", f"{m:.6g}")
    if np.abs(J - J.T).max() > SYMMETRY * np.abs(J).max():
        rec.fail(12, "a symmetric inertia matrix", f"asymmetry {np.abs(J - J.T).max():.3g}")
    return {"I1": np.array(m), "I2": m * c, "I7": 0.5 * (J + J.T) + m * (c @ c * np.eye(3) - np.outer(c, c))}


BASIS = {"I3": "aj,jq->aq", "I4": "aj,jq->aq", "I8": "jkl,jq->qkl", "I5": "jak,jq,kr->qar", "I9": "jkab,jq,kr->qrab"}


def _in_basis(key: str, a: np.ndarray, T: np.ndarray) -> np.ndarray:
    """An invariant of the file's modes for the modes Phi T (linear in each of its mode indices)."""
    spec = BASIS[key]
    return np.einsum(spec, a, *(T,) * spec.count(","), optimize=True)


def _stored(rec: Records, T, rot) -> tuple[ShapeIntegrals, list[str]]:
    """The invariants of groups 12 and 14-18 (needs 12 and 16); nodes with rotations make rotary sums whose
    mean-axis and modal-mass parts are what Inv4 and the unit modal mass leave (theory 3b)."""
    for g, what in ((16, "invariant 8, or record group 11 (lumped masses) to compute it"),
                    (12, "mass, centre of mass and inertia beside record groups 14-18")):
        if g not in rec.groups:
            rec.fail(g, what, "missing")
    nf = rec.counts.modes
    inv = {key: rec.invariant(g) if T is None else _in_basis(key, rec.invariant(g), T)
           for g, (key, _) in INVARIANT_GROUPS.items() if g in rec.groups} | _rigid(rec)
    J = from_adams(inv, nf, "mbdyn")
    if not np.any(rot) and J.Sbar is not None:
        _normalised(rec, J, 18, STORED_MODAL_MASS)
    notes = []
    if "I3" not in inv:
        notes.append(f"no {field(14)}: sum m Phi taken as zero (free-surface modes)")
    if "I9" not in inv:
        notes.append(f"no {field(18)}: W2 (quadratic inertia change, centrifugal softening) not evaluable"
                     + ("" if "I5" in inv else f"; no {field(17)} either: W3 not evaluable"))
    if np.any(rot):
        mean_axis = inv["I4"] - J.mean_axis_residual() if "I4" in inv else np.zeros((3, nf))
        modal_mass = np.eye(nf) - J.modal_mass() if J.Sbar is not None else np.zeros((nf, nf))
        J = replace(J, rotary=RotaryIntegrals(np.zeros((3, 3)), mean_axis, modal_mass))
        notes.append("nodes with rotations (theory 3b): their rotary inertia is part of I (record group 12 "
                     "gives the total)")
    notes.append(f"largest modal deflections and size from the {rec.counts.nodes} nodes of record groups 5-8 (a "
                 "file that lists only interface nodes understates them)")
    return J, notes


def _lumped(rec: Records, Phi, rot) -> tuple[ShapeIntegrals, ModalFE, list[str]]:
    """Nodal sums with group 11's masses and rotary inertia diag(RX, RY, RZ), as MBDyn builds its invariants;
    group 12, when present, replaces the rigid-body part (mass, CoM, inertia) as it does in MBDyn."""
    if any(g in rec.groups for g in INVARIANT_GROUPS):
        rec.fail(11, "record group 11 or groups 14-18, not both (MBDyn would add the nodal sums of 11 to 14-18)",
                 "both")
    d = rec.groups[11]
    m, Jd = d[:, 0], d[:, 3:]
    nodes = np.flatnonzero(np.any(Jd != 0, axis=1))
    rotary = NodalRotary(nodes, Jd[nodes][:, :, None] * np.eye(3), rot[nodes]) if nodes.size else None
    fe = ModalFE(Mesh(rec.points, {}), sp.csr_array(sp.diags_array(m)), Phi, rotary=rotary)
    J = _normalised(rec, fe.integrals(), 11, LUMPED_MODAL_MASS)
    notes = [] if np.array_equal(d[:, 1], m) and np.array_equal(d[:, 2], m) else \
        [f"{field(11)}: Y or Z masses differ from X; X used, as MBDyn does"]
    if 12 in rec.groups:
        mass = J.mass
        J = from_adams(to_adams(J, "mbdyn") | _rigid(rec), rec.counts.modes, "mbdyn")
        notes.append(f"{field(12)} replaces the nodal sums' mass ({J.mass / mass - 1:+.2g} relative), centre of "
                     "mass and inertia, as in MBDyn")
    return J, fe, notes


def _normalised(rec: Records, J: ShapeIntegrals, g: int, tol: float) -> ShapeIntegrals:
    """J, whose modal mass by nodal sums (theory 3, 3b) must be record group 9's, the identity after scaling."""
    error = np.abs(J.modal_mass() - np.eye(J.nf)).max()
    if not error <= tol:
        rec.fail(g, f"a modal mass sum m Phi^T Phi equal to that of record group 9 within {tol:g}",
                 f"max |difference| {error:.3g} after scaling to unit modal mass")
    return J


def _summary(X: np.ndarray, Phi: np.ndarray) -> NodalSummary | None:
    """The modes' largest nodal deflections and the nodes' extent (theory 4, 6); None for coincident nodes."""
    size = Mesh(X).largest_dimension()
    return NodalSummary(np.sqrt(largest_squares(Phi)), size, len(X), False) if size > 0 else None


def _framed(body: FlexibleBody, X: np.ndarray, Phi: np.ndarray) -> FlexibleBody:
    """The body with its nodal summary, moved to the CoM principal frame (theory 4) when the file's frame (the
    modal node's) fails the checks' tolerances for it, with a note."""
    if body.fe is None:
        body = replace(body, nodal=_summary(X, Phi))
    values = check_values(body)
    if values["com_offset"] <= TOLERANCES["com_offset"] and values["principal_axes"] <= TOLERANCES["principal_axes"]:
        return body
    _, c, R = body.in_principal_frame()
    moved = body.moved_to_principal_frame()
    return moved if moved.fe is not None else replace(moved, nodal=_summary((X - c) @ R, Phi))
