"""ANSYS MAPDL modal results: ``JOB.rst`` with ``JOB.full`` beside it, read with ansys-mapdl-reader (the
optional extra ``ffrf-advisor[ansys]``), each file in a guarded reading child of its own (io.guard);
docs/format.md says what to request.

Nodes, solid elements (SOLID185/186 bricks and their degenerate prisms, pyramids and tetrahedra, SOLID187;
MASS21 without rotary inertia is carried by the .full's M; ``ansys_cells``), eigenvalues, modes (UX, UY, UZ)
and the elements' corner stresses from the .rst; the mass M (checked against the elements' own on its nodal
sums) and stiffness K from the .full. Units from /UNITS, a ``units`` option or the
materials (``ansys_units``). K is the free body's when the .full's is free; a .full written with
constraints lacks their couplings, and then the elements' own stiffness is used where it reproduces the
.full's on every other DOF (``ansys_fe``). Modes that are eigenvectors of the free body are taken as they
are (rigid modes, told by their shapes, dropped by name); others are brought to free-free form (theory 4),
which needs the free K.
"""
from __future__ import annotations

import os
from dataclasses import replace

import numpy as np

from ..body import FlexibleBody, Provenance
from ..errors import BodyFileError
from ..fe.mesh import Mesh
from ..fe.modal import N_RIGID, mode_signs, rigid_modes
from ..fe_body import fe_body, mass_normalised_file_modes, with_centrifugal_response
from ..transform import free_surface_ritz
from . import ansys_files, guard
from .rigid_modes import rigid_modes_of
from .ansys_fe import free_stiffness, mass_agreement, material_of, nodal_von_mises, scalar_mass
from .ansys_files import AnsysRun
from .ansys_units import UnitChoice, choose
from .limits import check_file_size

EIGEN_TOL = 1e-4  # |K phi - lambda M phi| / |K phi| of a free body's mode: Block Lanczos leaves ~1e-6 (the example:
# 9e-7), a mode of another problem (constrained, another mesh) is off by order 1
FULL = (".full", ".FULL")


def read(path, load_fe: bool = False, units: str | None = None) -> FlexibleBody:
    """An MAPDL modal run as a body; ``units`` (an MAPDL /UNITS name or 't-mm-N-s') where the file has none."""
    return body_of(path, parse(path), units)


def parse(path) -> AnsysRun:
    """The run of ``path`` and the M and K of the .full beside it, each file read in a guarded child (io.guard)."""
    stem = os.path.splitext(str(path))[0]
    full = next((stem + s for s in FULL if os.path.isfile(stem + s)), None)
    if full is None:
        raise BodyFileError(path, ".full", f"{os.path.basename(stem)}.full beside it (the run's mass and "
                            "stiffness; docs/format.md)", "missing")
    check_file_size(path)
    check_file_size(full)
    ansys_files.library()  # imported once, here: the children share it
    run = guard.run(path, "ansys-mapdl-reader", ansys_files.load_result, str(path))
    M, K, held = guard.run(full, "ansys-mapdl-reader", ansys_files.load_matrices, full, run.nodes)
    return replace(run, full=full, M=M, K=K, constrained=held)


def body_of(path, run: AnsysRun, units: str | None = None) -> FlexibleBody:
    """The body of a run in its units (theory 1-4): its free modes as they are, or its modes brought to
    free-free form with the free K; the static centrifugal response and G where K and the material allow."""
    materials = [(d["EX"], d["DENS"]) for m, d in run.materials.items()
                 if m in run.cell_materials and d.get("EX", 0) > 0 and d.get("DENS", 0) > 0]
    choice = choose(path, run.units, materials, units)
    run = _scaled(run, choice)
    Ms, mesh = scalar_mass(run), Mesh(run.points, run.cells)
    mass_note = mass_agreement(run, Ms, choice.length, choice.mass)  # first: it refuses inverted elements
    material, material_note = material_of(run, choice.length, choice.mass)
    K, stiffness_note = free_stiffness(run, mesh, material)
    rigid, rigid_notes = _rigid(run)
    lam, Phi, stress, modes_note = _modes(run, rigid, Ms, K, stiffness_note, choice)
    n = len(run.points)
    notes = (f"MAPDL {os.path.basename(str(path))} with {os.path.basename(run.full)}: {len(run.eigenvalues)} modes, "
             f"{n} nodes, {', '.join(f'{v} {t}' for t, v in run.element_types.items())}; cells "
             f"{', '.join(f'{len(c)} {t}' for t, c in mesh.cells.items()) or 'none'}", choice.note, material_note,
             stiffness_note, modes_note, mass_note,
             "modal von Mises stress from the corner stresses, averaged at the nodes" if stress is not None else
             "no modal stresses (no element stresses in the .rst)", *rigid_notes)
    kept = None if K is None else material  # the static response needs the K the modes belong to
    body = fe_body(os.path.basename(str(path)).split(".")[0], mesh, Ms, Phi, lam,
                   Provenance(source=str(path), mass_matrix="consistent" if run.M.nnz > 3 * n else "lumped",
                              notes=notes), K, stress, kept, choice.units)
    return body if kept is None else with_centrifugal_response(body)


