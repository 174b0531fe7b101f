"""Nastran SOL 103 results: ``.op2`` read with pyNastran (the optional extra ``ffrf-advisor[nastran]``);
docs/format.md says what to request from Nastran.

Grids only (scalar points dropped); positions and mode components turned from each grid's CD frame to
basic (rectangular frames); the geometry from the OP2 (``PARAM,POST,-1``), else from the input deck beside
it. Eigenvalues and generalised masses from the eigenvalue table; modes scaled by the generalised masses and
checked against the 6-DOF nodal mass (theory 3b): the nodal form of MAAX punched beside the OP2
(``nastran_dmig``), else the mass assembled from the elements (``nastran_mass``). The run must be
free-free (six rigid-body modes, told by their shapes and dropped by name: ``nastran_checks``), or come with the
free body's MAAX and KAAX: then it is brought to free-free form (theory 4). Stresses: von Mises averaged at
the grids (``nastran_stress``).
"""
from __future__ import annotations

import os
from collections import Counter

import numpy as np
import scipy.sparse as sp

from ..body import FlexibleBody, ModalFE, NodalRotary, Provenance
from ..errors import BodyFileError, FFRFError
from ..fe.assembly import full_mass
from ..fe.modal import N_RIGID, mode_signs
from ..fe.mesh import Mesh
from ..transform import free_surface_ritz
from . import guard, nastran_checks, nastran_dmig, nastran_props
from .nastran_modes import NastranModes
from .nastran_mass import (NodalMass, assembled_mass, generalized_mass_error, modes_with_extra_nodes,
                           rotary_share)
from .nastran_stress import nodal_stress
from .limits import check_file_size
from .pynastran import quietly

GENMASS_TOL = 1e-4  # assembled against Nastran's generalised masses: float32 modes reach ~1e-7
FREE_K_TOL = 1e-6  # |K r| / |K| |r| of a free body's K: round-off of the punch's 16-digit fields, summed
PUNCH = (".pch", ".PCH")  # where PARAM,EXTOUT,DMIGPCH puts MAAX and KAAX
DECK = (".bdf", ".dat", ".nas", ".BDF", ".DAT", ".NAS")  # the input deck, for the geometry
DECK_FACTOR = 16  # bytes of pyNastran's card objects per byte of deck


def _load(path):
    """pyNastran's model of the OP2 with its geometry."""
    try:
        from pyNastran.op2.op2_geom import read_op2_geom
    except ImportError:
        raise FFRFError("the Nastran reader needs pyNastran: pip install 'ffrf-advisor[nastran]'") from None
    return quietly(path, "an OP2 file pyNastran can read", read_op2_geom, str(path), debug=None)


def parse(path, free_free: bool = False) -> tuple[NastranModes, NodalMass, nastran_dmig.Matrices | None]:
    """The run of ``path``, its nodal mass and the matrices punched beside it, parsed in a guarded child
    (io.guard); with ``free_free`` a run that is not free-free and cannot be transformed (no MAAX and KAAX)
    is refused before its elements are looked at. The geometry comes from the OP2, else from the input
    deck beside it (JOBNAME.bdf, .dat or .nas)."""
    check_file_size(path, 8)
    pch, deck = beside(path, PUNCH), beside(path, DECK)
    extra = sum(os.path.getsize(f) for f in (pch, deck) if f is not None)
    return guard.run(path, "pyNastran", _parse_and_assemble, path, pch, deck, free_free, extra_bytes=extra)


def beside(path, suffixes: tuple[str, ...]) -> str | None:
    """The file of the same job name beside ``path`` with one of ``suffixes``, if there is one."""
    stem = os.path.splitext(str(path))[0]
    return next((stem + s for s in suffixes if os.path.isfile(stem + s)), None)


def _parse_and_assemble(path, pch: str | None, deck: str | None, free_free: bool):
    m = _load(path)
    if not m.nodes and deck is not None:
        _geometry_from_deck(m, deck)
    run = _modes(path, m)
    mats = None if pch is None else nastran_dmig.read(pch, run.grids, _frames(path, m, run.grids))
    if free_free:
        _require_free_free(path, run, mats)
    assembled = mats is None or mats.M is None
    mass = assembled_mass(path, m, run) if assembled else nastran_dmig.nodal_form(mats.M, run.points, pch)
    mass.notes += nastran_props.checked(path, m, mass, run.points, assembled)
    return run, mass, mats


