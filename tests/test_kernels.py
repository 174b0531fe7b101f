"""The compiled right-hand side on its two storages of Sbar (issue 24, item 6): the numpy reference equations
(sim.equations) for every canonical term set at odd and even mode counts, in strips and tall, the storage size,
RK4 on the Lie group against a numpy RKMK4, and stages that allocate nothing."""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from ffrf_advisor.fe_body import modal_body
from ffrf_advisor.fe.material import STEEL
from ffrf_advisor.fe.mesh import box_mesh
from ffrf_advisor.sim import equations as eq
from ffrf_advisor.sim import kernels
from ffrf_advisor.sim import model as model_module
from ffrf_advisor.sim import rk4
from ffrf_advisor.sim.integrate import Loads, Rhs, _compiled_model, integrate
from ffrf_advisor.sim.model import build_model, compact_blocks, initial_state, product_blocks
from ffrf_advisor.terms import FULL, IDS, LEVEL_SETS

NF = (1, 3, 4, 13, 16, 17, 37)  # below, at and past a strip of 4 rows and a width step of 16; odd and even
CANONICAL = (*LEVEL_SETS.values(), (*FULL, "geo_stiff"), *(("gyro0", t) for t in IDS[1:]))


@pytest.fixture(scope="module")
def block37():
    """A steel block 300 x 70 x 40 mm, 20-node hexahedra, 37 modes (subsets give the other mode counts)."""
    return modal_body(box_mesh([300.0, 70.0, 40.0], [8, 2, 2], "hexahedron20"), STEEL, 37, name="block37")


def _state(rng, model):
    """A random state: unit quaternion, a few hundred rad/s, modes decaying with their index."""
    nf = model.nf
    scale = 0.05 / (1 + np.arange(nf))
    y = initial_state(model, 200 * rng.normal(size=3), scale * rng.normal(size=nf),
                      np.sqrt(np.abs(model.eigenvalues)) * scale * rng.normal(size=nf))
    y[:4] = rng.normal(size=4)
    y[:4] /= np.linalg.norm(y[:4])
    return y


def _assert_kernels_match_reference(model, rng):
    """Compiled against numpy, free and with prescribed rotation, with torque and modal loads: 1e-13 of the
    largest rate (the same operations summed in another order)."""
    for prescribed in (None, (50 * rng.normal(size=3), 500 * rng.normal(size=3))):
        y = _state(rng, model)
        tau, fext = rng.normal(size=3), rng.normal(size=model.nf)
        loads = Loads(torque=lambda t: tau, modal=lambda t: fext,
                      prescribed=None if prescribed is None else (lambda t: prescribed))
        ref = eq.rhs(model, 0.0, y, tau, fext, prescribed)
        got = Rhs(model, loads)(0.0, y)
        assert np.abs(got - ref).max() <= 1e-13 * np.abs(ref).max(), (model.terms, model.nf, prescribed)


@pytest.fixture(params=["tall", "strips"])
def layout(request, monkeypatch):
    """Both storages of the Sbar blocks (sim.model): tall up to tall_max() modes, strips above."""
    monkeypatch.setattr(model_module, "tall_max", lambda: 10**6 if request.param == "tall" else 0)
    return request.param


@pytest.mark.parametrize("nf", NF)
def test_compact_kernels_equal_the_numpy_reference_for_every_canonical_set(block37, rng, nf, layout):
    body = block37.first_modes(nf)
    A = rng.normal(size=(6, nf, nf))
    for terms in CANONICAL:
        model = build_model(body, terms, damping=rng.uniform(0, 0.05, nf), G=A + A.transpose(0, 2, 1))
        _assert_kernels_match_reference(model, rng)


def test_a_body_with_W3_but_no_Sbar_runs_its_W3_terms(block37, rng, layout):
    """Adams' I5 without I9 (theory 3b): the compact blocks then hold W3k / 2, whose skew parts are W3k."""
    ints = block37.integrals
    spin = ints.W3().reshape(3, block37.nf, block37.nf)
    body = replace(block37, integrals=replace(ints, Sbar=None, spin=spin))
    for terms in (("gyro0", "coupling"), ("gyro0", "cor_coupling"), LEVEL_SETS["I"] + ("coupling", "cor_coupling")):
        _assert_kernels_match_reference(build_model(body, terms), rng)


def test_compact_storage_is_about_four_and_a_half_nf_squared():
    """The diagonal blocks' upper halves and one block of each off-diagonal pair, against Sbar and W3k's
    12 nf^2 before (strips padded to widths of 16: 4.6 nf^2 at 200 modes)."""
    nf = 200
    diag, off = compact_blocks(*product_blocks(np.zeros((3, 3, nf, nf))))
    assert (diag.size + off.size) / nf**2 < 4.7


def _qmul(a, b):
    return np.concatenate(([a[0] * b[0] - a[1:] @ b[1:]], a[0] * b[1:] + b[0] * a[1:] + np.cross(a[1:], b[1:])))


def _exp(theta):
    angle = np.linalg.norm(theta)
    return np.concatenate(([np.cos(angle / 2)], np.sinc(angle / (2 * np.pi)) / 2 * theta))


def _rkmk4(model, y, h, steps):
    """RKMK4 with the numpy right-hand side: stage quaternions p exp(a h Theta'), Theta' = dexp^-1(w)."""
    for _ in range(steps):
        k, th = [], []
        for a in (0.0, 0.5, 0.5, 1.0):
            theta = a * h * th[-1] if th else np.zeros(3)
            ys = y + a * h * k[-1] if k else y.copy()
            ys[:4] = _qmul(y[:4], _exp(theta))
            k.append(eq.rhs(model, 0.0, ys))
            w = ys[4:7]
            th.append(w + np.cross(theta, w) / 2 + np.cross(theta, np.cross(theta, w)) / 12)
        p = _qmul(y[:4], _exp(h / 6 * (th[0] + 2 * th[1] + 2 * th[2] + th[3])))
        y = y + h / 6 * (k[0] + 2 * k[1] + 2 * k[2] + k[3])
        y[:4] = p
    return y


