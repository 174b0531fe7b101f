"""The native body format ``.ffrf.h5`` (HDF5), specified in docs/format.md.

Reading is lazy: only the datasets a request needs are read, so ``info`` on
a file with cached invariants never touches the mode matrix.
"""
from __future__ import annotations

import os
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .. import __version__
from ..body import MASS_KINDS, FlexibleBody, ModalFE, NodalRotary, NodalSummary, Provenance, StaticCentrifugal
from ..errors import BodyFileError
from ..invariants import SPAN, NodalPass, RotaryIntegrals, ShapeIntegrals, block_rows, nodal_pass
from ..units import Units, UnitsError
from .atomic import atomic_path
from . import guard
from . import h5_checksums
from .h5_reader import CHILD_COPIES, Reader as _Reader
from .limits import check_hdf5_references, declare_work

h5py = guard.lazy_module("h5py")  # loaded at first use: in the children, in the tool only meanwhile (guard)

if TYPE_CHECKING:  # imported where the FE data is read or written: a cached body's analysis needs neither scipy
    import scipy.sparse as sp  # nor the FE modules

    from ..fe.material import Material
    from ..fe.mesh import Mesh

FORMAT_NAME = "ffrf-body"
VERSION = 4  # 2: optional /material, /static_centrifugal, /geometric_stiffness; 3: optional /rotary; 4: checksums
SUPPORTED_VERSIONS = (1, 2, 3, 4)  # (docs/format.md)
NODE_CHUNK = 4096  # nodal rows per HDF5 chunk
UNCHECKED = "read from a .ffrf.h5 of format 3 or older: no checksums (convert writes them)"  # a provenance note


# ---------------------------------------------------------------- writing
def _dataset(group: h5py.Group, name: str, data: np.ndarray, chunk_rows: bool = False) -> None:
    """Every dataset chunked with its Fletcher-32 checksum (h5_checksums); nodal rows gzip-compressed too."""
    data = np.ascontiguousarray(data)
    opts = dict(track_times=False, fletcher32=True, chunks=True)
    if chunk_rows and data.ndim and data.size > 1024:
        opts.update(chunks=(min(len(data), NODE_CHUNK), *data.shape[1:]), compression="gzip",
                    compression_opts=4, shuffle=True)
    group.create_dataset(name, data=data, **opts)


def _write_csr(group: h5py.Group, name: str, A: sp.sparray) -> None:
    import scipy.sparse as sp
    A = sp.csr_array(A)
    A.sort_indices()
    g = group.create_group(name, track_order=True)
    g.attrs["shape"] = np.asarray(A.shape, np.int64)
    _dataset(g, "data", A.data, True)
    _dataset(g, "indices", A.indices.astype(np.int64), True)
    _dataset(g, "indptr", A.indptr.astype(np.int64), True)


def _write_integrals(group: h5py.Group, J: ShapeIntegrals) -> None:
    g = group.create_group("invariants", track_order=True)
    g.attrs["mass"] = J.mass
    for name in ("first_moment", "I", "Ibar", "Sbar", "mode_sum", "spin"):
        if getattr(J, name) is not None:
            _dataset(g, name, getattr(J, name))
    if J.rotary is not None:
        for name in ("J", "mean_axis", "modal_mass"):
            _dataset(g, f"rotary_{name}", getattr(J.rotary, name))


def write(body: FlexibleBody, path: str | os.PathLike, overwrite: bool = False,
          cache_invariants: bool = True) -> None:
    """Write ``body`` to ``path`` atomically; bit-for-bit reproducible for the same body. The HDF5 library
    writes in a child (``guard.run_writer``): a failed write (a full disk) makes it crash on cleanup."""
    with atomic_path(path, overwrite) as tmp:
        guard.run_writer(path, _write_file, body, tmp, cache_invariants)


