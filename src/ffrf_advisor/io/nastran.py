"""Nastran SOL 103 results: ``.op2`` written with ``PARAM,POST,-1`` (geometry included), read with pyNastran
(the optional extra ``ffrf-advisor[nastran]``); docs/format.md says what to request from Nastran.

Grids only (scalar points dropped); positions and mode components turned from each grid's CD frame to
basic (rectangular frames). Eigenvalues and generalised masses from the eigenvalue table; modes scaled by
the generalised mass and checked against the mass assembled here (theory 3b):
- CONM2: mass and inertia at its CG (an offset CG becomes a node moving rigidly with its grid);
- CBAR, CBEAM, CROD, CONROD, CTUBE: half the element mass (with non-structural mass) at each end; CBEAM
  also half its torsional inertia rho J L about its axis;
- CQUAD4, CQUADR, CQUAD8, CTRIA3, CTRIAR, CTRIA6: the element mass shared equally by its nodes;
- CHEXA with 8 or 20 nodes: the consistent mass of the FE module;
- springs, dampers and rigid elements carry no mass; any other element is refused by name.
The run must be free-free (six rigid-body modes, which are dropped). Stresses: the largest element von
Mises stress per mode (bars and beams: the largest fibre stress |smax|, |smin|).
"""
from __future__ import annotations

import contextlib
import io
import os
import warnings
from collections import Counter
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from ..body import FlexibleBody, ModalFE, NodalRotary, Provenance
from ..errors import BodyFileError, FFRFError
from ..fe.assembly import mass_matrix
from ..fe.mesh import Mesh
from . import Format, guard, register
from .limits import check_file_size

RIGID_TOL = 1e-6   # |lambda| / largest |lambda| below which a mode is rigid ...
RIGID_HZ = 1e-2    # ... or a frequency below this (a run whose modes are all ~0)
N_RIGID = 6
GENMASS_TOL = 1e-4  # assembled against Nastran's generalised masses: float32 modes reach ~1e-7
LINES = ("CBAR", "CBEAM", "CROD", "CONROD", "CTUBE")
SHELLS = ("CQUAD4", "CQUADR", "CQUAD8", "CTRIA3", "CTRIAR", "CTRIA6")
MASSLESS = ("CELAS1", "CELAS2", "CELAS3", "CELAS4", "CDAMP1", "CDAMP2", "CDAMP3", "CDAMP4", "CVISC", "CBUSH",
            "CBUSH1D", "CGAP", "PLOTEL")
HEX20 = list(range(12)) + list(range(16, 20)) + list(range(12, 16))  # Nastran CHEXA20 -> VTK node order


@dataclass
class NastranModes:
    """A parsed SOL 103 run, in basic coordinates, before any requirement on it."""

    grids: np.ndarray        # (n,) grid ids
    points: np.ndarray       # (n, 3)
    eigenvalues: np.ndarray  # (nm,)
    generalized_mass: np.ndarray  # (nm,)
    T: np.ndarray            # (n, 3, nm) translations
    R: np.ndarray            # (n, 3, nm) rotations
    sigma_max: np.ndarray | None
    element_types: dict[str, int]


def _pynastran():
    try:
        from pyNastran.op2.op2_geom import read_op2_geom
    except ImportError:
        raise FFRFError("the Nastran reader needs pyNastran: pip install 'ffrf-advisor[nastran]'") from None
    return read_op2_geom


def _load(path):
    """pyNastran's model of the OP2 with its geometry, its log and warnings silenced (ours is one line)."""
    read_op2_geom = _pynastran()
    from cpylog import SimpleLogger

    try:
        with warnings.catch_warnings(), contextlib.redirect_stdout(io.StringIO()), \
                contextlib.redirect_stderr(io.StringIO()):
            warnings.simplefilter("ignore")
            return read_op2_geom(str(path), debug=None, log=SimpleLogger(level="critical"))
    except (Exception, SystemExit) as e:  # pyNastran raises many kinds on a damaged file (struct, assertions)
        raise BodyFileError(path, "file", "an OP2 file pyNastran can read",
                            f"{type(e).__name__}: {' '.join(str(e).split())[:160]}") from None


