"""Vectorised assembly of the scalar mass matrix Ms and the elastic stiffness K.

Node-interleaved DOF order: DOF ``3 * node + component``; then the full mass
matrix is ``kron(Ms, I3)`` (theory section 2, N eqs 34-35) and a mode matrix
of shape (n, 3, nf) reshapes to (3n, nf) without copying.
"""
from __future__ import annotations

from dataclasses import replace
from typing import Iterable, Iterator, Mapping

import numpy as np
import scipy.sparse as sp

from .elements import ElementType, element_type
from .material import Material
from .mesh import Mesh

Rule = tuple[np.ndarray, np.ndarray]  # reference points (nq, 3), weights (nq,)
_CHUNK_ENTRIES = 8_000_000  # element-matrix entries per assembly chunk (bounds its memory: about 0.3 GB)
LUMPINGS = ("rowsum", "hrz")


def _jacobians(etype: ElementType, coords: np.ndarray, xi: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """dN/dxi (npts, nn, 3), J (ne, npts, 3, 3) with J_ab = d x_b / d xi_a, and det J, refused where det J <= 0."""
    _, dN = etype.shape(xi)
    J = np.tensordot(coords, dN, axes=([1], [1])).transpose(0, 2, 3, 1)  # one matrix product (BLAS)
    detJ = _det3(J)
    if np.any(detJ <= 0):
        bad = int(np.argwhere(detJ <= 0)[0, 0])
        raise ValueError(f"element {bad} ({etype.name}) is inverted or degenerate (det J <= 0)")
    return dN, J, detJ


def _det3(J: np.ndarray) -> np.ndarray:
    """Determinants of (..., 3, 3) matrices by the rule of Sarrus (a loop-free 3 x 3 formula)."""
    a, b, c = J[..., 0, :], J[..., 1, :], J[..., 2, :]
    return (a[..., 0] * (b[..., 1] * c[..., 2] - b[..., 2] * c[..., 1])
            - a[..., 1] * (b[..., 0] * c[..., 2] - b[..., 2] * c[..., 0])
            + a[..., 2] * (b[..., 0] * c[..., 1] - b[..., 1] * c[..., 0]))


def element_gradients(etype: ElementType, coords: np.ndarray, xi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Shape-function gradients dN/dx (ne, npts, nn, 3) and det J (ne, npts) at reference points xi."""
    dN, J, detJ = _jacobians(etype, coords, xi)
    G = np.linalg.solve(J[:, :, None], dN.transpose(0, 2, 1)[None, :, None])  # (ne, np, 1, 3, nn)
    return G[:, :, 0].transpose(0, 1, 3, 2), detJ


def summed(parts: Iterable[sp.sparray], shape: tuple[int, int]) -> sp.csr_array:
    """The sum of sparse matrices, added in pairs of equal rank (a binary counter): O(nnz log parts) work and at
    most about twice the result's memory, where adding each part to a running sum costs O(nnz parts)."""
    stack: list[tuple[int, sp.csr_array]] = []
    for part in parts:
        rank, total = 0, sp.csr_array(part)
        while stack and stack[-1][0] == rank:
            total = stack.pop()[1] + total
            rank += 1
        stack.append((rank, total))
    result = sp.csr_array(shape)
    for _, part in stack:
        result = result + part
    return sp.csr_array(result)


def scattered(values: np.ndarray, index: np.ndarray, n: int) -> sp.csr_array:
    """Element matrices (ne, k, k) on the rows and columns ``index`` (ne, k) as an n x n matrix (duplicates summed)."""
    rows = np.broadcast_to(index[:, :, None], values.shape)
    cols = np.broadcast_to(index[:, None, :], values.shape)
    return sp.coo_array((values.ravel(), (rows.ravel(), cols.ravel())), shape=(n, n)).tocsr()


def _chunks(conn: np.ndarray, entries_per_element: int) -> Iterator[slice]:
    size = max(1, _CHUNK_ENTRIES // entries_per_element)
    for start in range(0, len(conn), size):
        yield slice(start, start + size)


def _blocks(mesh: Mesh) -> Iterator[tuple[ElementType, np.ndarray]]:
    for name, conn in mesh.cells.items():
        yield element_type(name), conn


def _element_mass(etype: ElementType, coords: np.ndarray, rho: float, rule: Rule | None = None) -> np.ndarray:
    """Consistent scalar element mass matrices rho int N_a N_b dV (ne, nn, nn): exact (``ElementType.mass_rule``)
    unless another ``rule`` (reference points, weights) is given."""
    xi, w = rule or etype.mass_rule()
    N, _ = etype.shape(xi)
    _, _, detJ = _jacobians(etype, coords, xi)
    NN = (N[:, :, None] * N[:, None, :]).reshape(len(w), -1)  # one matrix product for all elements
    return (rho * (detJ * w) @ NN).reshape(len(coords), N.shape[1], N.shape[1])


def _lumped(Me: np.ndarray, lumping: str, etype: ElementType) -> np.ndarray:
    """Diagonal element masses (ne, nn) by row sums or HRZ diagonal scaling."""
    if lumping == "rowsum":
        d = Me.sum(axis=2)
        if np.any(d <= 0):
            raise ValueError(f"row-sum lumping of {etype.name} gives non-positive nodal masses; use 'hrz'")
        return d
    diag = np.einsum("enn->en", Me)
    return diag * (Me.sum(axis=(1, 2)) / diag.sum(axis=1))[:, None]


def mass_matrix(mesh: Mesh, rho: float, lumping: str | None = None,
                rules: Mapping[str, Rule] | None = None) -> sp.csr_array:
    """Scalar nodal mass matrix Ms (n x n): consistent, or lumped ('rowsum' or 'hrz'); integrated exactly, or by
    ``rules`` per cell type (another code's own, e.g. ``fe.code_rules.CALCULIX``: the mass its modes are
    normalised with)."""
    if lumping not in (None, *LUMPINGS):
        raise ValueError(f"unknown lumping {lumping!r}; expected one of {LUMPINGS}")
    n = mesh.n_nodes
    return summed((_mass_part(etype, mesh.points, conn[part], rho, lumping, (rules or {}).get(etype.name), n)
                   for etype, conn in _blocks(mesh) for part in _chunks(conn, etype.n_nodes**2)), (n, n))


def _mass_part(etype, points, c, rho, lumping, rule, n) -> sp.csr_array:
    Me = _element_mass(etype, points[c], rho, rule)
    if lumping is None:
        return scattered(Me, c, n)
    d = _lumped(Me, lumping, etype)
    return sp.coo_array((d.ravel(), (c.ravel(), c.ravel())), shape=(n, n)).tocsr()


def _element_stiffness(etype: ElementType, coords: np.ndarray, material: Material,
                       rule: Rule | None = None) -> np.ndarray:
    """Element stiffness matrices (ne, 3nn, 3nn), node-interleaved, by ``rule`` or the type's ``gauss_rule``."""
    lam, mu = material.lame
    xi, w = rule or etype.gauss_rule()
    G, detJ = element_gradients(etype, coords, xi)  # (ne, nq, nn, 3)
    ne, nq, nn, _ = G.shape
    Gf = G.reshape(ne, nq, nn * 3)
    A = np.matmul((Gf * (detJ * w)[:, :, None]).transpose(0, 2, 1), Gf).reshape(ne, nn, 3, nn, 3)
    B = np.einsum("enimi->enm", A)  # sum_q dV grad N_n . grad N_m
    K = lam * A + mu * A.transpose(0, 1, 4, 3, 2)
    K += mu * B[:, :, None, :, None] * np.eye(3)[None, None, :, None, :]
    return K.reshape(ne, 3 * nn, 3 * nn)


def stiffness_matrix(mesh: Mesh, material: Material, gauss_order: int | None = None,
                     rules: Mapping[str, Rule] | None = None) -> sp.csr_array:
    """Linear-elastic stiffness K (3n x 3n), node-interleaved DOFs; ``gauss_order`` points per direction
    instead of each element type's own rule (another code's choice, e.g. MAPDL's KEYOPT), or ``rules`` per cell
    type (``mass_matrix``)."""
    n3 = 3 * mesh.n_nodes

    def parts():
        for etype, conn in _blocks(mesh):
            etype = etype if gauss_order is None else replace(etype, gauss_order=gauss_order)
            for part in _chunks(conn, (3 * etype.n_nodes) ** 2):
                c = conn[part]
                Ke = _element_stiffness(etype, mesh.points[c], material, (rules or {}).get(etype.name))
                yield scattered(Ke, (3 * c[:, :, None] + np.arange(3)).reshape(len(c), -1), n3)
    return summed(parts(), (n3, n3))


def full_mass(Ms: sp.sparray) -> sp.csr_array:
    """Full mass matrix kron(Ms, I3) in node-interleaved order."""
    return sp.csr_array(sp.kron(Ms, sp.eye_array(3), format="csr"))