def _rigid(run: AnsysRun) -> tuple[np.ndarray, list[str]]:
    """The run's rigid modes by their shapes (io.rigid_modes): six for a run whose .full holds no
    D constraint, any count (warned when not six) for one that does."""
    held = int(run.constrained.sum())
    where = (f"{held} DOFs held by D in {os.path.basename(run.full)}" if held else
             f"no DOF held in {os.path.basename(run.full)}: a free run")
    return rigid_modes_of(run.source, run.points, run.modes, run.eigenvalues, None if held else N_RIGID, where,
                          "NSL (mode shapes)")


def _modes(run: AnsysRun, rigid: np.ndarray, Ms, K, why: str, choice: UnitChoice):
    """Eigenvalues, mass-normalised modes, nodal stresses and a note: the run's flexible modes (not ``rigid``) when
    they are the free body's (or, without K, when the run has the six rigid modes), else its modes brought to
    free-free form."""
    flex = ~rigid
    count = int(rigid.sum())
    if not flex.any():
        raise BodyFileError(run.source, "eigenvalues", "at least one flexible mode", "only rigid modes")
    residual = _eigen_residual(run, K, flex)
    if residual is None and count != N_RIGID:
        raise BodyFileError(run.full, "stiffness matrix", "the free body's K to check or transform a run without "
                            f"six rigid modes (theory 4; it has {count})", why)
    if residual is not None and residual > EIGEN_TOL:
        return _ritz(run, K, count, residual)
    Phi, stress, scale = mass_normalised_file_modes(Ms, run.modes[:, :, flex],
                                                    nodal_von_mises(run, np.eye(len(flex))[:, flex]), run.points)
    modal_mass = scale**2 / (choice.length**2 * choice.mass)  # in the file's units
    rigid_part = ("six rigid modes dropped" if count == N_RIGID else
                  f"{count} rigid modes dropped" if count else "no rigid modes in the run")
    check = "" if residual is None else f"; the modes are the free body's (|K phi - lambda M phi| / |K phi| <= " \
                                        f"{residual:.2g})"
    return run.eigenvalues[flex], Phi, stress, (
        f"free-free: {rigid_part}{check}; the others scaled to unit modal mass with the .full's M (the file's are "
        f"within {np.abs(modal_mass - 1).max():.2g} of 1)")


def _scaled(run: AnsysRun, choice: UnitChoice) -> AnsysRun:
    """The run in the body's units: lengths, masses, stiffness and stresses scaled (time is the second)."""
    L, m = choice.length, choice.mass
    if (L, m) == (1.0, 1.0):
        return run
    stress = None if run.corner_stress is None else {t: s * np.float32(m / L) for t, s in run.corner_stress.items()}
    return replace(run, points=run.points * L, modes=run.modes * L, corner_stress=stress, M=run.M * m, K=run.K * m)


def _eigen_residual(run: AnsysRun, K, flex: np.ndarray) -> float | None:
    """max over the flexible modes of |K phi - lambda M phi| / |K phi| (None without K)."""
    if K is None:
        return None
    Phi = run.modes[:, :, flex].reshape(-1, int(flex.sum()))
    KPhi = K @ Phi
    return float((np.linalg.norm(KPhi - (run.M @ Phi) * run.eigenvalues[flex], axis=0)
                  / np.linalg.norm(KPhi, axis=0)).max())


def _ritz(run: AnsysRun, K, count: int, residual: float):
    """The run's modes brought to the form of theory section 4 with the .full's M and the free K: Ritz vectors
    of the free body, their stresses combined from the modes' corner stress tensors."""
    n, nm = len(run.points), len(run.eigenvalues)
    Psi, R = run.modes.reshape(3 * n, nm), rigid_modes(run.points)
    lam, S, dropped = free_surface_ritz(run.M, K, Psi, R)
    C = np.linalg.lstsq(np.hstack([Psi, R]), S, rcond=None)[0][:nm]  # S = Psi C + R D: R carries no stress
    signs = mode_signs(S, run.M, run.points)
    note = (f"not free-free ({count} of {nm} modes rigid; |K phi - lambda M phi| / |K phi| up to {residual:.2g}): "
            f"brought to the form of theory 4 with the .full's M and the free K: {len(lam)} Ritz vectors of the "
            f"free body ({dropped} rigid or dependent dropped), as good as the run's modes span its modes"
            + ("; their stresses combined from the modes' corner stress tensors" if run.corner_stress else ""))
    return lam, (S * signs).reshape(n, 3, -1), nodal_von_mises(run, C * signs), note