def parse(path, free_free: bool = False) -> tuple[NastranModes, "AssembledMass"]:
    """The run of ``path`` and its assembled mass, parsed in a guarded child (io.guard); with ``free_free``
    a run without exactly six rigid-body modes is refused before its elements are looked at."""
    check_file_size(path, 8)
    return guard.run(path, "pyNastran", _parse_and_assemble, path, free_free)


def _parse_and_assemble(path, free_free: bool):
    m = _load(path)
    run = _modes(path, m)
    if free_free:
        _require_free_free(path, run.eigenvalues)
    return run, assembled_mass(path, m, run)


def _modes(path, m) -> NastranModes:
    if not m.eigenvectors:
        raise BodyFileError(path, "eigenvectors", "mode shapes of a SOL 103 run (DISP=ALL)", "none")
    if not m.nodes:
        raise BodyFileError(path, "geometry", "grids in the OP2 (PARAM,POST,-1)", "none")
    ev = next(iter(m.eigenvectors.values()))
    grid = ev.node_gridtype[:, 1] == 1  # 2: scalar points, dropped
    gids = ev.node_gridtype[grid, 0]
    data = np.asarray(ev.data, dtype=float)[:, grid, :]  # (nm, n, 6) in each grid's CD frame
    lam = np.asarray(ev.eigns, dtype=float)
    table = next(iter(m.eigenvalues.values()), None)
    genmass = np.ones(len(lam)) if table is None else np.asarray(table.generalized_mass, dtype=float)
    if len(genmass) != len(lam) or np.any(genmass <= 0):
        raise BodyFileError(path, "eigenvalue table", f"{len(lam)} positive generalised masses")
    points, data = _to_basic(path, m, gids, data)
    return NastranModes(gids, points, lam, genmass, np.moveaxis(data[:, :, :3], 0, 2),
                        np.moveaxis(data[:, :, 3:], 0, 2), _stress_max(m, len(lam)),
                        dict(sorted(Counter(e.type for e in (*m.elements.values(), *m.masses.values())).items())))


def _to_basic(path, m, gids: np.ndarray, data: np.ndarray):
    """Grid positions in basic and mode components turned from each grid's CD frame to basic."""
    missing = [g for g in gids if g not in m.nodes]
    if missing:
        raise BodyFileError(path, "geometry", "every grid of the modes in the OP2 geometry", f"grid {missing[0]}")
    points = np.array([m.nodes[g].get_position() for g in gids])
    out = data.copy()
    for k, g in enumerate(gids):
        cd = m.nodes[g].cd
        if cd in (0, -1):
            continue
        coord = m.coords[cd]
        if coord.type not in ("CORD1R", "CORD2R"):
            raise BodyFileError(path, f"grid {g} CD", "a rectangular output frame (or PARAM,OUGCORD,BASIC)",
                                f"{coord.type} {cd}")
        for part in (slice(0, 3), slice(3, 6)):
            out[:, k, part] = coord.transform_vector_to_global(data[:, k, part])
    return points, out


def _stress_max(m, nm: int) -> np.ndarray | None:
    """Per mode, the largest element von Mises stress (bars, beams: the largest |fibre stress|)."""
    best = None
    stress = m.op2_results.stress
    for name in stress.get_table_types():
        for obj in getattr(stress, name.split(".")[-1]).values():
            headers = obj.get_headers()
            cols = [headers.index(h) for h in ("von_mises", "ovm") if h in headers] or \
                   [headers.index(h) for h in ("smax", "smin", "smaxa", "smina", "smaxb", "sminb") if h in headers]
            if not cols or obj.data.shape[0] != nm:
                continue
            value = np.abs(np.asarray(obj.data, dtype=float)[:, :, cols]).max(axis=(1, 2))
            best = value if best is None else np.maximum(best, value)
    return best


# ---------------------------------------------------------------- mass (theory 3b)
@dataclass
class AssembledMass:
    """Scalar translational mass over the grids (+ offset CG nodes), nodal rotary inertia, extra nodes."""

    Ms: sp.csr_array
    J: np.ndarray                 # (n + k, 3, 3)
    extra_points: np.ndarray      # (k, 3) CG of offset CONM2s
    extra_of: np.ndarray          # (k,) the grid index each moves with
    notes: list[str]


