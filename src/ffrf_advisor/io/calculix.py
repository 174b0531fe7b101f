"""CalculiX frequency-step results: ``job.frd`` (+ ``job.dat``, ``job.inp``, ``job.mas/.sti/.dof``).

Read from the .frd (ASCII or binary node/element output; calculix_frd): nodes,
elements of every .frd type, mode shapes (DISP) and nodal stresses (STRESS)
per mode. Eigenvalues come from the .dat table (7 digits) when it is beside
the .frd, else from the frequencies of the .frd (6 digits). The mass matrix is
the one CalculiX stored with ``*FREQUENCY, SOLVER=MATRIXSTORAGE`` (.mas,
.dof) where it is one over the .frd's nodes, else the consistent mass
assembled from the mesh and the ``*DENSITY`` of the deck (.inp) with the
deck's point masses (calculix_mass); the stiffness K from .sti with the
.mas. Shells and beams are read as CalculiX's expanded 3D elements (its
default output). A free-free body's total mass is checked against the .dat's
effective-mass total. The eigenvalues are checked against every copy the run
wrote and rigid modes are told by their shape (calculix_modes): dropped, and a
count other than six is a warning naming them.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..body import FlexibleBody, Provenance
from ..consistency import check_mode_numbers, checked
from ..errors import BodyFileError
from ..fe.assembly import mass_matrix
from ..fe.code_rules import CALCULIX, rules_of
from ..fe.elements import element_type
from ..fe.mesh import Mesh
from ..fe.stress import von_mises
from ..fe_body import fe_body, mass_normalised_file_modes, with_centrifugal_response
from .calculix_deck import (Deck, check_stiffness, deck_density, deck_material, read_deck, text_lines,  # noqa: F401
                            unsupported, write_deck)
from .calculix_frd import ASCII_DIGITS, NAMES, SOLIDS, Frd
from .calculix_modes import dat_eigenvalues as _dat_eigenvalues, eigenvalues, rigid_by_shape  # noqa: F401
from .calculix_mass import (carried_masses, check_modal_masses, check_total_mass, refuse_rotary_inertia,
                            stored_matrices, with_point_masses)

# CalculiX's C3D8R mass (one point, hourglass control) and C3D8I's incompatible modes (mass of their own) have no
# rule in fe.code_rules: its modes are those of another mass (modal masses 35 % and 10 % off on a bar)
UNCARRIED = {"C3D8R": "integrates its mass at one point", "C3D8I": "gives its incompatible modes mass"}
EXPANDED = {"S3": "C3D6", "S6": "C3D15", "S4": "C3D8I", "S4R": "C3D8R", "S8": "C3D20", "S8R": "C3D20R",
            "B31": "C3D8I", "B31R": "C3D8R", "B32": "C3D20", "B32R": "C3D20R"}  # CalculiX 2.20's 3D form of each
N_RIGID = 6


def _nodal(frd: Frd, index: dict, ids: np.ndarray, values: np.ndarray, field: str) -> np.ndarray:
    out = np.zeros((len(index), values.shape[1]))
    try:
        out[[index[i] for i in ids]] = values
    except KeyError as e:
        frd.fail(field, "results at nodes of the mesh", f"unknown node {e}")
    return out


def _tensor(v: np.ndarray) -> np.ndarray:
    """Symmetric tensors (n, 3, 3) from CalculiX components SXX SYY SZZ SXY SYZ SZX."""
    xx, yy, zz, xy, yz, zx = v[:, :6].T
    return np.stack([np.stack([xx, xy, zx], -1), np.stack([xy, yy, yz], -1), np.stack([zx, yz, zz], -1)], -2)


def _precise_points(frd: Frd, deck: Deck | None) -> tuple[np.ndarray, str | None]:
    """The .frd's node coordinates, or the deck's where it defines every node and agrees with the .frd to the
    .frd's precision (else an error naming the deck); a note saying which."""
    if deck is None or not deck.nodes or any(int(n) not in deck.nodes for n in frd.ids):
        return frd.nodes, None
    points = np.array([deck.nodes[int(n)] for n in frd.ids])
    size = float(np.ptp(frd.nodes, axis=0).max()) or 1.0
    off = float(np.abs(points - frd.nodes).max())
    if off > 10.0 ** (1 - ASCII_DIGITS) * size:
        raise BodyFileError(deck.path, "*NODE", f"the nodes of {frd.path.name} (within its precision)",
                            f"coordinates {off:.3g} away (another model's deck)")
    return points, "node coordinates from the deck's *NODE (full precision)"


def _names(frd: Frd, deck: Deck | None, cell_type: str) -> str:
    """CalculiX's names of a block's elements: the deck's *ELEMENT TYPE where it has them, else the .frd type's."""
    if deck is None:
        return NAMES[cell_type]
    names = sorted({deck.element_names.get(n, "") for n in frd.numbers[cell_type]} - {""})
    return ", ".join(names) or NAMES[cell_type]