def _write_file(body: FlexibleBody, tmp: Path, cache_invariants: bool) -> None:
    with h5py.File(tmp, "w", track_order=True, libver=("earliest", "v110")) as f:
        f.attrs["format"] = FORMAT_NAME
        f.attrs["version"] = VERSION
        f.attrs["name"] = body.name
        f.attrs["units"] = str(body.units)
        prov = f.create_group("provenance", track_order=True)
        prov.attrs["source"] = body.provenance.source
        prov.attrs["mass_matrix"] = body.provenance.mass_matrix
        prov.attrs["method"] = body.provenance.method
        prov.attrs["notes"] = "\n".join(n for n in body.provenance.notes if n != UNCHECKED)
        if body.provenance.digits is not None:
            prov.attrs["digits"] = body.provenance.digits
        prov.attrs["written_by"] = f"ffrf_advisor {__version__}"
        modes = f.create_group("modes", track_order=True)
        _dataset(modes, "eigenvalues", body.eigenvalues)
        stress = None
        if body.sigma_max is not None:
            stress = f.create_group("stress", track_order=True)
            _dataset(stress, "max", body.sigma_max)
        if body.fe is not None:
            _write_fe(f, modes, stress, body.fe)
        if body.static_centrifugal is not None:
            g = f.create_group("static_centrifugal", track_order=True)
            _dataset(g, "compliance", body.static_centrifugal.compliance)
            _dataset(g, "sigma", body.static_centrifugal.sigma)
        if body.geometric is not None:
            _dataset(f.create_group("geometric_stiffness", track_order=True), "G", body.geometric)
        if cache_invariants or body.fe is None:
            _write_integrals(f, body.integrals)
        if body.nodal_summary() is not None:
            _write_summary(f.create_group("nodal_summary", track_order=True), body.nodal_summary())
        h5_checksums.write(f, NODE_CHUNK)


def _write_summary(g: h5py.Group, summary: NodalSummary) -> None:
    _dataset(g, "max_deflection", summary.max_deflection)
    g.attrs["largest_dimension"] = summary.largest_dimension
    g.attrs["n_nodes"] = summary.n_nodes
    g.attrs["stiffness"] = summary.stiffness


def _write_fe(f: h5py.File, modes: h5py.Group, stress: h5py.Group | None, fe: ModalFE) -> None:
    mesh = f.create_group("mesh", track_order=True)
    _dataset(mesh, "points", fe.mesh.points, True)
    cells = mesh.create_group("cells", track_order=True)
    for cell_type, conn in fe.mesh.cells.items():
        _dataset(cells, cell_type, conn.astype(np.int64), True)
    mass = f.create_group("mass", track_order=True)
    _write_csr(mass, "Ms", fe.Ms)
    _dataset(modes, "Phi", fe.Phi, True)
    if fe.K is not None:
        _write_csr(f.create_group("stiffness", track_order=True), "K", fe.K)
    if fe.stress_nodal is not None and stress is not None:
        _dataset(stress, "nodal", fe.stress_nodal, True)
    if fe.rotary is not None:
        g = f.create_group("rotary", track_order=True)
        _dataset(g, "nodes", fe.rotary.nodes, True)
        _dataset(g, "J", fe.rotary.J, True)
        _dataset(g, "Phi", fe.rotary.Phi, True)
    if fe.material is not None:
        g = f.create_group("material", track_order=True)
        for key in ("name", "E", "nu", "rho"):
            g.attrs[key] = getattr(fe.material, key)


# ---------------------------------------------------------------- reading
def _header(r: _Reader) -> tuple[str, Units]:
    if r.f.attrs.get("format") not in (FORMAT_NAME, FORMAT_NAME.encode()):
        r.fail("@format", f"'{FORMAT_NAME}'", repr(r.f.attrs.get("format")))
    r.set_version(int(r.number("version", r.f, f"one of {SUPPORTED_VERSIONS}", lambda v: v in SUPPORTED_VERSIONS,
                               integer=True)))
    if r.nodal is not None and not isinstance(r.f.get(h5_checksums.GROUP), h5py.Group):
        r.fail(h5_checksums.GROUP, f"the checksums of format {r.version}", "missing")
    try:
        units = Units.parse(r.attr("units"))
    except UnitsError as e:
        r.fail("@units", "a unit system like 't-mm-N-s'", str(e))
    return str(r.attr("name")), units