def assembled_mass(path, m, run: NastranModes) -> AssembledMass:
    """The mass of the elements and point masses of ``m`` over the grids of ``run`` (theory 3b)."""
    index = {int(g): i for i, g in enumerate(run.grids)}
    n = len(run.grids)
    diag, J = np.zeros(n), np.zeros((n, 3, 3))
    solids = _element_mass(path, m, run, index, diag, J)
    extra = _point_masses(path, m, run, index, diag, J)
    k = len(extra)
    Ms = sp.diags_array(np.concatenate([diag, [e[2] for e in extra]])).tocsr()
    for (cell, rho), conns in solids.items():
        hexes = Mesh(run.points, {cell: np.array(conns)})
        Ms = Ms + sp.block_diag([mass_matrix(hexes, rho), sp.csr_array((k, k))]).tocsr()
    notes = [f"mass assembled from {', '.join(f'{v} {t}' for t, v in run.element_types.items())}"
             + (f"; {k} CONM2 with an offset CG as nodes moving rigidly with their grid" if k else "")]
    return AssembledMass(sp.csr_array(Ms), np.concatenate([J, np.array([e[3] for e in extra]).reshape(k, 3, 3)]),
                         np.array([e[0] for e in extra]).reshape(k, 3), np.array([e[1] for e in extra], np.int64),
                         notes)


def _element_mass(path, m, run: NastranModes, index: dict, diag: np.ndarray, J: np.ndarray) -> dict:
    """Lumped line and shell masses into ``diag`` and ``J``; the CHEXA connectivities by (cell type, rho)."""
    refused = sorted({e.type for e in m.elements.values()} - set(LINES) - set(SHELLS) - set(MASSLESS) - {"CHEXA"})
    if refused:
        raise BodyFileError(path, "elements", "element types whose mass the reader assembles (docs/format.md)",
                            ", ".join(refused))
    solids: dict[tuple[str, float], list] = {}
    for e in m.elements.values():
        if e.type in MASSLESS:
            continue
        nodes = [index[g] for g in e.node_ids if g is not None]
        if e.type == "CHEXA":
            _hexa(path, e, nodes, solids)
        elif e.type in LINES:
            a, b = nodes[:2]
            diag[[a, b]] += float(e.Mass()) / 2
            if e.type == "CBEAM":  # half the torsional inertia rho J L at each end, about the axis
                axis = (run.points[b] - run.points[a]) / e.Length()
                torsion = e.pid_ref.mid_ref.rho * np.atleast_1d(e.pid_ref.J())[0] * e.Length() / 2
                J[[a, b]] += torsion * np.outer(axis, axis)
        else:
            diag[nodes] += float(e.Mass()) / len(nodes)
    return solids


def _point_masses(path, m, run: NastranModes, index: dict, diag: np.ndarray, J: np.ndarray) -> list[tuple]:
    """CONM2 at their grid into ``diag`` and ``J``; those with an offset CG as (CG, grid index, mass, inertia)."""
    extra = []
    for c in m.masses.values():
        if c.type != "CONM2":
            raise BodyFileError(path, "masses", "CONM2 point masses", c.type)
        i = index[c.nid]
        cg, inertia = np.asarray(c.Centroid(), dtype=float), np.asarray(c.Inertia(), dtype=float)
        if np.linalg.norm(cg - run.points[i]) <= 1e-12 * max(1.0, np.abs(run.points).max()):
            diag[i] += c.mass
            J[i] += inertia
        else:
            extra.append((cg, i, c.mass, inertia))
    return extra


def _hexa(path, e, nodes: list[int], solids: dict) -> None:
    if len(nodes) not in (8, 20):
        raise BodyFileError(path, f"CHEXA {e.eid}", "8 or 20 nodes", str(len(nodes)))
    cell = "hexahedron" if len(nodes) == 8 else "hexahedron20"
    order = nodes if len(nodes) == 8 else [nodes[i] for i in HEX20]
    solids.setdefault((cell, float(e.pid_ref.mid_ref.rho)), []).append(order)


