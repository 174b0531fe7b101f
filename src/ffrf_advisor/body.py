"""The FlexibleBody data model (theory section 2): invariants, modal data, units, provenance."""
from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING

import numpy as np

from .invariants import (RotaryIntegrals, ShapeIntegrals, block_rows, frozen_array, largest_squares, principal_axes,
                         rotary_integrals, shape_integrals)
from .units import TMM, Units, factor

if TYPE_CHECKING:  # scipy.sparse and the FE modules where FE data is used: analysing a cached body needs none
    import scipy.sparse as sp

    from .fe.material import Material
    from .fe.mesh import Mesh

MASS_KINDS = ("consistent", "lumped", "unknown")
SYM_PAIRS = ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))  # the six centrifugal load cases kl (theory 9)
CASES = tuple(f"w{k + 1}w{l + 1}" for k, l in SYM_PAIRS)  # their names (theory 12)


def pair_weights(w: np.ndarray) -> np.ndarray:
    """(..., 6): ``w_k w_l``, doubled for k != l, for the load cases kl in SYM_PAIRS order (theory 9); w may
    carry leading batch axes."""
    w = np.asarray(w)
    return np.stack([w[..., k] * w[..., l] * (1 if k == l else 2) for k, l in SYM_PAIRS], axis=-1)


def pairs_at(G: np.ndarray, w: np.ndarray) -> np.ndarray:
    """``G(w) = sum_kl w_k w_l G_kl`` from the six matrices of the load cases kl (theory 9); w may carry
    leading batch axes."""
    return sum(c[..., None, None] * g for c, g in zip(np.moveaxis(pair_weights(w), -1, 0), G))


def rotated_pairs(G: np.ndarray, R: np.ndarray) -> np.ndarray:
    """Six matrices G_kl of a quadratic form in w (``G(w) = sum_kl w_k w_l G_kl``) in the frame turned by R."""
    full = np.zeros((3, 3, *G.shape[1:]))
    for c, (k, l) in enumerate(SYM_PAIRS):
        full[k, l] = full[l, k] = G[c]
    turned = np.einsum("ki,lj,kl...->ij...", R, R, full)
    return np.array([turned[k, l] for k, l in SYM_PAIRS])


@dataclass(frozen=True)
class Provenance:
    """Where a body came from and how its invariants were computed."""

    source: str = ""
    mass_matrix: str = "unknown"  # consistent | lumped | unknown
    method: str = "nodal sums with the scalar mass matrix (theory section 3)"
    notes: tuple[str, ...] = ()
    digits: int | None = None  # significant decimal digits of the source's numbers; None: double precision

    def __post_init__(self):
        if self.mass_matrix not in MASS_KINDS:
            raise ValueError(f"mass_matrix must be one of {MASS_KINDS}, got {self.mass_matrix!r}")
        if self.digits is not None and not 1 <= self.digits <= 17:
            raise ValueError(f"digits must be 1 to 17 or None, got {self.digits!r}")

    def with_note(self, note: str) -> "Provenance":
        return replace(self, notes=(*self.notes, note))


@dataclass(frozen=True)
class NodalRotary:
    """The nodes that carry rotary inertia (theory 3b): indices (k,), J_p (k, 3, 3), mode rotations (k, 3, nf)."""

    nodes: np.ndarray
    J: np.ndarray
    Phi: np.ndarray

    def __post_init__(self):
        object.__setattr__(self, "nodes", np.asarray(self.nodes, dtype=np.int64))
        for name in ("J", "Phi"):
            object.__setattr__(self, name, frozen_array(getattr(self, name)))

    def integrals(self) -> RotaryIntegrals:
        return rotary_integrals(self.J, self.Phi)

    def transformed(self, R: np.ndarray) -> "NodalRotary":
        """In axes given by the columns of R: J' = R^T J R, rotations R^T Phi*."""
        return NodalRotary(self.nodes, np.einsum("ak,iab,bl->ikl", R, self.J, R), np.einsum("ak,iap->ikp", R, self.Phi))

    def converted(self, src: Units, dst: Units) -> "NodalRotary":
        return NodalRotary(self.nodes, self.J * factor(src, dst, "inertia"),
                           self.Phi * factor(src, dst, "mode_rotation"))

    def with_modes(self, ix: np.ndarray) -> "NodalRotary":
        return NodalRotary(self.nodes, self.J, self.Phi[:, :, ix])