def _expanded(frd: Frd, deck: Deck | None) -> str | None:
    """A note naming the shells and beams CalculiX expanded into the .frd's 3D elements, or None."""
    if deck is None:
        return None
    names = {deck.element_names.get(n, "") for numbers in frd.numbers.values() for n in numbers}
    shells = sorted(names & set(EXPANDED))
    return f"{', '.join(shells)} read as CalculiX's expansion into 3D elements" if shells else None


def _solid_cells(frd: Frd, deck: Deck | None, index: dict) -> dict[str, np.ndarray]:
    """Connectivity by meshio type; shell and beam mid-surfaces (OUTPUT=2D) are refused by name."""
    flat = [t for t in frd.elements if t not in SOLIDS]
    if flat:
        frd.fail("3C", "3D results (CalculiX's default output: shells and beams expanded into the 3D elements "
                 "whose nodes carry the through-thickness motion the mass moves with); drop OUTPUT=2D",
                 f"{_names(frd, deck, flat[0])} mid-surface elements ({flat[0]}: *NODE FILE, OUTPUT=2D)")
    try:
        return {t: np.array([[index[n] for n in e] for e in es], np.int64) for t, es in frd.elements.items()}
    except KeyError as e:
        frd.fail("3C", "element nodes defined in the node block", f"unknown node {e}")


def _assembled(frd: Frd, deck: Deck | None, mesh: Mesh, why: str | None, stem: Path):
    """Consistent mass from the mesh and the deck's *DENSITY with CalculiX's own integration rule of each block
    (fe.code_rules: the mass its modes are normalised with), exact where the block has none; an element the tool
    cannot integrate as CalculiX does is refused by its CalculiX name, with the way forward."""
    rules = {}
    for cell_type in mesh.cells:
        given = _names(frd, deck, cell_type).split(", ")
        names = {EXPANDED.get(n, n) for n in given}
        coarse = [n for n in given if EXPANDED.get(n, n) in UNCARRIED]
        if coarse:
            solid = EXPANDED.get(coarse[0], coarse[0])
            frd.fail("3C", "elements whose mass CalculiX integrates as the tool does, or CalculiX's stored matrices "
                     "(*FREQUENCY, SOLVER=MATRIXSTORAGE, .mas/.dof beside the .frd)" + (f"; {why}" if why else ""),
                     f"{coarse[0]} (" + (f"expanded into {solid}: " if solid != coarse[0] else "")
                     + f"CalculiX {UNCARRIED[solid]})")
        try:
            element_type(cell_type)
        except ValueError:
            frd.fail("3C", "elements whose mass the tool integrates, or CalculiX's stored matrices (*FREQUENCY, "
                     "SOLVER=MATRIXSTORAGE, .mas/.dof beside the .frd)" + (f"; {why}" if why else ""),
                     f"{_names(frd, deck, cell_type)} ({cell_type})")
        rules.update(rules_of(CALCULIX, {cell_type: names.pop()}) if len(names) == 1 else {})
    return mass_matrix(mesh, deck_density(deck, frd.path, stem), rules=rules)


def _element_nodes(frd: Frd):
    """Element number -> node numbers of the .frd (for spiders given by ELSET)."""
    table = {n: e for t in frd.elements for n, e in zip(frd.numbers[t], frd.elements[t])}
    return lambda number: table.get(number, [])


def _blocks_of_every_mode(frd: Frd) -> None:
    """CalculiX writes the same result blocks for every mode: a mode without one another mode has (a damaged
    block name, 'STRESS' read as 'STRDSS') is an error naming the block and the mode, never a body without it."""
    modes = sorted({m for m, _ in frd.results if m > 0})
    names = [name for m, name in frd.results if m > 0]
    for name in sorted(set(names), key=lambda n: (-names.count(n), n)):  # the blocks most modes have first
        missing = [m for m in modes if (m, name) not in frd.results]
        if missing:
            frd.fail(name, f"a {name} block for every mode, as CalculiX writes them",
                     f"none for mode {missing[0]} (a damaged block name or a cut file)")


def _modes(frd: Frd, index: dict, stem: Path):
    """Modes present, eigenvalues of all of them with their source, nodal DISP (n, 3, m) and von Mises."""
    modes = sorted(m for m, name in frd.results if name == "DISP" and m > 0)  # mode 0: another step's results
    if not modes:
        frd.fail("DISP", "mode shapes (*NODE FILE or *NODE OUTPUT with U)", "none")
    _blocks_of_every_mode(frd)
    check_mode_numbers(frd.path, "DISP mode numbers", modes, first=1)
    lam, source = eigenvalues(frd, modes, stem.with_suffix(".dat"))
    Phi = np.stack([_nodal(frd, index, *frd.results[(m, "DISP")], "DISP")[:, :3] for m in modes], axis=-1)
    stress = None
    if (modes[0], "STRESS") in frd.results:
        stress = np.stack([von_mises(_tensor(_nodal(frd, index, *frd.results[(m, "STRESS")], "STRESS")))
                           for m in modes], axis=-1)
    return modes, lam, source, Phi, stress