# ---------------------------------------------------------------- the body
def modes_with_extra_nodes(run: NastranModes, mass: AssembledMass) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Points, translations and rotations with the offset-CG nodes appended: u = u_g + theta_g x (x - x_g)."""
    g = mass.extra_of
    arm = mass.extra_points - run.points[g]
    T = np.concatenate([run.T, run.T[g] + np.cross(run.R[g], arm[:, :, None], axisa=1, axisb=1, axisc=1)])
    return np.concatenate([run.points, mass.extra_points]), T, np.concatenate([run.R, run.R[g]])


def modal_mass_parts(run: NastranModes, mass: AssembledMass) -> tuple[np.ndarray, np.ndarray]:
    """Per mode of the file, the translational sum Phi^T Ms Phi and the rotary sum Phi*^T J Phi* (theory 3b)."""
    _, T, R = modes_with_extra_nodes(run, mass)
    n, _, nm = T.shape
    trans = np.einsum("iap,iap->p", T, (mass.Ms @ T.reshape(n, 3 * nm)).reshape(n, 3, nm))
    return trans, np.einsum("iap,iab,ibp->p", R, mass.J, R)


def generalized_mass_error(run: NastranModes, mass: AssembledMass) -> np.ndarray:
    """Per mode, (assembled modal mass) / (Nastran's generalised mass) - 1."""
    trans, rot = modal_mass_parts(run, mass)
    return (trans + rot) / run.generalized_mass - 1


def rotary_share(run: NastranModes, mass: AssembledMass) -> np.ndarray:
    """Per mode, the share of the modal mass that is rotary inertia (1 for a pure torsion of beam nodes)."""
    trans, rot = modal_mass_parts(run, mass)
    return np.divide(rot, trans + rot, out=np.zeros_like(rot), where=trans + rot > 0)


def rigid(lam: np.ndarray) -> np.ndarray:
    return (np.abs(lam) < RIGID_TOL * np.abs(lam).max()) | (np.sqrt(np.abs(lam)) / (2 * np.pi) < RIGID_HZ)


def _require_free_free(path, lam: np.ndarray) -> None:
    count = int(rigid(lam).sum())
    if count != N_RIGID:
        why = ("the run is constrained (SPCs or a grounded model): rerun SOL 103 without constraints"
               if count < N_RIGID else "the model is not connected (a mechanism)")
        raise BodyFileError(path, "eigenvalues", "a free-free run with six rigid-body modes (theory section 1)",
                            f"{count} of {len(lam)} modes below {RIGID_HZ:g} Hz: {why}")


def read(path, load_fe: bool = False) -> FlexibleBody:
    """A free-free SOL 103 run as a body (t-mm-N-s assumed: Nastran files carry no units)."""
    return body_of(path, *parse(path, free_free=True))


def body_of(path, run: NastranModes, mass: AssembledMass) -> FlexibleBody:
    """The body of a free-free run: rigid modes dropped, modes scaled by the generalised masses, the rotary
    nodes (theory 3b) kept apart, in the CoM principal frame."""
    flex = ~rigid(run.eigenvalues)
    points, T, R = modes_with_extra_nodes(run, mass)
    scale = 1 / np.sqrt(run.generalized_mass[flex])
    error = generalized_mass_error(run, mass)[flex]
    share = rotary_share(run, mass)[flex]
    notes = [f"Nastran {os.path.basename(str(path))}: {len(run.eigenvalues)} modes, six rigid dropped; "
             "units assumed t-mm-N-s", *mass.notes,
             *([f"rotary inertia carries up to {share.max():.1%} of a mode's modal mass (mode {share.argmax() + 1})"]
               if share.max() > 0 else []),
             f"modes scaled by Nastran's generalised masses; the assembled mass gives them within "
             f"{np.abs(error).max():.2g}" + ("" if np.abs(error).max() <= GENMASS_TOL else
                                            " (warning: more than float32 round-off: Nastran's mass differs)")]
    has_rotary = np.abs(mass.J).max(axis=(1, 2)) > 0
    rotary = NodalRotary(np.flatnonzero(has_rotary), mass.J[has_rotary], R[has_rotary][:, :, flex] * scale)
    fe = ModalFE(Mesh(points, {}), mass.Ms, T[:, :, flex] * scale, rotary=rotary if has_rotary.any() else None)
    sigma = None if run.sigma_max is None else run.sigma_max[flex] * scale
    body = FlexibleBody(name=os.path.basename(str(path)).split(".")[0], integrals=fe.integrals(),
                        eigenvalues=run.eigenvalues[flex], sigma_max=sigma, fe=fe,
                        provenance=Provenance(source=str(path), mass_matrix="lumped" if "CHEXA" not in
                                              run.element_types else "unknown", notes=tuple(notes), digits=7))
    return body.in_principal_frame()[0]


register(Format("nastran", (".op2",), read))
