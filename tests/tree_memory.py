"""The peak memory of a CLI run's process tree (tests/test_limits.py, benchmarks/bench_memory.py).

``tree_rss`` runs the CLI in a child interpreter that reports, at exit, its own peak RSS (VmHWM: Linux's
ru_maxrss would keep the peak of the process that spawned it) and the largest peak RSS of the processes it
waited for (the guarded reading child). ``synthetic_body`` writes a body of a
chosen size fast: a hexahedral bar with a lumped mass and smooth mass-normalised bending shapes standing in
for eigenmodes (what is measured is memory, not physics).
"""
from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import scipy.sparse as sp

from ffrf_advisor.body import FlexibleBody, ModalFE
from ffrf_advisor.fe.mesh import box_mesh
from ffrf_advisor.io import write_body

_WRAPPER = """
import atexit, json, resource, sys
from ffrf_advisor.cli import app
def report():
    status = dict(line.split(":", 1) for line in open("/proc/self/status"))
    parent = int(status["VmHWM"].split()[0]) / 1024  # this image's own peak (ru_maxrss keeps the spawner's)
    child = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024  # KiB on Linux
    sys.stderr.write("\\n" + json.dumps({"parent": parent, "child": child}) + "\\n")
atexit.register(report)
sys.argv = ["ffrf-advisor", *sys.argv[1:]]
app()
"""


def tree_rss(args: list[str]) -> tuple[int, str, dict]:
    """Exit code, output (stdout and stderr) and peak RSS [MiB] of the parent and of its largest child for
    ``ffrf-advisor args``."""
    done = subprocess.run([sys.executable, "-c", _WRAPPER, *args], capture_output=True, text=True, timeout=600)
    *errors, rss = done.stderr.strip().splitlines()
    return done.returncode, done.stdout + "\n".join(errors), json.loads(rss)


def synthetic_body(path, divisions: int, nf: int) -> float:
    """Write a bar of ``divisions`` x 10 x 10 hexahedra with ``nf`` modes to ``path``; the bytes of its arrays."""
    mesh = box_mesh([1000.0, 100.0, 100.0], [divisions, 10, 10], "hexahedron")
    n, x = mesh.n_nodes, mesh.points[:, 0] / 1000 + 0.5
    m = np.full(n, 7.85e-2 / n)
    Phi = np.zeros((n, 3, nf))
    Phi[:, 1, :] = np.cos(np.pi * np.outer(x, np.arange(2, nf + 2)))
    Phi /= np.sqrt(np.einsum("i,ikp,ikp->p", m, Phi, Phi))
    fe = ModalFE(mesh=mesh, Ms=sp.diags_array(m).tocsr(), Phi=Phi)
    lam = (2 * np.pi * 10.0 * np.arange(1, nf + 1)) ** 2
    write_body(FlexibleBody(name="bar", integrals=fe.integrals(), eigenvalues=lam, fe=fe), path, overwrite=True)
    Ms = fe.Ms
    return float(Phi.nbytes + mesh.points.nbytes + sum(c.nbytes for c in mesh.cells.values())
                 + Ms.data.nbytes + Ms.indices.nbytes + Ms.indptr.nbytes)
