"""Cost of the centrifugal response (static solution of theory 11 + geometric stiffness G_kl of theory 9)
against the modal analysis of the same sample body, side by side in one run.

Prints per body the wall time of the free-free modal analysis (shift-invert Lanczos, 16 modes), of the
static solution of the six load cases (one sparse factorisation) and of the six modal G_kl, and the ratio
(static + G) / modal. Timings are single runs taken serially (each is seconds to minutes).

Run: python benchmarks/bench_geometric.py [NAME ...]   (default: every sample; the carbody needs ~8 GB)
"""
from __future__ import annotations

import argparse
import time

from ffrf_advisor.centrifugal import static_centrifugal
from ffrf_advisor.fe.assembly import mass_matrix, stiffness_matrix
from ffrf_advisor.fe.geometric import modal_geometric
from ffrf_advisor.fe.modal import free_free_modes
from ffrf_advisor.fe_body import fe_body
from ffrf_advisor.body import Provenance
from ffrf_advisor.samples import N_MODES, RECIPES, SAMPLES


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("names", nargs="*", default=list(SAMPLES))
    args = parser.parse_args()
    for name in args.names:
        make_mesh, material, _ = RECIPES[name]
        mesh = make_mesh(1)
        Ms, K = mass_matrix(mesh, material.rho), stiffness_matrix(mesh, material)
        t0 = time.perf_counter()
        modes = free_free_modes(K, Ms, mesh.points, N_MODES)
        t_modal = time.perf_counter() - t0
        body = fe_body(name, mesh, Ms, modes.Phi, modes.eigenvalues, Provenance(), K, None, material)
        t0 = time.perf_counter()
        _, U = static_centrifugal(body.fe, material)
        t_static = time.perf_counter() - t0
        t0 = time.perf_counter()
        modal_geometric(body.fe.mesh, material, body.fe.Phi, U)
        t_G = time.perf_counter() - t0
        print(f"{name:11s} {3 * mesh.n_nodes:7d} DOFs: modal analysis {t_modal:7.2f} s, static (6 cases) "
              f"{t_static:7.2f} s, G_kl {t_G:6.2f} s; (static + G) / modal = {(t_static + t_G) / t_modal:.2f}",
              flush=True)


if __name__ == "__main__":
    main()
