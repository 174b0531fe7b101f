"""Meshes readable by meshio (VTU, VTK, XDMF, MED, Gmsh) that carry mode shapes as point data.

Point data ``mode_1`` .. ``mode_n`` (n x 3 each), optional ``von_mises_1`` ..
``von_mises_n``, and ``rotation_1`` .. ``rotation_n`` (n x 3, small rotations) where nodes carry rotary
inertia (theory 3b); field data ``eigenvalues`` (or the --eigenvalues option) and
``density`` (or --density), optional ``young`` and ``poisson`` (or the options)
and ``units_si`` (kg, m, s per mass, length and time unit: t-mm-N-s is 1000,
0.001, 1, the only units read). The mass comes from the cells (``meshio_cells``:
solids of every type the FE module has, shells, beams and point masses with their
data); cells without mass of their own are named in a note, any other cell type
is an error naming it.

VTU is written too (``write``, format ``vtu``): the mesh with each mode
and its nodal von Mises stress, the eigenvalues and frequencies, density,
material and units as field data, and the static centrifugal deflections of the
six load cases ``static_w1w1`` .. ``static_w2w3`` (per unit spin^2, theory 11)
where the body has its material: ParaView opens them, and they read back to the
same body. Masses on nodes beyond the density's consistent mass become vertex
cells with ``mass`` and ``inertia`` (and the modes' ``rotation_*``); a mass
matrix of another kind (shells, beams, lumped) is refused.
"""
from __future__ import annotations

import contextlib
import io
import os
import re
from dataclasses import replace

import numpy as np
import scipy.sparse as sp

from ..body import CASES, FlexibleBody, ModalFE, NodalRotary, Provenance
from ..consistency import check_frequencies, check_mode_numbers, checked
from ..errors import BodyFileError, FFRFError
from ..fe.assembly import full_mass, mass_matrix
from ..fe.material import Material
from ..fe.mesh import Mesh
from ..fe.modal import mode_signs
from ..fe_body import fe_body, with_centrifugal_response
from . import guard
from .meshio_cells import body_cells
from .atomic import atomic_path
from .limits import check_file_size, check_reference

_MODE = re.compile(r"^mode_(\d+)$")


def _numbers(path, field: str, value, n: int | None = None) -> np.ndarray:
    try:
        a = np.asarray(value, dtype=float).ravel()
    except (TypeError, ValueError):
        raise BodyFileError(path, field, "numbers", repr(value)[:60]) from None
    if (n is not None and len(a) != n) or not np.all(np.isfinite(a)):
        raise BodyFileError(path, field, f"{n if n is not None else 'some'} finite numbers",
                            f"{len(a)} values" + ("" if np.all(np.isfinite(a)) else " with NaN/inf"))
    return a


def _modes(path, m, n_nodes: int) -> tuple[list[int], np.ndarray]:
    numbers = sorted(int(g.group(1)) for key in m.point_data if (g := _MODE.match(key)))
    if not numbers:
        raise BodyFileError(path, "point_data/mode_1", "mode shapes as point data mode_1 .. mode_n", "none")
    check_mode_numbers(path, "point_data/mode_*", numbers, first=1)
    Phi = np.stack([np.asarray(m.point_data[f"mode_{p}"], dtype=float) for p in numbers], axis=-1)
    if Phi.shape != (n_nodes, 3, len(numbers)) or not np.all(np.isfinite(Phi)):
        raise BodyFileError(path, "point_data/mode_*", f"finite ({n_nodes}, 3) vectors per mode", str(Phi.shape))
    return numbers, Phi


