"""Invariant computation against the bare product Phi^T (Ms Phi), measured in one run.

A 27-node hexahedral box with about 100k nodes (>= 300k DOF) and its
consistent mass matrix; 50 smooth deterministic mode fields stand in for
eigenmodes (computing 50 true eigenmodes of 300k DOF is not what is
measured here). Prints

  time ratio   = time(shape integrals + I0, W1, W2, W3) / time(Phi^T (Ms Phi))   target <= 2
  memory ratio = peak extra memory of the invariants / bytes of Phi            target <= 1.5

Run: python benchmarks/bench_invariants.py
"""
from __future__ import annotations

import time
import tracemalloc

import numpy as np

from ffrf_advisor.fe.assembly import mass_matrix
from ffrf_advisor.fe.material import STEEL
from ffrf_advisor.fe.mesh import box_mesh
from ffrf_advisor.invariants import shape_integrals

NF = 50


def smooth_modes(X: np.ndarray, nf: int) -> np.ndarray:
    rng = np.random.default_rng(0)
    k = rng.normal(size=(nf, 3, 3)) * 3 / np.ptp(X, axis=0)
    phase = rng.uniform(0, 2 * np.pi, (nf, 3))
    Phi = np.empty((len(X), 3, nf))
    for p in range(nf):
        Phi[:, :, p] = np.sin(X @ k[p].T + phase[p])
    return Phi


def invariants(X, Ms, Phi):
    J = shape_integrals(X, Ms, Phi)
    return J.I0(), J.W1(), J.W2(), J.W3()


def best_of(fn, repeat=3) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def main() -> None:
    mesh = box_mesh([460.0, 230.0, 110.0], [46, 23, 11], "hexahedron27")
    Ms = mass_matrix(mesh, STEEL.rho)
    X = mesh.points
    Phi = smooth_modes(X, NF)
    n = len(X)
    Phi2 = Phi.reshape(n, 3 * NF)
    print(f"body: {n} nodes, {3 * n} DOF, {NF} modes, Ms nnz {Ms.nnz}, Phi {Phi.nbytes / 2**20:.1f} MiB")
    t_bare = best_of(lambda: Phi2.T @ (Ms @ Phi2))
    t_inv = best_of(lambda: invariants(X, Ms, Phi))
    tracemalloc.start()
    invariants(X, Ms, Phi)
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    tracemalloc.start()
    Phi2.T @ (Ms @ Phi2)
    _, peak_bare = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    print(f"bare Phi^T (Ms Phi): {t_bare:.3f} s, peak extra {peak_bare / Phi.nbytes:.2f} x Phi")
    print(f"invariants:          {t_inv:.3f} s, peak extra {peak / Phi.nbytes:.2f} x Phi")
    print(f"time ratio   {t_inv / t_bare:.2f}  (target <= 2)")
    print(f"memory ratio {peak / Phi.nbytes:.2f}  (target <= 1.5)")


if __name__ == "__main__":
    main()
