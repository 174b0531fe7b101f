"""Shared FE bodies (built once per session) for the tests."""
from __future__ import annotations

import numpy as np
import pytest

from ffrf_advisor.fe_body import modal_body
from ffrf_advisor.fe.material import STEEL
from ffrf_advisor.fe.mesh import Box, box_mesh, box_union_mesh

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