def read(path, load_fe: bool = False, eigenvalues=None, density: float | None = None, young: float | None = None,
         poisson: float | None = None) -> FlexibleBody:
    """A modal body from a meshio mesh with mode fields (t-mm-N-s); with ``young`` and ``poisson`` (options or
    field data) a body of solids and point masses without inertia carries its material, static centrifugal
    response and geometric stiffness (theory 9, 11)."""
    m = guard.run(path, "meshio", _meshio_read, path)
    units = _units_note(path, m)
    material = _material(path, *(_scalar(path, m, k, v) for k, v in (("young", young), ("poisson", poisson))))
    cells = body_cells(path, m)
    mesh = Mesh(cells.points, cells.solids)
    numbers, Phi = _modes(path, m, mesh.n_nodes)
    nf = len(numbers)
    lam = _numbers(path, "eigenvalues", _given(path, m, "eigenvalues", eigenvalues), nf)
    _frequencies_agree(path, m, lam, eigenvalues is None)
    rho = _numbers(path, "density", _given(path, m, "density", density), 1)[0] if cells.distributed else 0.0
    bad_density = cells.distributed and rho <= 0
    if bad_density or np.any(lam <= 0):
        raise BodyFileError(path, "density" if bad_density else "eigenvalues", "positive values (flexible modes only)")
    Ms, rotary, notes = _mass(path, m, cells, mesh, rho, numbers)
    Phi, rotary, stress, scale = normalised(Ms, Phi, rotary, _stress(path, m, mesh.n_nodes, numbers), mesh.points)
    provenance = Provenance(
        source=str(path), mass_matrix="consistent",
        method="consistent mass assembled from the mesh; nodal sums (theory section 3"
               + (", 3b)" if rotary is not None else ")"),
        notes=(f"{units}: coordinates mm, density {rho:g} t/mm^3, "
               f"eigenvalues 1/s^2; modes mass-normalised (file scale factors "
               f"{', '.join(f'{1 / s:.4g}' for s in scale[:4])}{' ...' if nf > 4 else ''})",
               f"{mesh.n_cells} solid cells, {mesh.n_nodes} nodes", *notes))
    given = "--young, --poisson" if young is not None else "field data"
    return checked(_body(os.path.basename(str(path)).split(".")[0], mesh, Ms, Phi, lam, stress, rotary, provenance,
                 None if material is None else (replace(material, rho=rho), given)), path)


def _frequencies_agree(path, m, lam: np.ndarray, from_file: bool) -> None:
    """The file's second copy of the eigenvalues, field data ``frequencies_hz``, agrees with ``eigenvalues``
    (``consistency.check_frequencies``; single precision where the file stores it so)."""
    if from_file and "frequencies_hz" in m.field_data:
        f = m.field_data["frequencies_hz"]
        digits = 7 if np.asarray(f).dtype == np.float32 else None
        check_frequencies(path, ("field_data/frequencies_hz", "field_data/eigenvalues"),
                          _numbers(path, "field_data/frequencies_hz", f, len(lam)), lam, digits)


def _body(name: str, mesh: Mesh, Ms, Phi: np.ndarray, lam: np.ndarray, stress, rotary: NodalRotary | None,
          provenance: Provenance, material: tuple[Material, str] | None) -> FlexibleBody:
    """The body in its CoM principal frame; with the material (and where it was given) and no rotary nodes, its
    static centrifugal response and geometric stiffness (theory 9, 11)."""
    if material is not None:
        (mat, given), material = material, None
        if rotary is not None or not mesh.cells:
            why = "nodes with rotary inertia need 6-DOF stiffness" if rotary is not None else "no solid cells"
            provenance = provenance.with_note(f"material E={mat.E:g}, nu={mat.nu:g} not used for the static "
                                              f"centrifugal response: {why}")
        else:
            material = mat
            provenance = provenance.with_note(f"material E={mat.E:g}, nu={mat.nu:g} ({given}): static "
                                              "centrifugal response and geometric stiffness computed")
    if rotary is None:
        body = fe_body(name, mesh, Ms, Phi, lam, provenance, stress=stress, material=material)
        return body if material is None else with_centrifugal_response(body)
    fe = ModalFE(mesh, Ms, Phi, stress_nodal=stress, rotary=rotary)
    return FlexibleBody(name=name, integrals=fe.integrals(), eigenvalues=lam, provenance=provenance, fe=fe,
                        sigma_max=None if stress is None else stress.max(axis=0)).in_principal_frame()[0]


