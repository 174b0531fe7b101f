"""Where a CalculiX body's mass comes from: the stored matrices (.mas/.sti/.dof), the deck's point masses and
spiders, and the check of the total against CalculiX's own (the .dat's effective-mass total).

``SOLVER=MATRIXSTORAGE`` writes the matrices over the equations CalculiX
solved: one row per active degree of freedom, labelled ``node.direction``
(``.dof``). Where every node of the .frd has its three translations there
and nothing else is, ``M = kron(Ms, I3)`` over the .frd's nodes (theory 2).
Otherwise CalculiX reduced the mass onto other rows (shells and beams
expanded into 3D elements carry the shell or beam node's number once per
expanded node; a ``*RIGID BODY`` or a knot moves its nodes' mass onto its
REF and ROT nodes, which the .frd does not hold): ``dof_rows`` says why, and
the mass is taken from the mesh and the deck instead.
"""
from __future__ import annotations

from collections import Counter
from pathlib import Path

import numpy as np
import scipy.sparse as sp

from ..errors import BodyFileError
from ..fe.assembly import full_mass
from .calculix_deck import Deck, text_lines
from .limits import check_file_size

DAT_DIGITS = 7  # the .dat prints E14.7: 7 significant digits
# CalculiX writes modes of unit modal mass with its own M. Where the tool assembles the mass, CalculiX's C3D10 mass
# (its 4-point stiffness rule, inexact for N_a N_b) moves them by up to 2.5e-4 on the test bracket: a mass left out
# (a point mass, a spider's) moves them by its share of the modal mass, far above this.
MODAL_MASS_TOL = 1e-3
TOTAL_MASS = "T O T A L   E F F E C T I V E   M A S S"


def _expanded_rows(labels: list[tuple[int, int]], ids: np.ndarray, points: np.ndarray,
                   deck_nodes: dict) -> np.ndarray | None:
    """Rows of shells and beams CalculiX expanded, matched to the .frd's expanded nodes, or None.

    CalculiX numbers the equations node by node in increasing (internal) node
    number and labels an expanded node with its shell or beam node; the 3D
    .frd holds the expanded nodes under their internal numbers. Where every
    .frd node has its three rows and nothing else has rows (no knot, no
    spider), the k-th group of rows is the k-th .frd node; each match is
    checked: the group's label must be the deck node nearest the .frd node
    (an expanded node lies on its node's normal within half the thickness)."""
    if len(labels) != 3 * len(ids) or [c for _, c in labels] != [1, 2, 3] * len(ids):
        return None
    from scipy.spatial import cKDTree
    named = np.array(sorted({n for n, _ in labels}))
    if not all(int(n) in deck_nodes for n in named):
        return None
    _, nearest = cKDTree(np.array([deck_nodes[int(n)] for n in named])).query(points)
    order = np.argsort(ids, kind="stable")
    if not np.array_equal(named[nearest[order]], np.array([n for n, _ in labels[0::3]])):
        return None
    return (3 * order[:, None] + np.arange(3)).ravel()


def dof_rows(dof: Path, index: dict[int, int], ids: np.ndarray, points: np.ndarray,
             deck_nodes: dict) -> tuple[np.ndarray | None, str | None]:
    """Row -> DOF ``3 * node + direction`` over the .frd's nodes, or None and why the rows are no such map."""
    check_file_size(dof, 16)
    try:
        labels = [(int(n), int(c)) for n, c in (w.split(".") for w in dof.read_text().split())]
    except ValueError as e:
        raise BodyFileError(dof, "labels", "node.direction labels", str(e)[:60]) from None
    twice = [n for (n, c), k in Counter(labels).items() if k > 1]
    if twice:
        rows = _expanded_rows(labels, ids, points, deck_nodes)
        return (rows, None) if rows is not None else (None, (
            f"{dof.name} holds node {twice[0]} more than once (CalculiX's shells or beams expanded into 3D "
            "elements, labelled with the shell or beam node) and rows the .frd's nodes do not match one by one "
            "(a knot, or the extra nodes of C3D8I's incompatible modes)"))
    alien = [n for n, c in labels if n not in index or not 1 <= c <= 3]
    if alien:
        return None, (f"{dof.name} holds node {alien[0]}, which is no node of the .frd (a *RIGID BODY's REF or "
                      "ROT NODE or a knot of shells and beams, on which CalculiX reduced the mass of the nodes it "
                      "moves)")
    if len(labels) != 3 * len(index):
        return None, (f"{dof.name} holds {len(labels)} of the {3 * len(index)} translations of the .frd's nodes "
                      "(CalculiX eliminated constrained or dependent ones and moved their mass)")
    return np.array([3 * index[n] + c - 1 for n, c in labels]), None