@dataclass(frozen=True)
class NodalSummary:
    """What the analysis needs of the nodal data, kept where they are not read (a cached body): each mode's
    largest nodal deflection per unit modal coordinate (theory 6: the deflection cap of q_max), the mesh's
    largest dimension (the checks of theory 4, the small-deformation ratio), its node count, and whether a
    stiffness matrix is stored (the basis can be transformed)."""

    max_deflection: np.ndarray
    largest_dimension: float
    n_nodes: int
    stiffness: bool

    def __post_init__(self):
        object.__setattr__(self, "max_deflection", frozen_array(self.max_deflection))

    def converted(self, src: Units, dst: Units) -> "NodalSummary":
        return replace(self, max_deflection=self.max_deflection * factor(src, dst, "mode"),
                       largest_dimension=self.largest_dimension * factor(src, dst, "length"))

    def with_modes(self, ix: np.ndarray) -> "NodalSummary":
        return replace(self, max_deflection=self.max_deflection[ix])


@dataclass(frozen=True)
class ModalFE:
    """Nodal FE data of a body: mesh, scalar mass Ms (n x n), modes Phi (n, 3, nf), optional K and stress."""

    mesh: Mesh
    Ms: sp.csr_array
    Phi: np.ndarray
    K: sp.csr_array | None = None
    stress_nodal: np.ndarray | None = None  # von Mises (n, nf) per unit modal coordinate
    material: Material | None = None        # in the body's units; with it K and stresses can be recomputed
    rotary: NodalRotary | None = None       # nodes with rotary inertia and their mode rotations (theory 3b)

    def __post_init__(self):
        object.__setattr__(self, "Phi", frozen_array(self.Phi))
        object.__setattr__(self, "stress_nodal", frozen_array(self.stress_nodal))

    def integrals(self) -> ShapeIntegrals:
        """The shape integrals of theory section 3 by nodal sums, with the rotary sums of 3b."""
        return shape_integrals(self.mesh.points, self.Ms, self.Phi,
                               None if self.rotary is None else self.rotary.integrals())

    def max_deflection(self) -> np.ndarray:
        """Largest nodal displacement magnitude of each mode at unit modal coordinate (nf,), over blocks of
        nodal rows (no temporary the size of Phi)."""
        rows = block_rows(self.Phi.shape[2])
        return np.sqrt(np.max([largest_squares(self.Phi[a:a + rows]) for a in range(0, len(self.Phi), rows)],
                              axis=0))

    def summary(self) -> NodalSummary:
        return NodalSummary(self.max_deflection(), self.mesh.largest_dimension(), self.mesh.n_nodes, self.K is not None)

    def transformed(self, c: np.ndarray, R: np.ndarray) -> "ModalFE":
        """Points x' = R^T (x - c), mode components S' = R^T S, K' = T^T K T with T = kron(1, R)."""
        mesh = replace(self.mesh, points=(self.mesh.points - c) @ R, cells=dict(self.mesh.cells))
        Phi = np.einsum("ak,iap->ikp", R, self.Phi)
        K = self.K
        if K is not None:
            import scipy.sparse as sp
            T = sp.kron(sp.eye_array(self.mesh.n_nodes), R, format="csr")
            K = sp.csr_array(T.T @ K @ T)
        rotary = None if self.rotary is None else self.rotary.transformed(R)
        return replace(self, mesh=mesh, Phi=Phi, K=K, rotary=rotary)

    def converted(self, src: Units, dst: Units) -> "ModalFE":
        mesh = replace(self.mesh, points=self.mesh.points * factor(src, dst, "length"), cells=dict(self.mesh.cells))
        return ModalFE(
            mesh=mesh,
            Ms=self.Ms * factor(src, dst, "mass"),
            Phi=self.Phi * factor(src, dst, "mode"),
            K=None if self.K is None else self.K * factor(src, dst, "stiffness"),
            stress_nodal=None if self.stress_nodal is None
            else self.stress_nodal * factor(src, dst, "modal_stress"),
            material=None if self.material is None else replace(
                self.material, E=self.material.E * factor(src, dst, "stress"),
                rho=self.material.rho * factor(src, dst, "density")),
            rotary=None if self.rotary is None else self.rotary.converted(src, dst),
        )


def _per_mode(a: np.ndarray | None, ix: np.ndarray, axes: int) -> np.ndarray | None:
    """``a`` with its last axis (axes = 1) or last two axes (axes = 2, mode x mode) taken at ``ix``."""
    if a is None:
        return None
    return a[..., ix] if axes == 1 else a[..., ix, :][..., ix]


def _permutation(R: np.ndarray) -> bool:
    """R only swaps or flips axes (a box's extents are then the same numbers)."""
    P = np.abs(R)
    return bool(np.allclose(P, np.round(P), atol=1e-9))


