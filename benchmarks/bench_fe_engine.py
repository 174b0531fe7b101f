"""scikit-fem against fe.assembly as the engine behind fe/: speed and peak memory of Ms and K on a tetra10 box.

A 4:2:1 box split into quadratic tetrahedra (fe.split, about --nodes nodes), its consistent scalar mass Ms
(n x n) and its stiffness K (3n x 3n), each assembled by both engines in a child process of its own (the peak
resident memory of a child is that assembly's, interpreter and mesh included; the mesh alone is measured the
same way and printed). Timings are minima over --repeat rounds, the engines taken in turn within each round
(benchmarks/timing.py). Both results are compared entry by entry on the smaller sizes. Not run by CI.

Each child may address MAX_GIB at most (the machine is shared); one that needs more fails and is reported so.

Run: python benchmarks/bench_fe_engine.py [--nodes 125000 1000000] [--matrices Ms K] [--repeat 2]
"""
from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import time

import numpy as np

ENGINES = ("ours", "skfem")
MAX_GIB = 10.0  # address space of a child (the machine is shared): an assembly that needs more fails, reported


def grid(n_nodes: int) -> tuple[int, int, int]:
    """Cells (4k, 2k, k) whose tetra10 mesh has about n_nodes nodes ((8k + 1)(4k + 1)(2k + 1) of them)."""
    k = max(1, round((n_nodes / 64) ** (1 / 3)))
    return 4 * k, 2 * k, k


def mesh_of(n_nodes: int):
    from ffrf_advisor.fe.split import box_split_mesh
    nx, ny, nz = grid(n_nodes)
    return box_split_mesh([4.0 * nx, 2.0 * ny, 1.0 * nz], (nx, ny, nz), "tetra10")


def skfem_mesh(mesh):
    """scikit-fem's MeshTet2 of the same tetrahedra (its own mid-edge numbering), built outside the timing."""
    import skfem
    corners = np.unique(mesh.cells["tetra10"][:, :4])
    assert corners[-1] == len(corners) - 1  # fe.split numbers corners first
    linear = skfem.MeshTet(mesh.points[corners].T.copy(), mesh.cells["tetra10"][:, :4].T.copy())
    return skfem.MeshTet2.from_mesh(linear)


def assemble(engine: str, matrix: str, mesh):
    from ffrf_advisor.fe.material import STEEL
    if engine == "ours":
        from ffrf_advisor.fe.assembly import mass_matrix, stiffness_matrix
        return mass_matrix(mesh, STEEL.rho) if matrix == "Ms" else stiffness_matrix(mesh, STEEL)
    import skfem
    from skfem.models.elasticity import lame_parameters, linear_elasticity
    m = mesh  # a MeshTet2 here
    if matrix == "Ms":  # its rule of degree 7 (24 points): exact on curved elements, as ours (64 points)
        basis = skfem.Basis(m, skfem.ElementTetP2(), intorder=7)
        return skfem.BilinearForm(lambda u, v, w: STEEL.rho * u * v).assemble(basis)
    basis = skfem.Basis(m, skfem.ElementVector(skfem.ElementTetP2()), intorder=2)
    return linear_elasticity(*lame_parameters(STEEL.E, STEEL.nu)).assemble(basis)


def child(engine: str, matrix: str, n_nodes: int) -> None:
    """One assembly (or none: matrix 'mesh'), printing seconds, peak RSS and nnz as JSON."""
    mesh = mesh_of(n_nodes)
    if engine == "skfem":
        mesh = skfem_mesh(mesh)
    t0 = time.perf_counter()
    A = None if matrix == "mesh" else assemble(engine, matrix, mesh)
    seconds = time.perf_counter() - t0
    peak = _high_water_gib()
    print(json.dumps({"seconds": seconds, "peak_gib": peak, "nnz": 0 if A is None else int(A.nnz)}))


def _high_water_gib() -> float:
    """This process's peak resident memory (VmHWM, which exec resets; ru_maxrss would keep the parent's)."""
    for line in open("/proc/self/status"):
        if line.startswith("VmHWM:"):
            return int(line.split()[1]) / 2**20
    return float("nan")


def run(engine: str, matrix: str, n_nodes: int) -> dict:
    cap = int(MAX_GIB * 2**30)
    out = subprocess.run([sys.executable, __file__, "--child", engine, matrix, str(n_nodes)],
                         capture_output=True, text=True,
                         preexec_fn=lambda: resource.setrlimit(resource.RLIMIT_AS, (cap, cap)))
    if out.returncode:
        return {"seconds": float("nan"), "peak_gib": float("nan"), "nnz": 0, "error": out.stderr[-300:]}
    return json.loads(out.stdout.strip().splitlines()[-1])


def agreement(n_nodes: int) -> dict[str, float]:
    """max |ours - skfem| / max |ours| for Ms and K, skfem's DOFs mapped to our nodes by position."""
    from scipy.spatial import cKDTree
    import skfem
    mesh = mesh_of(n_nodes)
    m2 = skfem_mesh(mesh)
    order = cKDTree(skfem.Basis(m2, skfem.ElementTetP2()).doflocs.T).query(mesh.points)[1]
    dofs = (3 * order[:, None] + np.arange(3)).ravel()
    out = {}
    for matrix, index in (("Ms", order), ("K", dofs)):
        ours, theirs = assemble("ours", matrix, mesh), assemble("skfem", matrix, m2)
        out[matrix] = float(abs(ours - theirs[index][:, index]).max() / abs(ours).max())
    return out


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--nodes", type=int, nargs="+", default=[125_000, 1_000_000])
    parser.add_argument("--matrices", nargs="+", default=["Ms", "K"])
    parser.add_argument("--repeat", type=int, default=2)
    parser.add_argument("--agree-nodes", type=int, default=20_000)
    parser.add_argument("--child", nargs=3)
    args = parser.parse_args()
    if args.child:
        child(args.child[0], args.child[1], int(args.child[2]))
        return
    print(f"agreement on {args.agree_nodes} nodes: {agreement(args.agree_nodes)}")
    for n in args.nodes:
        base = run("ours", "mesh", n)
        print(f"\ntetra10 box {grid(n)} cells, about {n} nodes; the mesh alone: peak {base['peak_gib']:.2f} GiB")
        for matrix in args.matrices:
            best = {e: {"seconds": float("inf")} for e in ENGINES}
            for _ in range(args.repeat):
                for e in ENGINES:
                    r = run(e, matrix, n)
                    if not r["seconds"] >= best[e]["seconds"]:
                        best[e] = r
            for e in ENGINES:
                r = best[e]
                print(f"  {matrix:2s} {e:5s}: {r['seconds']:7.2f} s, peak {r['peak_gib']:5.2f} GiB, nnz {r['nnz']}"
                      + (f"  FAILED: {r['error']}" if "error" in r else ""))
            ratio = best["skfem"]["seconds"] / best["ours"]["seconds"]
            mem = best["skfem"]["peak_gib"] / best["ours"]["peak_gib"]
            print(f"  {matrix:2s} skfem / ours: time {ratio:.2f}, peak memory {mem:.2f}")


if __name__ == "__main__":
    main()
