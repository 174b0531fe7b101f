"""Can the kept modes carry the centrifugal load? (theory section 11)

The exact static response u to the centrifugal load f of a spin about a
principal axis (``centrifugal``: one sparse solve of the FE model, stored
with the body as ``StaticCentrifugal``) is compared with what the kept modes
give, ``u_m = Phi Omega^-2 Phi^T f``. Since ``Phi^T f`` is the modal
centrifugal force ``f_cf1`` (theory 5) and ``u_m`` is the K-orthogonal
projection of u,

    |u - u_m|_K^2 / |u|_K^2 = 1 - sum_p f_p^2 / lambda_p / (f^T u),

so the energy-norm error of any mode set follows from the stored compliance
``f^T u`` and the invariants: no FE data is needed here.
"""
from __future__ import annotations

import numpy as np

from .body import StaticCentrifugal
from .significance import f_cf1
from .units import TIME


def energy_error(body, static: StaticCentrifugal, k: int) -> float:
    """|u - u_m|_K / |u|_K about principal axis k for the body's kept modes (module docstring)."""
    f = f_cf1(body, np.eye(3)[k])
    captured = float(np.sum(f**2 / body.eigenvalues))
    c = float(static.compliance[k])
    return float(np.sqrt(max(0.0, 1.0 - captured / c))) if c > 0 else 0.0


def basis_errors(body) -> np.ndarray | None:
    """The energy-norm errors about the three principal axes, None without the stored static response."""
    static = body.static_centrifugal
    return None if static is None else np.array([energy_error(body, static, k) for k in range(3)])


def modal_widening_stress(body, a) -> float:
    """``sum_p |q_c,p| sigma_p`` at unit spin about the unit axis a: the widening stress the kept modes give
    (rule II without the exact solution; an upper bound of their von Mises stress)."""
    return float(np.abs(f_cf1(body, np.asarray(a, float)) / body.eigenvalues) @ body.sigma_max)


def summary(body, w_op: float | None) -> list[dict] | None:
    """Per principal axis: energy-norm error, exact and modal widening stress at w_op (rad/s; per (rad/s)^2
    when None) in the body's stress unit; None without the stored static response."""
    errors = basis_errors(body)
    if errors is None:
        return None
    s2 = (1.0 if w_op is None else w_op**2) * float(TIME[body.units.time]) ** 2
    return [{"axis": k + 1, "energy_error": float(errors[k]),
             "sigma_exact": float(body.static_centrifugal.sigma[k] * s2),
             "sigma_modal": None if body.sigma_max is None else modal_widening_stress(body, np.eye(3)[k]) * s2}
            for k in range(3)]