def _geometry_from_deck(m, deck: str) -> None:
    """Grids, frames, elements, properties, materials, masses and parameters of the input deck, into the OP2's
    model."""
    from pyNastran.bdf.bdf import read_bdf

    check_file_size(deck, DECK_FACTOR)
    geometry = quietly(deck, "an input deck pyNastran can read with its INCLUDE files", read_bdf, deck, xref=True,
                       validate=False, punch=not _has_bulk_section(deck))
    for name in ("nodes", "coords", "elements", "masses", "properties", "materials", "params", "spcs", "spcadds",
                 "suport", "suport1"):
        setattr(m, name, getattr(geometry, name))


def _has_bulk_section(deck: str) -> bool:
    """Whether the deck has executive and case control before BEGIN BULK (else it is bulk data only)."""
    with open(deck, "rb") as f:
        return b"BEGIN BULK" in f.read(1 << 20).upper()


def _modes(path, m) -> NastranModes:
    if not m.eigenvectors:
        raise BodyFileError(path, "eigenvectors", "mode shapes of a SOL 103 run (DISP=ALL)", "none")
    if not m.nodes:
        raise BodyFileError(path, "geometry", "grids in the OP2 (PARAM,POST,-1) or an input deck beside it", "none")
    ev = next(iter(m.eigenvectors.values()))
    grid = ev.node_gridtype[:, 1] == 1  # 2: scalar points, dropped
    gids = ev.node_gridtype[grid, 0]
    data = np.asarray(ev.data, dtype=float)[:, grid, :]  # (nm, n, 6) in each grid's CD frame
    lam = np.asarray(ev.eigns, dtype=float)
    table = next(iter(m.eigenvalues.values()), None)
    nastran_checks.check_tables(path, ev, table)
    genmass = np.ones(len(lam)) if table is None else np.asarray(table.generalized_mass, dtype=float)
    if len(genmass) != len(lam) or np.any(genmass <= 0):
        raise BodyFileError(path, "eigenvalue table", f"{len(lam)} positive generalised masses")
    points, data = _to_basic(path, m, gids, data)
    stress = nodal_stress(m, len(lam), gids)
    return NastranModes(gids, points, lam, genmass, np.moveaxis(data[:, :, :3], 0, 2),
                        np.moveaxis(data[:, :, 3:], 0, 2), None if stress is None else stress.max(axis=0),
                        dict(sorted(Counter(e.type for e in (*m.elements.values(), *m.masses.values())).items())),
                        stress, *nastran_checks.constraints(m))


def _to_basic(path, m, gids: np.ndarray, data: np.ndarray):
    """Grid positions in basic and mode components (nm, n, 6) turned from each grid's CD frame to basic."""
    missing = [g for g in gids if g not in m.nodes]
    if missing:
        raise BodyFileError(path, "geometry", "every grid of the modes in the OP2 geometry", f"grid {missing[0]}")
    points = np.array([m.nodes[g].get_position() for g in gids])
    F = _frames(path, m, gids)
    out = np.concatenate([np.einsum("kab,pkb->pka", F, data[:, :, part]) for part in (slice(0, 3), slice(3, 6))],
                         axis=2)
    return points, out


def _frames(path, m, gids: np.ndarray) -> np.ndarray:
    """Per grid, the matrix F (3 x 3) of its CD frame: a vector in basic is F times its CD components."""
    F = np.tile(np.eye(3), (len(gids), 1, 1))
    for k, g in enumerate(gids):
        cd = m.nodes[g].cd
        if cd in (0, -1):
            continue
        coord = m.coords[cd]
        if coord.type not in ("CORD1R", "CORD2R"):
            raise BodyFileError(path, f"grid {g} CD", "a rectangular output frame (or PARAM,OUGCORD,BASIC)",
                                f"{coord.type} {cd}")
        F[k] = np.asarray(coord.transform_vector_to_global(np.eye(3)), dtype=float).T
    return F