def _stored_matrix(path: Path, rows: np.ndarray, n3: int) -> sp.csr_array:
    """A symmetric matrix from CalculiX 'row col value' triplets (upper triangle, 1-based DOF numbers)."""
    check_file_size(path, 2)  # text of 'i j value' lines holds more bytes than the three numbers parsed
    try:
        i, j, v = np.loadtxt(path, ndmin=2).T
        i, j = rows[i.astype(int) - 1], rows[j.astype(int) - 1]
    except (ValueError, IndexError) as e:
        raise BodyFileError(path, path.name, "'row col value' triplets over the DOFs of the .dof file",
                            str(e)[:60]) from None
    off = i != j
    return sp.coo_array((np.r_[v, v[off]], (np.r_[i, j[off]], np.r_[j, i[off]])), shape=(n3, n3)).tocsr()


def stored_matrices(stem: Path, index: dict, ids: np.ndarray, points: np.ndarray,
                    deck_nodes: dict) -> tuple[sp.csr_array | None, sp.csr_array | None, str | None]:
    """Scalar mass Ms (from M = kron(Ms, I3)) and stiffness K from job.mas/.sti/.dof over the .frd's nodes
    (``ids`` at ``points``), or None and why not (None without matrices)."""
    mas, sti, dof = (stem.with_suffix(s) for s in (".mas", ".sti", ".dof"))
    if not (mas.is_file() and dof.is_file()):
        return None, None, None
    rows, why = dof_rows(dof, index, ids, points, deck_nodes)
    if rows is None:
        return None, None, why
    n3 = 3 * len(index)
    M = _stored_matrix(mas, rows, n3)
    Ms = sp.csr_array(M[0::3, 0::3])
    if abs(M - full_mass(Ms)).max() > 1e-10 * abs(Ms).max():
        raise BodyFileError(mas, mas.name, "a mass matrix of the form kron(Ms, I3) (solid elements)")
    return Ms, (_stored_matrix(sti, rows, n3) if sti.is_file() else None), None


# ---------------------------------------------------------------- point masses and spiders
def _skew(r: np.ndarray) -> np.ndarray:
    """(k, 3, 3) cross-product matrices: skew(r) a = r x a."""
    z = np.zeros(len(r))
    x, y, w = r.T
    return np.stack([np.stack([z, -w, y], -1), np.stack([w, z, -x], -1), np.stack([-y, x, z], -1)], -2)


def rigid_point(X: np.ndarray, U: np.ndarray, x: np.ndarray, digits: int, where: str) -> np.ndarray:
    """Displacements (3, nm) at point ``x`` of the rigid motion the nodes X (k, 3) make with U (k, 3, nm):
    ``U_j = u + theta x (X_j - x)`` fitted by least squares (theory 3b: small rotations); a fit that leaves
    more than the file's precision (10^(1-digits) of the largest U) or cannot fix theta is an error."""
    A = np.concatenate([np.broadcast_to(np.eye(3), (len(X), 3, 3)), -_skew(X - x)], axis=2).reshape(-1, 6)
    if np.linalg.matrix_rank(A, tol=1e-9 * np.abs(A).max()) < 6:
        raise ValueError(f"{where}: its nodes lie on one line, which does not fix its rotation")
    b = U.reshape(-1, U.shape[-1])
    sol, *_ = np.linalg.lstsq(A, b, rcond=None)
    off = np.abs(A @ sol - b).max()
    if off > 10.0 ** (1 - digits) * max(np.abs(b).max(), 1e-300):
        raise ValueError(f"{where}: its nodes do not move rigidly in the .frd's modes (off by {off:.3g})")
    return sol[:3]


def _rigid_nodes(deck: Deck, body_card, element_nodes) -> list[int]:
    if body_card.nset:
        return deck.members(deck.nsets, body_card.nset)
    return sorted({n for e in deck.members(deck.elsets, body_card.elset or "") for n in element_nodes(e)})


def refuse_rotary_inertia(deck: Deck | None) -> None:
    """*ROTARY INERTIA is refused by name: CalculiX 2.20 does not read it (it warns 'card image cannot be
    interpreted' and solves without it), so neither its modes nor its .mas hold it."""
    if deck is not None and deck.rotary:
        deck.fail("*ROTARY INERTIA", "cards CalculiX 2.20 reads (it warns 'card image cannot be interpreted' and "
                  "solves without the rotary inertia); model it as point masses on a *RIGID BODY's nodes",
                  f"*ROTARY INERTIA, ELSET={deck.rotary[0]}")


def point_masses(deck: Deck) -> list[tuple[int, float]]:
    """(node, mass) of every ``*MASS`` element of the deck."""
    out = []
    for elset, m in deck.masses:
        for e in deck.members(deck.elsets, elset):
            out += [(n, m) for n in deck.element_nodes.get(e, [])]
    return out


