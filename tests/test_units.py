"""Units: parsing, exact factors, and conversion of whole bodies."""
from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest

from ffrf_advisor.invariants import shape_integrals
from ffrf_advisor.units import SI, TMM, Units, UnitsError, factor


def test_parse_and_print():
    assert str(Units.parse("t-mm-N-s")) == "t-mm-N-s"
    assert Units.parse("kg-m-N-s") == SI
    assert str(Units.parse("kg-mm-mN-s")) == "kg-mm-mN-s"
    for bad in ("t-mm-kN-s", "t-mm-N", "lb-in-lbf-s"):
        with pytest.raises(UnitsError):
            Units.parse(bad)


def test_factors_are_exact():
    assert factor(TMM, SI, "mass") == 1000.0
    assert factor(TMM, SI, "inertia") == float(Fraction(1, 1000))
    assert factor(TMM, SI, "stress") == 1e6
    assert factor(TMM, SI, "q") == np.sqrt(1000.0) / 1000.0
    assert factor(TMM, SI, "eigenvalue") == 1.0
    for quantity in ("inertia", "q", "modal_stress", "mode"):
        assert abs(factor(TMM, SI, quantity) * factor(SI, TMM, quantity) - 1) < 1e-15


def test_converted_body_equals_recomputation_in_SI(block_body):
    si = block_body.converted(SI)
    fe = si.fe
    direct = shape_integrals(fe.mesh.points, fe.Ms, fe.Phi)
    for name in ("I", "Ibar", "Sbar"):
        a, b = getattr(direct, name), getattr(si.integrals, name)
        assert np.abs(a - b).max() <= 1e-13 * np.abs(a).max()
    assert si.mass == pytest.approx(block_body.mass * 1000, rel=1e-15)
    assert np.array_equal(si.eigenvalues, block_body.eigenvalues)
    # the same physical stress: sigma [N/mm^2] * q [sqrt(t) mm] -> Pa
    q_tmm = 0.3
    q_si = q_tmm * factor(TMM, SI, "q")
    assert si.sigma_max[0] * q_si == pytest.approx(block_body.sigma_max[0] * q_tmm * 1e6, rel=1e-14)
    back = si.converted(TMM)
    assert np.abs(back.I0 - block_body.I0).max() <= 1e-15 * np.abs(block_body.I0).max()