@dataclass(frozen=True)
class StaticCentrifugal:
    """Exact static centrifugal response per principal axis at unit spin (theory 11; ``centrifugal``): the
    compliance f^T u [energy time^4] and the largest von Mises stress of u [stress time^2]. Depends on the
    FE model only, not on the kept modes."""

    compliance: np.ndarray
    sigma: np.ndarray

    def __post_init__(self):
        object.__setattr__(self, "compliance", frozen_array(self.compliance))
        object.__setattr__(self, "sigma", frozen_array(self.sigma))

    def converted(self, src: Units, dst: Units) -> "StaticCentrifugal":
        return StaticCentrifugal(self.compliance * factor(src, dst, "compliance_per_spin4"),
                                 self.sigma * factor(src, dst, "stress_per_spin2"))

    def permuted(self, R: np.ndarray) -> "StaticCentrifugal | None":
        """The values for the frame turned by R when R only swaps or flips axes, else None (recompute)."""
        if not _permutation(R):
            return None
        ix = np.argmax(np.abs(R), axis=0)  # new axis j is old axis ix[j]
        return StaticCentrifugal(self.compliance[ix], self.sigma[ix])


@dataclass(frozen=True)
class FlexibleBody:
    """One flexible body: shape integrals, eigenvalues lambda_p = Omega_p^2, modal stress, units.

    ``sigma_max[p]`` is the largest von Mises stress of mode p at unit modal
    coordinate (theory section 6), in the body's stress units per unit q.
    """

    name: str
    integrals: ShapeIntegrals
    eigenvalues: np.ndarray
    units: Units = TMM
    sigma_max: np.ndarray | None = None
    provenance: Provenance = field(default_factory=Provenance)
    fe: ModalFE | None = None
    static_centrifugal: StaticCentrifugal | None = None  # theory 11, from FE data
    geometric: np.ndarray | None = None  # (6, nf, nf) modal geometric stiffness per unit spin^2 (theory 9)
    nodal: NodalSummary | None = None  # the nodal data's summary where ``fe`` was not read (``nodal_summary``)

    def __post_init__(self):
        object.__setattr__(self, "eigenvalues", frozen_array(self.eigenvalues))
        object.__setattr__(self, "sigma_max", frozen_array(self.sigma_max))
        nf = self.integrals.nf
        if self.eigenvalues.shape != (nf,):
            raise ValueError(f"eigenvalues: expected shape ({nf},), got {self.eigenvalues.shape}")
        if self.sigma_max is not None and self.sigma_max.shape != (nf,):
            raise ValueError(f"sigma_max: expected shape ({nf},), got {self.sigma_max.shape}")
        object.__setattr__(self, "geometric", frozen_array(self.geometric))
        if self.geometric is not None and self.geometric.shape != (6, nf, nf):
            raise ValueError(f"geometric: expected shape (6, {nf}, {nf}), got {self.geometric.shape}")
        if self.fe is not None and self.fe.Phi.shape[2] != nf:
            raise ValueError(f"modes: expected {nf} modes, got {self.fe.Phi.shape[2]}")
        if self.nodal is not None and self.nodal.max_deflection.shape != (nf,):
            raise ValueError(f"nodal max_deflection: expected shape ({nf},), got {self.nodal.max_deflection.shape}")

    # --- derived quantities -------------------------------------------------
    @property
    def nf(self) -> int:
        return self.integrals.nf

    @property
    def mass(self) -> float:
        return self.integrals.mass

    @property
    def com(self) -> np.ndarray:
        return self.integrals.com

    @property
    def I0(self) -> np.ndarray:
        return self.integrals.I0()

    @property
    def W1(self) -> np.ndarray:
        return self.integrals.W1()

    @property
    def W2(self) -> np.ndarray:
        return self.integrals.W2()

    @property
    def W3(self) -> np.ndarray:
        return self.integrals.W3()

    @property
    def frequencies_hz(self) -> np.ndarray:
        """Eigenfrequencies sqrt(lambda_p) / (2 pi), in 1/time unit of the body."""
        return np.sqrt(np.abs(self.eigenvalues)) * np.sign(self.eigenvalues) / (2 * np.pi)

    def nodal_summary(self) -> NodalSummary | None:
        """The nodal data's summary: from ``fe`` when it was read, else as the file cached it, else None."""
        return self.fe.summary() if self.fe is not None else self.nodal

    def largest_dimension(self) -> float:
        """Largest extent of the mesh, or of the box with the same mass and principal inertia."""
        if self.fe is not None:
            return self.fe.mesh.largest_dimension()
        if self.nodal is not None:
            return self.nodal.largest_dimension
        return float(self.equivalent_box().max())

    def equivalent_box(self) -> np.ndarray:
        """Edges of the solid box with the body's mass and principal second moments about its CoM; nodal rotary
        inertia (theory 3b: a shell's fibres, a beam's section) counts as the second moments S = tr(I0)/2 - I0 it
        adds (a flat shell would otherwise be a box of zero thickness)."""
        J = self.integrals.shifted(self.com)
        S = J.I if J.rotary is None else np.trace(J.I0()) / 2 * np.eye(3) - J.I0()
        return np.sqrt(12 * np.clip(np.linalg.eigvalsh(S), 0, None) / self.mass)

    # --- transformations ----------------------------------------------------
    def in_principal_frame(self) -> tuple["FlexibleBody", np.ndarray, np.ndarray]:
        """The body with its frame moved to the CoM and turned to the principal axes (theory section 4).

        Returns (body, c, R): old CoM position c and the rotation R whose
        columns are the new axes in the old frame.
        """
        c = self.com
        shifted = self.integrals.shifted(c)
        R = principal_axes(shifted.I0())
        fe = None if self.fe is None else self.fe.transformed(c, R)
        moved = np.linalg.norm(c) > 1e-9 * self.largest_dimension()
        static = None if self.static_centrifugal is None or moved else self.static_centrifugal.permuted(R)
        geo = None if self.geometric is None or moved else rotated_pairs(self.geometric, R)
        nodal = self.nodal if fe is None and _permutation(R) else None  # extents are those of the file's axes
        body = replace(self, integrals=shifted.rotated(R), fe=fe, static_centrifugal=static, geometric=geo,
                       nodal=nodal)
        return body, c, R

    def moved_to_principal_frame(self) -> "FlexibleBody":
        """``in_principal_frame``'s body, its provenance noting where the frame moved and how it turned."""
        body, c, R = self.in_principal_frame()
        note = (f"transformed from the file's frame: origin moved to the CoM at "
                f"[{', '.join(f'{x:.6g}' for x in c)}] {self.units.length}, axes turned to the principal axes "
                f"(rotation rows {'; '.join(' '.join(f'{x:.6f}' for x in row) for row in R.T)})")
        return replace(body, provenance=body.provenance.with_note(note))

    def first_modes(self, nf: int) -> "FlexibleBody":
        """The body with its first ``nf`` modes only (every quantity per mode truncated alike)."""
        if not 1 <= nf <= self.nf:
            raise ValueError(f"first_modes: expected 1 to {self.nf} modes, got {nf}")
        return self.with_modes(np.arange(nf))

    def with_modes(self, index) -> "FlexibleBody":
        """The body with the modes ``index`` (a selection or a reordering), every per-mode quantity alike."""
        ix = np.asarray(index, dtype=int)
        ints = self.integrals
        take = lambda a, axes: _per_mode(a, ix, axes)  # noqa: E731
        integrals = replace(ints, Ibar=take(ints.Ibar, 1), mode_sum=take(ints.mode_sum, 1),
                            Sbar=take(ints.Sbar, 2), spin=take(ints.spin, 2),
                            rotary=None if ints.rotary is None else ints.rotary.with_modes(ix))
        fe = None if self.fe is None else replace(
            self.fe, Phi=self.fe.Phi[:, :, ix], stress_nodal=take(self.fe.stress_nodal, 1),
            rotary=None if self.fe.rotary is None else self.fe.rotary.with_modes(ix))
        return replace(self, integrals=integrals, eigenvalues=self.eigenvalues[ix],
                       sigma_max=take(self.sigma_max, 1), fe=fe, geometric=take(self.geometric, 2),
                       nodal=None if self.nodal is None else self.nodal.with_modes(ix))

    def converted(self, units: Units) -> "FlexibleBody":
        """The same body in other units; every conversion factor is exact up to one rounding."""
        src = self.units
        return replace(
            self,
            units=units,
            integrals=self.integrals.converted(src, units),
            eigenvalues=self.eigenvalues * factor(src, units, "eigenvalue"),
            sigma_max=None if self.sigma_max is None else self.sigma_max * factor(src, units, "modal_stress"),
            fe=None if self.fe is None else self.fe.converted(src, units),
            static_centrifugal=None if self.static_centrifugal is None
            else self.static_centrifugal.converted(src, units),
            nodal=None if self.nodal is None else self.nodal.converted(src, units),
        )