def _mass(path, m, cells, mesh: Mesh, rho: float, numbers: list[int]):
    """Ms (n x n), the nodes with rotary inertia with their file rotations (or None) and notes (theory 3b)."""
    n = mesh.n_nodes
    try:
        Ms = mass_matrix(mesh, rho) if mesh.cells else sp.csr_array((n, n))
    except ValueError as e:
        raise BodyFileError(path, "cells", "solid cells of positive volume in VTK node order", str(e)) from None
    notes = cells.notes()
    extra = cells.structural_mass(path, rho)
    if extra is None:
        rotations = _rotations(path, m, numbers, n, needed=0)
        return Ms, None, notes + (["point data rotation_* not used: no node carries rotary inertia"]
                                  if rotations is not None else [])
    Ms = sp.csr_array(Ms + extra.Ms)
    nodes = np.flatnonzero(np.abs(extra.J).max(axis=(1, 2)) > 0)
    rotations = _rotations(path, m, numbers, n, needed=len(nodes))
    if not len(nodes):
        return Ms, None, notes
    return Ms, NodalRotary(nodes, extra.J[nodes], rotations[nodes]), notes


def _rotations(path, m, numbers: list[int], n: int, needed: int) -> np.ndarray | None:
    """Point data rotation_1 .. rotation_n (n, 3, nf), or None where absent; refused absent where ``needed``
    nodes carry rotary inertia."""
    keys = [f"rotation_{p}" for p in numbers]
    present = [k in m.point_data for k in keys]
    if not any(present) and not needed:
        return None
    if not all(present):
        raise BodyFileError(path, f"point_data/{keys[present.index(False)]}", "mode rotations rotation_1 .. "
                            f"rotation_{len(keys)} (theory 3b) for the {needed} nodes with rotary inertia (shells, "
                            "beams, point masses with inertia)" if needed else
                            "rotations for every mode or none", "missing")
    R = np.stack([np.asarray(m.point_data[k], dtype=float).reshape(n, -1) for k in keys], axis=-1)
    if R.shape[1] != 3 or not np.all(np.isfinite(R)):
        raise BodyFileError(path, "point_data/rotation_*", f"finite ({n}, 3) vectors per mode", str(R.shape))
    return R


def normalised(Ms, Phi: np.ndarray, rotary: NodalRotary | None, stress: np.ndarray | None, X: np.ndarray):
    """Modes of a file scaled to unit modal mass Phi^T M Phi + Phi*^T J Phi* (theory 3b), signed by
    ``fe.modal.mode_signs``, with their rotations and nodal stresses scaled alike. Returns (Phi, rotary, stress,
    scale), ``scale`` the file modes' sqrt(modal mass)."""
    M, S = full_mass(Ms), Phi.reshape(-1, Phi.shape[2])
    modal = np.einsum("ip,ip->p", S, M @ S)
    if rotary is not None:
        modal = modal + np.einsum("iap,iab,ibp->p", rotary.Phi, rotary.J, rotary.Phi)
    scale = np.sqrt(modal)
    factor = mode_signs(S, M, X) / scale
    return ((S * factor).reshape(Phi.shape),
            None if rotary is None else NodalRotary(rotary.nodes, rotary.J, rotary.Phi * factor),
            None if stress is None else stress / scale, scale)


PARSE_FACTOR = 8  # bytes meshio holds per byte of file while parsing (XML trees, base64, decompressed data)
XINCLUDE = "{http://www.w3.org/2001/XInclude}include"


def _meshio_read(path):
    """meshio's mesh (run in the guarded child, io.guard), after the size and reference checks."""
    check_file_size(path, PARSE_FACTOR)
    if str(path).lower().endswith((".xdmf", ".xmf")):
        _check_xdmf_references(path)
    meshio = meshio_module()

    try:
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
            return meshio.read(path)  # meshio prints its complaints; ours is the one line
    except (Exception, SystemExit) as e:  # meshio raises many kinds on bad input, even SystemExit
        got = "not parseable as its suffix's format" if isinstance(e, SystemExit) else f"{type(e).__name__}: {e}"
        raise BodyFileError(path, "file", "a mesh meshio can read", got[:200]) from None


MISSING_DIMENSIONS = {"wedge15": 3, "pyramid13": 3}  # meshio 5.3.5 knows their node counts, not their dimension


