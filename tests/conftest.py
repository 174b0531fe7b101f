"""Shared FE bodies (built once per session) for the tests, and the simulator's kernels compiled once per run."""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

from ffrf_advisor.fe_body import modal_body
from ffrf_advisor.fe.material import STEEL
from ffrf_advisor.fe.mesh import Box, box_mesh, box_union_mesh

# The simulator's compiled kernels take about 35 s to compile on a fresh install (numba caches them on disk for
# later runs). Two pytest-xdist workers that meet them in their first tests compile each of them twice at once;
# instead, before its first test, each worker runs its share of the integrators once (the right-hand side they
# share is compiled by both), and loads the other share from the cache when a test needs it.
KERNEL_SHARES = {"gw0": ("rk4", "jacobian"), "gw1": ("dop853", "midpoint")}


def pytest_sessionstart(session):
    share = KERNEL_SHARES.get(os.environ.get("PYTEST_XDIST_WORKER", ""), ())
    if share:
        _run_integrators(share)


def _run_integrators(names) -> None:
    """One short run of each integrator in ``names`` ("jacobian": the compiled linearisation) on the beam."""
    from ffrf_advisor.io import read_body
    from ffrf_advisor.sim.integrate import integrate
    from ffrf_advisor.sim.linearise import compiled_jacobian
    from ffrf_advisor.sim.model import build_model, initial_state
    from ffrf_advisor.terms import FULL
    model = build_model(read_body(Path(__file__).parent.parent / "sample_bodies" / "beam.ffrf.h5"), FULL)
    y0 = initial_state(model, (0.0, 0.0, 30.0), np.zeros(model.nf))
    for name in names:
        if name == "jacobian":
            compiled_jacobian(model)(0.0, y0[4:])
        else:
            integrate(model, y0, 1e-4, name, step=None if name == "dop853" else 1e-5)

@pytest.fixture(autouse=True)
def _memory_limit_per_test():
    """Each test starts and ends with the default memory limit: a CLI run with --max-memory sets it for the
    process (io.limits.set_max_bytes), which would hold for the tests after it that read without the CLI."""
    from ffrf_advisor.io import limits
    limits.set_max_bytes(None)
    yield
    limits.set_max_bytes(None)


SLENDER = (1000.0, 20.0, 10.0)  # length/height 100: Euler-Bernoulli within 1 % for two modes


@pytest.fixture(scope="session")
def block_body():
    """A compact steel block 300 x 70 x 40 mm, 27-node hexahedra, 10 modes."""
    return modal_body(box_mesh([300, 70, 40], [10, 3, 2], "hexahedron27"), STEEL, 10, name="block")


@pytest.fixture(scope="session")
def lshape_body():
    """An asymmetric union of boxes (not principal, CoM off the origin before the transform)."""
    boxes = [Box((0, 0, 0), (200, 40, 30)), Box((0, 40, 0), (40, 160, 30)), Box((160, 0, 30), (200, 40, 90))]
    return modal_body(box_union_mesh(boxes, 20.0, "hexahedron27"), STEEL, 8, name="lshape")


@pytest.fixture(scope="session")
def slender_beam():
    """Free-free steel beam 1000 x 20 x 10 mm along x, 20-node hexahedra, 24 modes."""
    return modal_body(box_mesh(SLENDER, [40, 4, 2], "hexahedron20"), STEEL, 24, name="slender")


@pytest.fixture
def rng():
    return np.random.default_rng(20261121)
