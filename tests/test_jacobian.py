"""The linearisation's Jacobian (sim.linearise.jacobian) against complex-step derivatives of the plain-numpy
right-hand side: Im f(x + i h e_j) / h with h = 1e-30 is the derivative to rounding (no difference is taken),
an independent computation of what equations.modal_derivatives writes out term by term."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from ffrf_advisor.io import read_body
from ffrf_advisor.sim import linearise as lin
from ffrf_advisor.sim.model import build_model
from ffrf_advisor.terms import FULL, IDS, LEVEL_SETS

DIR = Path(__file__).resolve().parent.parent / "sample_bodies"
ALL = (*FULL, "geo_stiff")
SETS = (*LEVEL_SETS.values(), ALL, *(tuple(t for t in ALL if t != left) for left in ALL))  # each term once off


def complex_step(model, x: np.ndarray) -> np.ndarray:
    """d(rates)/dx at x, column j from one complex state x + i 1e-30 e_j."""
    h = 1e-30
    return (lin._rates(model, x + 1j * h * np.eye(len(x))).imag / h).T


def states(body, rng, count: int = 2):
    """Spinning, deformed, vibrating states (w about 300 rad/s, q and q' at 1e-3 of their natural size)."""
    om = np.sqrt(np.abs(body.eigenvalues))
    for _ in range(count):
        yield np.concatenate([rng.normal(size=3) * 300, rng.normal(size=body.nf) * 1e-3 / om,
                              rng.normal(size=body.nf) * 1e-3])


@pytest.mark.parametrize("name", ["beam", "carbody", "genstruct1", "conrod"])
def test_the_jacobian_is_the_derivative_of_the_rates_for_every_term(name):
    """Every level's set, the full set with geo_stiff and that set with each term left out, modal damping 2 %:
    the columns of q and q' equal the complex-step ones to 1e-12 of each column's largest entry (two exact
    derivatives, rounded in two orders: 1.4e-14 seen), those of w (central differences) to 1e-6 (their
    round-off, eps times the rates' terms over the 1e-6 step: 3e-8 seen)."""
    assert set(ALL) == set(IDS)
    body = read_body(DIR / f"{name}.ffrf.h5")
    rng, nf = np.random.default_rng(7), body.nf
    for terms in SETS:
        if "geo_stiff" in terms and body.geometric is None:
            continue
        model = build_model(body, terms, damping=0.02)
        for x in states(body, rng):
            J, exact = lin.jacobian(model, x), complex_step(model, x)
            off = np.abs(J - exact) / (np.abs(exact).max(axis=0) + 1e-300)
            assert off[:, 3:].max() < 1e-12, (terms, off[:, 3:].max())
            assert off[:, :3].max() < 1e-6, (terms, off[:, :3].max())
            assert np.array_equal(J[3:3 + nf], np.hstack([np.zeros((nf, 3 + nf)), np.eye(nf)]))


def test_frequencies_at_high_spin_are_those_of_the_exact_jacobian():
    """The carbody's full set at 3000 rad/s about its third axis: every oscillation of the Jacobian at the
    equilibrium (|Im mu| above 1e-4 of the largest |mu|) is that of the complex-step one to 1e-8 of itself
    (5e-10 seen). Central differences in q with steps of 1e-6 of q's natural size moved one by 8e-5 there
    (eps times the centrifugal forces over the step)."""
    body = read_body(DIR / "carbody.ffrf.h5")
    model = build_model(body, FULL)
    axis, q, J, _ = lin.equilibrium(model, np.eye(3)[2], 3000.0)
    exact = complex_step(model, np.concatenate([3000.0 * axis, q, np.zeros(body.nf)]))
    mu, mu0 = np.linalg.eigvals(J), np.linalg.eigvals(exact)
    osc = mu0[np.abs(mu0.imag) > 1e-4 * np.abs(mu0).max()]
    assert len(osc) >= 8  # past its critical speeds most are real there; ten oscillate
    assert np.max(np.abs(osc[:, None] - mu[None, :]).min(axis=1) / np.abs(osc)) < 1e-8


@pytest.mark.parametrize("name", ["beam", "carbody", "genstruct1"])
def test_the_static_deflection_balances_the_flexible_forces(name):
    """linearise.static_deflection (K from equations.stiffness_columns, the forces being affine in q) leaves
    flexible_force at 1e-11 of its terms (|Omega^2 q| and the centrifugal load) for every level's set and the
    full set with geo_stiff, at 300 and 3000 rad/s about each axis (a solve's backward error: about 1e-15)."""
    from ffrf_advisor.sim.equations import flexible_force
    body = read_body(DIR / f"{name}.ffrf.h5")
    zero = np.zeros(body.nf)
    for terms in (*LEVEL_SETS.values(), ALL):
        if "geo_stiff" in terms and body.geometric is None:
            continue
        model = build_model(body, terms)
        for s in (300.0, 3000.0):
            for w in s * np.eye(3):
                q = lin.static_deflection(model, w)
                scale = np.abs(model.eigenvalues * q).max() + np.abs(flexible_force(model, zero, zero, w, zero)).max()
                assert np.abs(flexible_force(model, q, zero, w, zero)).max() <= 1e-11 * scale, (terms, s)