def meshio_module():
    """meshio, able to hold wedge15 and pyramid13 cells: its table of topological dimensions lacks them, so any
    mesh with them fails to build, read or write with KeyError (meshio issue 1247, open in 5.3.5)."""
    import meshio
    from meshio import _mesh

    for cell_type, dim in MISSING_DIMENSIONS.items():
        _mesh.topological_dimension.setdefault(cell_type, dim)
    return meshio


def _check_xdmf_references(path) -> None:
    """Heavy data (HDF5 or binary DataItems) and XIncludes of an XDMF file: files in its folder only."""
    import xml.etree.ElementTree as ET

    try:
        root = ET.parse(path).getroot()
    except (ET.ParseError, OSError) as e:
        raise BodyFileError(path, "file", "an XDMF (XML) file", str(e)[:100]) from None
    for item in root.iter():
        if item.tag == XINCLUDE:
            check_reference(path, "xi:include@href", item.get("href", ""))
        elif item.tag == "DataItem" and item.get("Format", "XML").upper() in ("HDF", "BINARY"):
            check_reference(path, "DataItem", (item.text or "").strip().split(":")[0])


def _material(path, young: float | None, poisson: float | None) -> Material | None:
    """--young and --poisson together, in range, or neither."""
    if young is None and poisson is None:
        return None
    if young is None or poisson is None:
        raise BodyFileError(path, "--young/--poisson", "both or neither", "only one")
    if not (np.isfinite(young) and young > 0 and np.isfinite(poisson) and -1 < poisson < 0.5):
        raise BodyFileError(path, "--young/--poisson", "E > 0 and -1 < nu < 0.5", f"{young!r}, {poisson!r}")
    return Material("meshio --young/--poisson", float(young), float(poisson), 1.0)


TMM_SI = (1e3, 1e-3, 1.0)  # kg per t, m per mm, s per s


def _units_note(path, m) -> str:
    """How the units are known: field data ``units_si``, which must then say t-mm-N-s, or assumed."""
    if "units_si" not in m.field_data:
        return "units t-mm-N-s assumed (a meshio file states none)"
    si = _numbers(path, "field_data/units_si", m.field_data["units_si"], 3)
    if not np.allclose(si, TMM_SI, rtol=1e-12):
        raise BodyFileError(path, "field_data/units_si", f"t-mm-N-s ({', '.join(map(str, TMM_SI))})",
                            ", ".join(f"{x:g}" for x in si))
    return "units t-mm-N-s (field data units_si)"


def _scalar(path, m, field: str, option: float | None) -> float | None:
    """The option, else one number of field data, else None."""
    if option is not None or field not in m.field_data:
        return option
    return float(_numbers(path, f"field_data/{field}", m.field_data[field], 1)[0])


def _given(path, m, field: str, option):
    """The option's value, else the field data, else a one-line error."""
    if option is not None:
        return option
    if field not in m.field_data:
        raise BodyFileError(path, f"field_data/{field}", f"{field} as field data or the --{field} option", "missing")
    return m.field_data[field]


def _stress(path, m, n_nodes: int, numbers: list[int]) -> np.ndarray | None:
    keys = [f"von_mises_{p}" for p in numbers]
    present = [k in m.point_data for k in keys]
    if not any(present):
        return None
    if not all(present):
        raise BodyFileError(path, "point_data/von_mises_*", "von Mises for every mode or none",
                            f"missing {keys[present.index(False)]}")
    S = np.stack([np.asarray(m.point_data[k], dtype=float).reshape(-1) for k in keys], axis=-1)
    if S.shape != (n_nodes, len(numbers)) or not np.all(np.isfinite(S)) or np.any(S < 0):
        raise BodyFileError(path, "point_data/von_mises_*", "finite non-negative nodal values", str(S.shape))
    return S