def _provenance(r: _Reader, path) -> Provenance:
    g = r.f.get("provenance")
    if not isinstance(g, h5py.Group):
        return Provenance(source=str(path))
    get = lambda k, d="": (g.attrs.get(k, d).decode() if isinstance(g.attrs.get(k, d), bytes)  # noqa: E731
                           else str(g.attrs.get(k, d)))
    kind = get("mass_matrix", "unknown")
    if kind not in MASS_KINDS:
        r.fail("provenance@mass_matrix", f"one of {MASS_KINDS}", repr(kind))
    notes = tuple(n for n in get("notes").split("\n") if n) + ((UNCHECKED,) if r.nodal is None else ())
    source = get("source") or str(path)
    digits = g.attrs.get("digits")
    if digits is not None:
        r.number("digits", g, "a whole number of significant digits from 1 to 17", lambda v: 1 <= v <= 17, True)
    return Provenance(source=source, mass_matrix=kind, method=get("method") or Provenance.method, notes=notes,
                      digits=None if digits is None else int(digits))


def _mesh(r: _Reader) -> Mesh:
    from ..fe.elements import ELEMENT_TYPES
    from ..fe.mesh import Mesh
    points = r.array("mesh/points", (None, 3))
    n = len(points)
    cells = {}
    if "mesh/cells" in r.f:
        for cell_type, ds in r.node("mesh/cells", group=True).items():
            if cell_type not in ELEMENT_TYPES:
                r.fail(f"mesh/cells/{cell_type}", f"a cell type of {', '.join(ELEMENT_TYPES)}")
            conn = r.array(f"mesh/cells/{cell_type}", (None, ELEMENT_TYPES[cell_type].n_nodes), integer=True)
            if conn.size and (conn.min() < 0 or conn.max() >= n):
                r.fail(f"mesh/cells/{cell_type}", f"node indices in [0, {n})")
            cells[cell_type] = conn
    return Mesh(points, cells)


def _mass(r: _Reader, n: int) -> sp.csr_array:
    if "mass/Ms" in r.f:
        Ms = r.csr("mass/Ms", (n, n))
    elif "mass/M" in r.f:
        import scipy.sparse as sp
        M = r.csr("mass/M", (3 * n, 3 * n))
        Ms = sp.csr_array(M[0::3, 0::3])
        if abs(M - sp.kron(Ms, sp.eye_array(3))).max() > 1e-12 * abs(Ms).max():
            r.fail("mass/M", "a full mass matrix of the form kron(Ms, I3) (theory section 2)")
    else:
        r.fail("mass/Ms", "a dataset group (or mass/M)", "missing")
    diag = Ms.diagonal()
    if Ms.sum() <= 0 or np.any(diag <= 0):
        r.fail("mass/Ms", "positive total mass and positive diagonal", f"total {Ms.sum():.3e}")
    if abs(Ms - Ms.T).max() > 1e-12 * diag.max():
        r.fail("mass/Ms", "a symmetric matrix")
    return Ms


def _cached_integrals(r: _Reader, nf: int) -> ShapeIntegrals:
    g = r.node("invariants", group=True)
    mass = r.number("mass", g, "a positive finite number", lambda v: v > 0)
    return ShapeIntegrals(
        mass=float(mass),
        first_moment=r.array("invariants/first_moment", (3,)),
        I=r.array("invariants/I", (3, 3)),
        Ibar=r.array("invariants/Ibar", (3, 3, nf)),
        Sbar=r.array("invariants/Sbar", (3, 3, nf, nf)) if "invariants/Sbar" in r.f else None,
        mode_sum=r.array("invariants/mode_sum", (3, nf)),
        spin=r.array("invariants/spin", (3, nf, nf)) if "invariants/spin" in r.f else None,
        rotary=RotaryIntegrals(r.array("invariants/rotary_J", (3, 3)), r.array("invariants/rotary_mean_axis", (3, nf)),
                               r.array("invariants/rotary_modal_mass", (nf, nf)))
        if "invariants/rotary_J" in r.f else None,
    )