def _require_free_free(path, run: NastranModes, mats: nastran_dmig.Matrices | None) -> None:
    """A run without six rigid modes (by their shapes) refused unless the free body's MAAX and KAAX came with it;
    a run of a model with SPC (without SUPORT) refused so before its modes are looked at."""
    if mats is not None and mats.M is not None and mats.K is not None:
        return
    count = None if run.rigid_expected is None else int(nastran_checks.rigid(path, run)[0].sum())
    if count == N_RIGID:
        return
    why = (f"the run is constrained ({run.constraints}): rerun SOL 103 without constraints"
           if count is None or count < N_RIGID else "the model is not connected (a mechanism)")
    raise BodyFileError(path, "eigenvalues", "a free-free run with six rigid-body modes (theory section 1), or "
                        "the free body's MAAX and KAAX beside it (PARAM,EXTOUT,DMIGPCH) to transform the basis",
                        f"{'?' if count is None else count} of {len(run.eigenvalues)} modes rigid (by their shapes): "
                        f"{why}")


def read(path, load_fe: bool = False) -> FlexibleBody:
    """A free-free SOL 103 run as a body (t-mm-N-s assumed: Nastran files carry no units)."""
    return body_of(path, *parse(path, free_free=True))


def body_of(path, run: NastranModes, mass: NodalMass, mats: nastran_dmig.Matrices | None = None) -> FlexibleBody:
    """The body of a run: brought to free-free form when it is not (theory 4), rigid modes dropped, modes
    scaled by the generalised masses, the rotary nodes (theory 3b) kept apart, in the CoM principal frame."""
    notes = [f"Nastran {os.path.basename(str(path))}: {len(run.eigenvalues)} modes; units assumed t-mm-N-s",
             *mass.notes]
    rigid, rigid_notes = nastran_checks.rigid(path, run)
    notes += rigid_notes
    if int(rigid.sum()) != N_RIGID:
        run, note = free_surface_run(path, run, mass, mats, int(rigid.sum()))
        notes.append(note)
        rigid = np.arange(len(run.eigenvalues)) < N_RIGID  # free_surface_run puts the six rigid modes first
    flex = ~rigid
    points, T, R = modes_with_extra_nodes(run, mass)
    scale = 1 / np.sqrt(run.generalized_mass[flex])
    notes += _mass_notes(run, mass, flex)
    if mats is not None:
        notes += _matrix_notes(run, flex, scale, mass, mats)
    has_rotary = np.abs(mass.J).max(axis=(1, 2)) > 0
    rotary = NodalRotary(np.flatnonzero(has_rotary), mass.J[has_rotary], R[has_rotary][:, :, flex] * scale)
    stress = None if run.stress_nodal is None else \
        np.concatenate([run.stress_nodal, np.zeros((len(points) - len(run.grids), len(flex)))])[:, flex] * scale
    fe = ModalFE(Mesh(points, {}), mass.Ms, T[:, :, flex] * scale, stress_nodal=stress,
                 rotary=rotary if has_rotary.any() else None)
    sigma = None if run.sigma_max is None else run.sigma_max[flex] * scale
    off_diagonal = sp.csr_array(mass.Ms - sp.diags_array(mass.Ms.diagonal())).count_nonzero()
    kind = "lumped" if off_diagonal == 0 else "consistent" if mats is not None and mats.M is not None else "unknown"
    body = FlexibleBody(name=os.path.basename(str(path)).split(".")[0], integrals=fe.integrals(),
                        eigenvalues=run.eigenvalues[flex], sigma_max=sigma, fe=fe,
                        provenance=Provenance(source=str(path), mass_matrix=kind, notes=tuple(notes), digits=7))
    return body.in_principal_frame()[0]