@pytest.mark.parametrize("nf", (16, 37))
def test_rk4_lie_equals_a_numpy_rkmk4(block37, rng, nf):
    """20 steps of 1e-5 s on the full set: the compiled loop equals the reference stage for stage (1e-12)."""
    model = build_model(block37.first_modes(nf), FULL)
    y0 = _state(rng, model)
    run = integrate(model, y0, 20e-5, "rk4-lie", 1e-5, output_step=20e-5)
    ref = _rkmk4(model, y0, 1e-5, 20)
    assert np.abs(run.y[-1] - ref).max() <= 1e-12 * np.abs(ref).max()


@pytest.mark.parametrize("nf", (16, 37))
def test_classical_rk4_equals_its_python_reference(block37, rng, nf):
    """The compiled classical RK4 (quaternion normalised after the step) against integrate's Python loop
    (_rk4_step over the same right-hand side): the same states stage for stage (1e-12), and past the explicit
    limit the same failing step and reason."""
    from ffrf_advisor.sim.integrate import _fixed_python
    model = build_model(block37.first_modes(nf), FULL)
    y0 = _state(rng, model)
    run = integrate(model, y0, 20e-5, "rk4", 1e-5, output_step=5e-5)
    ref = _fixed_python(model, y0, 1e-5, 20, 5, "rk4", Loads(), None)
    assert np.abs(run.y - ref.y).max() <= 1e-12 * np.abs(ref.y).max()
    h = 4 * 2 * np.sqrt(2) / np.sqrt(model.eigenvalues.max())  # four times the RK4 limit: the state overflows
    run, ref = integrate(model, y0, 2000 * h, "rk4", h), _fixed_python(model, y0, h, 2000, 1, "rk4", Loads(), None)
    assert run.failed and ref.failed and (run.steps, run.reason) == (ref.steps, ref.reason)


@pytest.mark.parametrize("h_factor", (0.5, 4.0))
def test_rk4_in_chunks_for_a_progress_bar_equals_one_call(block37, rng, h_factor):
    """With a progress callback RK4 runs in chunks of about 1 % (each a call from Python), else in one call:
    the same samples bit for bit, the same evaluations, and past the explicit limit (h_factor 4) the same failing
    step; the callback is told of rising fractions."""
    model = build_model(block37.first_modes(16), FULL)
    y0 = _state(rng, model)
    h = h_factor * 2 * np.sqrt(2) / np.sqrt(model.eigenvalues.max())
    told = []
    chunked = integrate(model, y0, 2000 * h, "rk4", h, output_step=4 * h, progress=told.append)
    whole = integrate(model, y0, 2000 * h, "rk4", h, output_step=4 * h)
    assert np.array_equal(chunked.y, whole.y) and np.array_equal(chunked.t, whole.t)
    assert (chunked.nfev, chunked.steps, chunked.failed, chunked.reason) == \
        (whole.nfev, whole.steps, whole.failed, whole.reason)
    assert whole.failed == (h_factor > 1) and len(told) >= (1 if whole.failed else 100) and told == sorted(told)


def test_rk4_lie_stages_allocate_nothing(block37):
    """Numba's allocation count of rk4_loop is the same for 1 and 50 steps (it was 14 per step)."""
    nrt = pytest.importorskip("numba.core.runtime._nrt_python")
    from numba.core.runtime import rtsys
    model = build_model(block37.first_modes(16), FULL)
    y0, compiled = initial_state(model, (10.0, 5.0, 300.0), (0.04, 0.02)), _compiled_model(model)
    out = np.empty((51, len(y0)))

    def allocations(steps):
        before = rtsys.get_allocation_stats().alloc
        rk4.rk4_loop(kernels.rhs_address(), y0, 1e-5, steps, 1, True, out, compiled)
        return rtsys.get_allocation_stats().alloc - before

    nrt.memsys_enable_stats()
    try:
        allocations(1)
        assert allocations(1) == allocations(50)
    finally:
        nrt.memsys_disable_stats()


@pytest.mark.parametrize("size, level2, expected", [("1024K", "Unified", 66), ("2M", "Data", 93),
                                                    ("256K", "Unified", 48), ("512K", "Instruction", 48),
                                                    (None, None, 48)])
def test_the_tall_storage_reaches_as_far_as_the_l2_cache_holds_it(tmp_path, monkeypatch, size, level2, expected):
    """sim.model.tall_max from Linux's sysfs description of the caches: tall while its 72 nf^2 bytes take at most
    TALL_L2_SHARE of the L2 (data or unified) cache, never below TALL_MAX; an instruction cache, or no
    description, leaves TALL_MAX."""
    caches = [("1", "Data", "32K"), ("1", "Instruction", "32K")] + ([("2", level2, size)] if size else [])
    for k, (level, kind, text) in enumerate(caches):
        index = tmp_path / f"index{k}"
        index.mkdir()
        for name, value in (("level", level), ("type", kind), ("size", text)):
            (index / name).write_text(value + "\n")
    read = model_module.l2_bytes.__wrapped__  # uncached, reading tmp_path
    monkeypatch.setattr(model_module, "l2_bytes", lambda: read(tmp_path))
    assert model_module.tall_max() == expected
    if expected > model_module.TALL_MAX:  # the largest nf whose tall storage takes at most the share
        share = model_module.TALL_L2_SHARE * read(tmp_path)
        assert 72 * expected**2 <= share < 72 * (expected + 1) ** 2