CACHE_TOLERANCE = 1e-6  # relative: a cache written by this tool agrees to round-off, another tool's to its digits


def _cache_agrees(r: _Reader, cached: ShapeIntegrals, nodal: ShapeIntegrals) -> None:
    """The cached invariants equal the nodal sums of the file's mass and modes (theory 3): otherwise commands that
    read the cache (info) and those that read the nodal data (analyze) would see two bodies."""
    for name in ("mass", "first_moment", "I", "Ibar"):
        a, b = np.asarray(getattr(cached, name), float), np.asarray(getattr(nodal, name), float)
        size = (nodal.mass * np.abs(nodal.I).max()) ** 0.5  # mass x length: the first moment's scale at the CoM
        scale = max(np.abs(b).max(), size if name == "first_moment" else 0.0)
        if np.abs(a - b).max() > CACHE_TOLERANCE * max(scale, 1e-300):
            r.fail(f"invariants/{name}" if name != "mass" else "invariants@mass",
                   "the cached invariants to equal the nodal sums of mass/Ms and modes/Phi (theory 3)",
                   f"a relative difference of {np.abs(a - b).max() / max(scale, 1e-300):.2g}")


def _summary(r: _Reader, nf: int) -> NodalSummary:
    """The cached summary of the nodal data (``body.NodalSummary``): what analyze, gate, compare, settings and info
    need of them, so those commands read neither the mesh nor the modes."""
    g = r.node("nodal_summary", group=True)
    deflection = r.array("nodal_summary/max_deflection", (nf,))
    if np.any(deflection < 0):
        r.fail("nodal_summary/max_deflection", "non-negative deflections")
    size = r.number("largest_dimension", g, "a positive finite length", lambda v: 0 < v < 1e150)
    n = r.number("n_nodes", g, "a positive integer", lambda v: v >= 1, integer=True)
    stiffness = g.attrs.get("stiffness")
    if not isinstance(stiffness, (bool, np.bool_)):
        r.fail("nodal_summary@stiffness", "true or false", repr(stiffness))
    return NodalSummary(deflection, float(size), int(n), bool(stiffness))


def _summary_agrees(r: _Reader, cached: NodalSummary, nodal: NodalSummary) -> None:
    """The cached summary is that of the nodal data (the same rule as the invariants' cache)."""
    if (cached.n_nodes != nodal.n_nodes or cached.stiffness != nodal.stiffness
            or abs(cached.largest_dimension - nodal.largest_dimension) > CACHE_TOLERANCE * nodal.largest_dimension
            or np.abs(cached.max_deflection - nodal.max_deflection).max()
            > CACHE_TOLERANCE * nodal.max_deflection.max()):
        r.fail("nodal_summary", "the summary of the nodal data (mesh, modes/Phi, stiffness/K) they cache",
               "values that differ from them")


def _phi(r: _Reader, n: int, nf: int) -> h5py.Dataset:
    ds = r.node("modes/Phi")
    if ds.shape != (n, 3, nf):
        r.fail("modes/Phi", f"shape (n, 3, nf) = ({n}, 3, {nf})", str(tuple(ds.shape)))
    if ds.dtype.kind != "f":
        r.fail("modes/Phi", "floating-point numbers", f"dtype {ds.dtype}")
    return ds


def read(path: str | os.PathLike, load_fe: bool | str = False) -> FlexibleBody:
    """Read a ``.ffrf.h5`` body; the reading runs in a guarded child (io.guard). With ``load_fe`` True the
    nodal data are read into the body; otherwise only the invariants cache (and with ``load_fe="summary"``,
    what the analysis needs, the nodal summary) is read, and where the file lacks it (written before it did,
    or without the cache) both are computed in one streamed pass over the nodal data (``_streamed``)."""
    return guard.run(path, "the HDF5 library", _read_file, path, load_fe)