def write(body: FlexibleBody, path, overwrite: bool = False) -> None:
    """The body as a VTU/VTK mesh (module docstring), in t-mm-N-s, written atomically."""
    meshio = meshio_module()
    from ..centrifugal import static_centrifugal
    from ..units import TMM
    if body.fe is None:
        raise FFRFError(f"{path}: a mesh file holds nodal FE data; {body.name} has invariants only")
    b = body.converted(TMM)
    fe, n = b.fe, b.fe.mesh.n_nodes
    rho, nodes, masses = _density_and_point_masses(b, path)
    point = {f"mode_{p + 1}": fe.Phi[:, :, p] for p in range(b.nf)}
    if fe.stress_nodal is not None:
        point |= {f"von_mises_{p + 1}": fe.stress_nodal[:, p] for p in range(b.nf)}
    field = {"eigenvalues": b.eigenvalues, "frequencies_hz": b.frequencies_hz, "density": np.array([rho]),
             "units_si": np.array(TMM_SI)}
    if fe.material is not None and fe.rotary is None:
        U = static_centrifugal(fe, fe.material)[1]
        point |= {f"static_{c}": U[:, j].reshape(n, 3) for j, c in enumerate(CASES)}
        field |= {"young": np.array([fe.material.E]), "poisson": np.array([fe.material.nu])}
    cells, cell_data = list(fe.mesh.cells.items()), {}
    if len(nodes):
        J, R = np.zeros((n, 3, 3)), np.zeros_like(fe.Phi)
        if fe.rotary is not None:
            J[fe.rotary.nodes], R[fe.rotary.nodes] = fe.rotary.J, fe.rotary.Phi
            point |= {f"rotation_{p + 1}": R[:, :, p] for p in range(b.nf)}
        cell_data = {"mass": [*(np.full(len(c), np.nan) for _, c in cells), masses],
                     "inertia": [*(np.full((len(c), 9), np.nan) for _, c in cells), J[nodes].reshape(-1, 9)]}
        cells.append(("vertex", nodes[:, None]))
    mesh = meshio.Mesh(fe.mesh.points, cells, point_data=point, cell_data=cell_data)
    with atomic_path(path, overwrite) as tmp:
        meshio.write(tmp, mesh, file_format="vtu")
        _add_field_data(tmp, field)


def _add_field_data(path, field: dict) -> None:
    """meshio's VTU writer drops field data (its reader reads it): add it as the grid's <FieldData>, ASCII
    with every digit (``repr``: the numbers read back exactly)."""
    import xml.etree.ElementTree as ET
    tree = ET.parse(path)
    grid = tree.getroot().find("UnstructuredGrid")
    data = ET.Element("FieldData")
    for name, values in field.items():
        array = ET.SubElement(data, "DataArray", type="Float64", Name=name,
                              NumberOfTuples=str(len(values)), format="ascii")
        array.text = " ".join(repr(float(x)) for x in values)
    grid.insert(0, data)
    tree.write(path, xml_declaration=True, encoding="utf-8")


POINT_MASS_TOL = 1e-12  # of the largest mass entry: the round-off of an assembled mass matrix


def _density_and_point_masses(body: FlexibleBody, path) -> tuple[float, np.ndarray, np.ndarray]:
    """The density whose consistent mass the body's mass matrix is, plus masses on nodes (written as vertex
    cells): rho from the off-diagonal entries, which point masses do not touch, by least squares; what remains
    on the diagonal is the nodes' point masses, (nodes, masses). Nodes with rotary inertia must be among them.
    A mesh file holds no mass matrix: any other one is refused."""
    fe = body.fe
    M1 = mass_matrix(fe.mesh, 1.0) if fe.mesh.cells else sp.csr_array(fe.Ms.shape)
    off1, off = (sp.csr_array(M - sp.diags_array(M.diagonal())) for M in (M1, fe.Ms))
    fit = float(off1.multiply(off1).sum())
    rho = float(off.multiply(off1).sum()) / fit if fit > 0 else 0.0
    extra = sp.csr_array(fe.Ms - rho * M1)
    tol = POINT_MASS_TOL * abs(fe.Ms).max()
    d = extra.diagonal()
    nodes = np.flatnonzero(d > tol)
    rotary = np.array([], np.int64) if fe.rotary is None else fe.rotary.nodes
    if rho <= 0 or abs(extra - sp.diags_array(d)).max() > tol or d.min() < -tol or np.setdiff1d(rotary, nodes).size:
        raise FFRFError(f"{path}: a mesh file holds one density and point masses; {body.name}'s mass matrix is not "
                        "the consistent mass of a uniform density plus masses on nodes with any rotary inertia "
                        "(shells, beams, lumped mass): write .ffrf.h5")
    return rho, nodes, d[nodes]