def _mass(frd, deck, mesh, Phi, stress, index, stem):
    """Ms, K, mesh, Phi and stress with any spider REF NODEs carrying masses appended, and notes."""
    Ms, K, why = stored_matrices(stem, index, frd.ids, mesh.points, {} if deck is None else deck.nodes)
    if Ms is not None:
        stored = "mass and stiffness" if K is not None else "mass"
        files = ".mas/.dof/.sti" if K is not None else ".mas/.dof"
        return Ms, K, mesh, Phi, stress, [f"{stored}: CalculiX matrix storage ({files})"]
    Ms = _assembled(frd, deck, mesh, why, stem)
    notes = ["mass: consistent, assembled from the mesh and *DENSITY of the deck with CalculiX's rules"
             + (f" (not the .mas: {why})" if why else "")]
    if deck is None or not deck.masses:
        return Ms, None, mesh, Phi, stress, notes
    masses, points, motion = carried_masses(deck, mesh.points, Phi, index, frd.digits, _element_nodes(frd))
    n = len(index) + len(points)
    notes.append(f"{len(masses)} point masses of *MASS ({sum(m for _, m in masses):.7g}) on their nodes"
                 + (f", {len(points)} on spider REF NODEs moving with the spider" if len(points) else ""))
    if len(points):
        mesh = Mesh(np.vstack([mesh.points, points]), mesh.cells)
        Phi = np.concatenate([Phi, motion])
        stress = None if stress is None else np.concatenate([stress, np.zeros((len(points), stress.shape[1]))])
    return with_point_masses(Ms, masses, n), None, mesh, Phi, stress, notes


def read(path, load_fe: bool = False) -> FlexibleBody:
    """A modal body from CalculiX frequency results (t-mm-N-s assumed)."""
    frd = Frd(path)
    if frd.nodes is None or not frd.elements:
        frd.fail("frd", "a node block (2C) and an element block (3C)", "missing")
    index = {int(n): k for k, n in enumerate(frd.ids)}
    stem = Path(path).with_suffix("")
    deck = read_deck(stem.with_suffix(".inp"))
    refuse_rotary_inertia(deck)
    check_stiffness(deck)
    cells = _solid_cells(frd, deck, index)
    points, from_deck = _precise_points(frd, deck)
    modes, lam, source, Phi, stress = _modes(frd, index, stem)
    Ms, K, mesh, Phi, stress, mass_notes = _mass(frd, deck, Mesh(points, cells), Phi, stress, index, stem)
    rigid, rigid_notes = rigid_by_shape(mesh.points, Phi, lam, modes, frd.path, free=unsupported(deck))
    notes = [f"CalculiX {Path(path).name}: {len(modes)} modes, {int(rigid.sum())} rigid dropped; {source}"]
    notes += [n for n in (from_deck, _expanded(frd, deck)) if n] + rigid_notes + mass_notes
    free_free = rigid.sum() == N_RIGID and not any(n.startswith("warning") for n in rigid_notes)
    flex = ~rigid
    if not flex.any():
        frd.fail("DISP", "at least one flexible mode", "only rigid modes")
    if free_free:
        total = check_total_mass(stem.with_suffix(".dat"), float(Ms.sum()), mass_notes[0], deck)
        notes += [total] if total else []
    Phi_n, stress, scale = mass_normalised_file_modes(Ms, Phi[:, :, flex],
                                                      None if stress is None else stress[:, flex], mesh.points)
    check_modal_masses(frd.path, scale, mass_notes[0])
    material = _deck_material_for(deck, mesh)
    if material is not None:
        notes.append("material from the deck (*ELASTIC, *DENSITY): static centrifugal response and geometric "
                     "stiffness computed (theory 9, 11)")
    body = fe_body(Path(path).name.split(".")[0], mesh, Ms, Phi_n, lam[flex],
                   Provenance(source=str(path), mass_matrix="consistent", notes=tuple(notes), digits=frd.digits),
                   K, stress, material)
    body = checked(body, path)  # eigenvalues against K, modal stresses against their bound (theory 2, 6)
    return body if material is None or not free_free else with_centrifugal_response(body)


def _deck_material_for(deck: Deck | None, mesh: Mesh):
    """The deck's material where every node is in an element (a spider's REF NODE is not: its stiffness would be
    singular, no static response then), else None."""
    used = np.zeros(mesh.n_nodes, bool)
    for conn in mesh.cells.values():
        used[conn.ravel()] = True
    return deck_material(deck) if used.all() else None