def _read_file(path, load_fe: bool | str) -> FlexibleBody:
    try:
        f = h5py.File(path, "r")
    except OSError:
        raise BodyFileError(path, "file", "an HDF5 file", "unreadable or corrupt HDF5") from None
    with f:  # errors nobody foresaw become the one-line error in io.read_body
        check_hdf5_references(path, f)
        return _read_open(_Reader(path, f), path, load_fe)


def _read_open(r: _Reader, path, load_fe: bool | str) -> FlexibleBody:
    name, units = _header(r)
    eigenvalues = r.array("modes/eigenvalues", (_mode_count(r),))
    nf = len(eigenvalues)
    sigma = r.array("stress/max", (nf,)) if "stress/max" in r.f else None
    if sigma is not None and np.any(sigma < 0):
        r.fail("stress/max", "non-negative von Mises stresses")
    has_fe = "modes/Phi" in r.f
    fe = None
    material = _material(r)  # validated whether or not the nodal data are read
    summary = _summary(r, nf) if "nodal_summary" in r.f else None
    if "invariants" not in r.f and not has_fe:
        r.fail("modes/Phi", "nodal modes (or a cached invariants group)", "missing")
    integrals, nodal = None, summary
    if load_fe is True and has_fe:
        fe = _read_fe(r, nf, material)
        integrals, nodal = fe.integrals(), fe.summary()
    elif "invariants" not in r.f or (load_fe == "summary" and has_fe and summary is None):
        integrals, nodal = _streamed(r, nf)
    if integrals is None:
        integrals = _cached_integrals(r, nf)
    else:  # the nodal data were read: what the file caches must be theirs
        _checksum_agrees(r, "nodal_sha256", r.nodal.hexdigest if r.nodal else None, "the nodal data the caches "
                         "came from (mesh/points, mass, modes/Phi, rotary) it records")
        if "invariants" in r.f:
            _cache_agrees(r, _cached_integrals(r, nf), integrals)
        if summary is not None:
            _summary_agrees(r, summary, nodal)
    body = FlexibleBody(name=name, integrals=integrals, eigenvalues=eigenvalues, units=units,
                        sigma_max=sigma, provenance=_provenance(r, path), fe=fe,
                        static_centrifugal=_static_centrifugal(r), geometric=_geometric(r, nf),
                        nodal=nodal if fe is None else None)
    if r.nodal is not None:  # last: a field's own check names it better
        for key, digest in h5_checksums.section_digests(r.f, r.read).items():
            _checksum_agrees(r, key, lambda: digest, "the " + key.split("_sha")[0].replace("attributes", "header "
                             "attributes (format, units, provenance, material)") + " it records")
    return body


def _checksum_agrees(r: _Reader, key: str, digest, what: str) -> None:
    """The SHA-256 ``digest()`` of ``what`` equals ``/checksums@key`` (format 4; h5_checksums)."""
    if digest is None or r.nodal is None:
        return
    stored, got = r.f[h5_checksums.GROUP].attrs.get(key), digest()
    if not isinstance(stored, str) or stored != got:
        r.fail(f"{h5_checksums.GROUP}@{key}", f"the SHA-256 of {what}",
               "a different digest: the file was changed after it was written" if isinstance(stored, str)
               else "missing" if stored is None else repr(stored))


def _mode_count(r: _Reader) -> int:
    """nf as the eigenvalues declare it, checked against every other per-mode dataset before any is read."""
    eigenvalues = r.node("modes/eigenvalues")
    nf = eigenvalues.shape[0] if eigenvalues.ndim == 1 else None
    if nf == 0:
        r.fail("modes/eigenvalues", "at least one flexible mode", "none")
    for name, axis in (("stress/max", 0), ("modes/Phi", 2), ("invariants/mode_sum", 1)):
        ds = r.f.get(name)
        if isinstance(ds, h5py.Dataset) and nf is not None and ds.ndim > axis and ds.shape[axis] != nf:
            r.fail("modes/eigenvalues", f"as many modes as {name} has ({ds.shape[axis]})", str(nf))
    return nf