def carried_masses(deck: Deck, frd_points: np.ndarray, U: np.ndarray, index: dict[int, int], digits: int,
                   element_nodes) -> tuple[list[tuple[int, float]], np.ndarray, np.ndarray]:
    """The deck's point masses on the .frd's nodes (node index, mass), and the REF NODEs of spiders that carry
    masses outside the .frd: their points (k, 3) and displacements (k, 3, nm) from the spider's rigid
    motion. A mass on a ROT NODE (its values are rotations) or on a node nothing moves is refused."""
    rot = {b.rot for b in deck.rigid if b.rot}
    refs = {b.ref: b for b in deck.rigid if b.ref}
    on_frd, points, motion, extra = [], [], [], {}
    for node, m in point_masses(deck):
        if node in rot:
            deck.fail("*MASS", "masses on nodes that move (a ROT NODE's values are rotations)",
                      f"a mass on node {node}, the ROT NODE of a *RIGID BODY")
        if node in index:
            on_frd.append((index[node], m))
        elif node in refs and node in deck.nodes:
            extra.setdefault(node, []).append(m)
        else:
            deck.fail("*MASS", "masses on nodes of the .frd or on a *RIGID BODY's REF NODE",
                      f"a mass on node {node}, which no element of the .frd holds and no *RIGID BODY moves")
    for k, (node, ms) in enumerate(extra.items()):
        spider = [index[n] for n in _rigid_nodes(deck, refs[node], element_nodes) if n in index]
        x = np.array(deck.nodes[node])
        try:
            motion.append(rigid_point(frd_points[spider], U[spider], x, digits,
                                      f"the *RIGID BODY of REF NODE {node}"))
        except ValueError as e:
            deck.fail("*RIGID BODY", "a spider whose nodes the .frd holds and moves rigidly", str(e))
        points.append(x)
        on_frd.append((len(index) + k, float(sum(ms))))
    return on_frd, np.reshape(points, (-1, 3)), np.reshape(motion, (-1, 3, U.shape[-1]))


def with_point_masses(Ms: sp.sparray, masses: list[tuple[int, float]], n: int) -> sp.csr_array:
    """Ms grown to ``n`` nodes with the point masses on its diagonal (a point mass moves with its node)."""
    Ms = sp.csr_array(Ms)
    grown = sp.block_diag([Ms, sp.csr_array((n - Ms.shape[0], n - Ms.shape[0]))]) if n > Ms.shape[0] else Ms
    if not masses:
        return sp.csr_array(grown)
    i, m = np.array([k for k, _ in masses]), np.array([m for _, m in masses])
    return sp.csr_array(grown + sp.coo_array((m, (i, i)), shape=(n, n)))


# ---------------------------------------------------------------- the FE code's own total mass
def dat_total_mass(path: Path) -> np.ndarray | None:
    """The x, y, z components of the .dat's 'TOTAL EFFECTIVE MASS' of the last frequency step, or None."""
    if not path.is_file():
        return None
    total, armed = None, False
    for line in text_lines(path):
        if TOTAL_MASS in line:
            armed = True
            continue
        parts = line.split()
        if armed and len(parts) == 6:
            try:
                total, armed = np.array([float(p) for p in parts[:3]]), False
            except ValueError:
                armed = False
    return total


def check_modal_masses(frd: Path, scale: np.ndarray, source: str) -> None:
    """CalculiX's modes have unit modal mass with its M: their modal masses with the body's mass (``scale``
    squared) off by more than MODAL_MASS_TOL name a mass the body lacks or has twice."""
    off = float(np.abs(scale**2 - 1).max())
    if off > MODAL_MASS_TOL:
        raise BodyFileError(frd, "DISP", f"modes of unit modal mass with the body's mass ({source})",
                            f"modal masses off by up to {off:.2g} (a mass left out or counted twice)")


def check_total_mass(dat: Path, mass: float, source: str, deck: Deck | None) -> str | None:
    """The body's mass against CalculiX's effective-mass total of a free-free run (the six rigid modes carry
    every translation's mass exactly): an error naming both beyond the .dat's 7 digits, else a note. Where the
    x, y, z totals differ (a *RIGID BODY's or a knot's rotations counted as translations) a note says so."""
    total = dat_total_mass(dat)
    if total is None:
        return None
    spread = float(np.ptp(total) / np.abs(total).max())
    if deck is not None and deck.rigid or spread > 10.0 ** (1 - DAT_DIGITS):
        return (f"total mass not checked against the .dat: its effective-mass totals differ by {spread:.2g} between "
                "x, y and z (CalculiX counts the rotations of a *RIGID BODY's ROT NODE or a knot's as translations)")
    off = float(np.abs(total / mass - 1).max())
    if off > 10.0 ** (1 - DAT_DIGITS):  # one unit of the 7th printed digit
        raise BodyFileError(dat, "TOTAL EFFECTIVE MASS", f"the total mass of the body read ({mass:.7g}, {source})",
                            f"{total[0]:.7g}, {total[1]:.7g}, {total[2]:.7g} (off by {off:.2g}: a mass left out "
                            "or counted twice)")
    return f"total mass {mass:.7g} agrees with the .dat's effective-mass total to {off:.1g}"
