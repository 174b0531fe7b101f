"""Shared FE bodies (built once per session) for the tests, and the simulator's kernels compiled once per run."""
from __future__ import annotations

import os

import numpy as np
import pytest

from ffrf_advisor.fe_body import modal_body
from ffrf_advisor.fe.material import STEEL
from ffrf_advisor.fe.mesh import Box, box_mesh, box_union_mesh

# The simulator's compiled code takes about 35 s to compile on a fresh install (numba caches it on disk for later
# runs). Two pytest-xdist workers that meet it in their first tests would compile all of it twice at once;
# instead each worker compiles its share before its first test (sim.integrate.compile_ahead) and loads the other
# share from the cache when a test needs it. The first compiles the right-hand side (13 s here) that every run
# needs, then RK4 and the Jacobian (17 s in all); the other's share (DOP853 and the midpoint rule, 20 s) ends after
# the right-hand side is cached, so neither compiles it twice (a fresh default suite 120 s against 127-130 s with
# the right-hand side in the longer share, 96 s warm, in one phase of this machine).
KERNEL_SHARES = {"gw0": ("rhs", "rk4"), "gw1": ("dop853", "midpoint")}


def pytest_sessionstart(session):
    share = KERNEL_SHARES.get(os.environ.get("PYTEST_XDIST_WORKER", ""), ())
    if share:
        from ffrf_advisor.sim.integrate import compile_ahead
        compile_ahead(share)

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