def _geometric(r: _Reader, nf: int) -> np.ndarray | None:
    if "geometric_stiffness" not in r.f:
        return None
    G = r.array("geometric_stiffness/G", (6, nf, nf))
    if np.abs(G - G.transpose(0, 2, 1)).max() > 1e-12 * max(np.abs(G).max(), 1e-300):
        r.fail("geometric_stiffness/G", "six symmetric matrices")
    return G


def _static_centrifugal(r: _Reader) -> StaticCentrifugal | None:
    if "static_centrifugal" not in r.f:
        return None
    compliance = r.array("static_centrifugal/compliance", (3,))
    sigma = r.array("static_centrifugal/sigma", (3,))
    if np.any(compliance < 0) or np.any(sigma < 0):
        r.fail("static_centrifugal", "non-negative compliances and stresses")
    return StaticCentrifugal(compliance, sigma)


def _material(r: _Reader) -> Material | None:
    if "material" not in r.f:
        return None
    g = r.node("material", group=True)
    values = {key: float(r.number(key, g, want, ok)) for key, ok, want in (
        ("E", lambda v: v > 0, "a positive number"), ("rho", lambda v: v > 0, "a positive number"),
        ("nu", lambda v: -1 < v < 0.5, "a number in (-1, 0.5)"))}
    from ..fe.material import Material
    return Material(str(r.attr("name", g)), values["E"], values["nu"], values["rho"])


def _read_fe(r: _Reader, nf: int, material: Material | None) -> ModalFE:
    mesh = _mesh(r)
    n = mesh.n_nodes
    if nf > 3 * n:
        r.fail("modes/eigenvalues", f"at most 3n = {3 * n} modes for the {n} nodes of the mesh", str(nf))
    r.budget.take("modes/eigenvalues", 12.0 * 8 * nf * nf)  # the invariants Sbar and spin computed from them
    Ms = _mass(r, n)
    _phi(r, n, nf)
    Phi = r.array("modes/Phi", (n, 3, nf))
    K = r.csr("stiffness/K", (3 * n, 3 * n)) if "stiffness/K" in r.f else None
    stress = r.array("stress/nodal", (n, nf)) if "stress/nodal" in r.f else None
    return ModalFE(mesh, Ms, Phi, K, stress, material, _rotary(r, n, nf))


def _streamed(r: _Reader, nf: int) -> tuple[ShapeIntegrals, NodalSummary]:
    """Invariants and nodal summary in one pass over blocks of nodes (``invariants.nodal_pass``) in the reading
    child, which sends back only them. The modes are read whole where the memory limit allows it, else chunk
    by chunk and never held whole, so --max-memory bounds the working set, not the file (docs/format.md,
    "Limits"); the mesh and Ms are read whole and validated as for ``_read_fe``; K is not read (the analysis
    needs only whether it is there); the nodal stresses are validated block by block."""
    with r.kept_in_child():
        mesh = _mesh(r)
        n = mesh.n_nodes
        if nf > 3 * n:
            r.fail("modes/eigenvalues", f"at most 3n = {3 * n} modes for the {n} nodes of the mesh", str(nf))
        r.budget.take("modes/eigenvalues", 12.0 * 8 * nf * nf)  # the invariants Sbar and spin computed from them
        Ms = _mass(r, n)
        ds = _phi(r, n, nf)
        rotary = _rotary(r, n, nf)
        if CHILD_COPIES * 8.0 * ds.size <= r.budget.remaining:  # the modes whole, in the child only
            Phi, rows = r.array("modes/Phi", (n, 3, nf)), block_rows(nf)
            phi_rows = lambda a, b: Phi[a:b]  # noqa: E731
        else:
            declare_work(8.0 * ds.size)  # read chunk by chunk, never charged whole to the memory budget
            rows = _stream_rows(r, ds, nf)
            phi_rows = _checked_rows(r, "modes/Phi", _chunked(r, ds, rows))
    result = nodal_pass(mesh.points, lambda a, b: Ms[a:b], phi_rows, nf,
                        None if rotary is None else rotary.integrals(), rows)
    if "stress/nodal" in r.f:
        _stream_check(r, "stress/nodal", (n, nf), rows)
    return result.integrals, NodalSummary(result.max_deflection, mesh.largest_dimension(), n, "stiffness/K" in r.f)