def _mass_notes(run: NastranModes, mass: NodalMass, flex: np.ndarray) -> list[str]:
    """The rotary share and how well the nodal mass gives the generalised masses the modes are scaled by."""
    error = np.abs(generalized_mass_error(run, mass)[flex]).max()
    share = rotary_share(run, mass)[flex]
    return [*([f"rotary inertia carries up to {share.max():.1%} of a mode's modal mass (mode {share.argmax() + 1})"]
              if share.max() > 0 else []),
            f"the modes other than the rigid ones scaled by their generalised masses; {mass.what} gives them "
            f"within {error:.2g}"
            + ("" if error <= GENMASS_TOL else " (warning: more than float32 round-off: Nastran's mass differs, "
                                               "e.g. its default lumped mass of solids and shells, where "
                                               "PARAM,COUPMASS,1 or MAAX punched beside the OP2 give the mass "
                                               "the modes were computed with; or the body model cannot hold all "
                                               "of it, theory 3b)")]


def _matrix_notes(run: NastranModes, flex: np.ndarray, scale: np.ndarray, mass: NodalMass,
                  mats: nastran_dmig.Matrices) -> list[str]:
    """Checks of the run against the punched MAAX and KAAX (theory 3b, 4)."""
    V = nastran_dmig.six_dof(run.T, run.R)[:, flex] * scale
    notes = []
    if mats.M is not None:
        full = np.abs(np.einsum("ip,ip->p", V, mats.M @ V) - 1).max()
        loss = nastran_dmig.rigid_mass_loss(mats.M, mass, run.points)
        notes.append(f"{nastran_dmig.MASS} gives the generalised masses within {full:.2g}; its nodal form keeps "
                     f"its rigid-body mass within {loss:.2g}"
                     + ("" if loss <= GENMASS_TOL else " (warning: it couples DOFs the body model does not hold: "
                                                       "consistent beam mass, anisotropic nodal mass, theory 3b)"))
    if mats.K is not None:
        rayleigh = np.einsum("ip,ip->p", V, mats.K @ V)
        lam = run.eigenvalues[flex]
        notes.append(f"{nastran_dmig.STIFFNESS} gives the eigenvalues within "
                     f"{np.abs(rayleigh - lam).max() / np.abs(lam).max():.2g} (relative to the largest); "
                     "the body keeps no K (it has rotations)")
    return notes


def free_surface_run(path, run: NastranModes, mass: NodalMass, mats: nastran_dmig.Matrices | None,
                     count: int) -> tuple[NastranModes, str]:
    """A run that is not free-free brought to the form of theory section 1 with the punched MAAX and KAAX:
    its modes M-orthogonalised against the 6-DOF rigid modes, the reduced eigenproblem solved (theory 4).
    The result is six rigid modes and Ritz vectors of the free body, without modal stresses; ``count``: the run's
    rigid modes."""
    if mats is None or mats.M is None or mats.K is None:
        _require_free_free(path, run, mats)
    residual = nastran_dmig.free_body_residual(mats.K, run.points)
    if residual > FREE_K_TOL:
        raise BodyFileError(mats.source, f"DMIG {nastran_dmig.STIFFNESS}", "the stiffness of the free body "
                            f"(|K r| / |K| |r| <= {FREE_K_TOL:g} for the rigid modes r)",
                            f"{residual:.2g}: the matrices of a constrained run lack its constrained DOFs")
    n, nm = len(run.grids), len(run.eigenvalues)
    rigid6 = nastran_dmig.rigid_modes_6(run.points)
    lam, S, dropped = free_surface_ritz(mats.M, mats.K, nastran_dmig.six_dof(run.T, run.R), rigid6)
    S = S.reshape(n, 6, -1)
    S = S * mode_signs(S[:, :3].reshape(3 * n, -1), full_mass(mass.Ms[:n, :n]), run.points)
    rigid6 = rigid6.reshape(n, 6, 6)
    k = len(lam)
    out = NastranModes(run.grids, run.points, np.r_[np.zeros(N_RIGID), lam], np.ones(N_RIGID + k),
                       np.concatenate([rigid6[:, :3], S[:, :3]], axis=2),
                       np.concatenate([rigid6[:, 3:], S[:, 3:]], axis=2), None, run.element_types)
    note = (f"not free-free ({count} of {nm} modes rigid): the modes "
            f"brought to the form of theory 4 with {nastran_dmig.MASS} and {nastran_dmig.STIFFNESS}: {k} Ritz vectors "
            f"of the free body ({dropped} rigid or dependent dropped), as good as the run's modes span its modes; "
            "no modal stresses (their combination needs stress tensors)")
    return out, note