BLOCKS_HELD = 3 * SPAN + 2  # blocks of Phi rows a streamed pass holds: chunk cache (SPAN + 1), reach, its float copy, Y


def _stream_rows(r: _Reader, ds: h5py.Dataset, nf: int) -> int:
    """Nodal rows per block of the streamed pass: ``invariants.block_rows`` in whole chunks, fewer where the
    memory limit left is smaller (charged to the budget; refused when a single chunk's blocks do not fit)."""
    chunk = ds.chunks[0] if ds.chunks else 1
    per_row = 8.0 * 3 * nf * BLOCKS_HELD
    fit = int(r.budget.remaining / 2 / per_row) // chunk * chunk
    rows = max(chunk, min(block_rows(nf, chunk), fit))
    r.budget.take("modes/Phi", per_row * rows, copies=1)  # the child's working set only
    return rows


def _chunked(r: _Reader, ds: h5py.Dataset, rows: int) -> h5py.Dataset:
    """``ds`` opened with a chunk cache of SPAN + 1 blocks, so each compressed chunk is inflated once while the
    blocks of ``nodal_pass`` reach their neighbours (h5py's default cache holds 1 MiB)."""
    row_bytes = 8 * int(np.prod(ds.shape[1:]))
    chunk = 8 * int(np.prod(ds.chunks)) if ds.chunks else 0
    dapl = h5py.h5p.create(h5py.h5p.DATASET_ACCESS)
    dapl.set_chunk_cache(521, (SPAN + 1) * max(chunk, rows * row_bytes), 1.0)
    return h5py.Dataset(h5py.h5d.open(r.f.id, ds.name.encode(), dapl))


def _checked_rows(r: _Reader, name: str, ds: h5py.Dataset):
    """Rows a:b of ``ds`` as finite floats (the field named otherwise), nodal data digested in row order."""
    digest = r.nodal.stream(name, ds.shape) if r.nodal is not None and h5_checksums.is_nodal(name) else None

    def rows(a: int, b: int) -> np.ndarray:
        block = r.read(ds, np.s_[a:b]).astype(float, copy=False)
        if not np.all(np.isfinite(block)):
            r.fail(name, "finite numbers", "NaN or inf")
        if digest is not None:
            digest.add(a, block)
        return block
    return rows


def _stream_check(r: _Reader, name: str, shape: tuple, rows: int) -> None:
    """A per-node dataset validated block by block (shape, numbers, finite) without being held."""
    ds = r.node(name)
    if ds.shape != shape or ds.dtype.kind not in "fiu":
        r.fail(name, f"numbers of shape {shape}", f"{ds.dtype} {tuple(ds.shape)}")
    read = _checked_rows(r, name, ds)
    for a in range(0, shape[0], rows):
        read(a, min(shape[0], a + rows))


def _rotary(r: _Reader, n: int, nf: int) -> NodalRotary | None:
    """Nodes with rotary inertia (theory 3b): indices in range and unique, J symmetric positive semi-definite."""
    if "rotary" not in r.f:
        return None
    nodes = r.array("rotary/nodes", (None,), integer=True)
    k = len(nodes)
    if k and (nodes.min() < 0 or nodes.max() >= n or len(np.unique(nodes)) != k):
        r.fail("rotary/nodes", f"distinct node indices in [0, {n})")
    J = r.array("rotary/J", (k, 3, 3))
    if k and (np.abs(J - J.transpose(0, 2, 1)).max() > 1e-12 * np.abs(J).max()
              or np.linalg.eigvalsh(J).min() < -1e-12 * np.abs(J).max()):
        r.fail("rotary/J", "symmetric positive semi-definite 3x3 inertia tensors")
    return NodalRotary(nodes, J, r.array("rotary/Phi", (k, 3, nf)))
