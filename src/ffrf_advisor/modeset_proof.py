"""Proof of a mode set by simulation (theory 12, docs/modes.md): the scenes on bases that differ.

Reference: the body with all its modes and the static deflections of all six centrifugal load cases as
residual vectors. Candidates: the advised body (``modeset.reduced_body``), the advised modes without their
residual vectors, the first k modes for several k, and all modes. Every basis runs the same scenes with the same term
set (compiled DOP853); modal coordinates differ between bases, so the runs are compared in what every basis
expresses: the spin w, the orientation, the largest nodal displacement and the peak von Mises stress
recovered from the nodal stress tensors, each relative to the reference's amplitude (theory 10; the last two
to at least a tenth of the deflection at q_max and of sigma_allow, verify's floors). Cost:
right-hand-side evaluations times the cost of one (``sim.cost``), at several tolerances for the
work-precision chart, and the RK4 cost at each basis' stable step ``2 sqrt 2 / Omega_max``.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from .amplitudes import FLOOR
from .analysis import Analysis
from .body import FlexibleBody
from .errors import FFRFError
from .modeset import InertiaLoads, ModeAdvice, reduced_body
from .sim.cost import rhs_cost
from .sim.integrate import rk4_limit
from .sim.model import N_ROT, build_model
from .verify.measures import relative_angle
from .sim.integrate import EXPONENTIAL
from .verify.runner import REF_RTOL, run_scene
from .verify.scenes import make_scenes

MEASURES = ("w", "orientation", "displacement", "stress_peak")
RTOLS = (1e-5, 1e-7, 1e-9)  # the work-precision points of every basis


@dataclass(frozen=True)
class BasisRun:
    """One basis through one scene at one tolerance: its errors against the reference and its cost."""

    basis: str
    size: int
    scene: str
    rtol: float
    errors: dict
    nfev: int
    cost: float   # multiply-adds: nfev x rhs_cost


@dataclass(frozen=True)
class ModeSetProof:
    """The runs of every basis (``runs``), each basis' size and RK4 cost per scene, and the verdict on the
    advised basis at the tightest tolerance."""

    tolerance: float
    terms: tuple[str, ...]
    sizes: dict
    rk4_cost: dict
    runs: list[BasisRun]
    verdict: str
    text: str

    def at(self, basis: str, rtol: float = RTOLS[-1]) -> list[BasisRun]:
        return [r for r in self.runs if r.basis == basis and r.rtol == rtol]


def bases(body: FlexibleBody, advice: ModeAdvice, loads: InertiaLoads) -> dict[str, FlexibleBody]:
    """The reference and the candidate bases by name: the advised body, its modes alone, the first k modes (k at
    a quarter, half and the advised size) and all modes without residual vectors."""
    from .augment import with_residual_vectors
    out = {"reference": with_residual_vectors(body, loads.U, "mode-set reference: all six centrifugal cases "
                                              "as residual vectors"),
           "advised": reduced_body(body, advice, loads)}
    if advice.residual_cases:
        out["advised modes only"] = body.with_modes(list(advice.kept))
    for k in sorted({max(1, body.nf // 4), max(1, body.nf // 2), min(body.nf, advice.size)} - {body.nf}):
        out[f"first {k}"] = body.first_modes(k)
    out["all modes"] = body
    return out


def displacement(body: FlexibleBody, q: np.ndarray) -> np.ndarray:
    """Largest nodal displacement magnitude at each sample, ``max_i |(Phi q)_i|`` (T,)."""
    u = np.einsum("iap,tp->tia", body.fe.Phi, q)
    return np.sqrt((u**2).sum(axis=2)).max(axis=1)


def peak_stress(body: FlexibleBody, q: np.ndarray) -> float:
    """The largest nodal von Mises stress over the run, recovered from the nodal stress tensors of the modes
    (``fe.stress.nodal_stress``: tensors add, von Mises does not), in samples of 50 at a time."""
    from .fe.stress import nodal_stress, von_mises
    S = nodal_stress(body.fe.mesh, body.fe.material, body.fe.Phi)  # (n, 3, 3, nf)
    return float(max(von_mises(np.einsum("nabp,tp->tnab", S, q[a:a + 50])).max() for a in range(0, len(q), 50)))


def _measures(body: FlexibleBody, y: np.ndarray) -> dict:
    q = y[:, N_ROT:N_ROT + body.nf]
    return {"p": y[:, :4], "w": y[:, 4:7], "d": displacement(body, q), "s": peak_stress(body, q)}


def floors(a: Analysis) -> tuple[float, float]:
    """(displacement, stress) below which a difference does not count in full (theory 10, verify.measures):
    a tenth of the largest deflection a mode reaches at its q_max, and a tenth of sigma_allow."""
    reach = np.asarray(a.amplitudes.q_max) * a.body.fe.max_deflection()
    return FLOOR * float(reach.max()), FLOOR * float(a.amplitudes.sigma_allow)


def _errors(m: dict, ref: dict, floor: tuple[float, float]) -> dict:
    """Errors of the measures against the reference's, each relative to its amplitude (theory 10), the
    displacement and the stress at least to their floors."""
    scale = lambda x, least=0.0: max(float(np.abs(x).max()), least, 1e-300)  # noqa: E731
    return {"w": float(np.linalg.norm(m["w"] - ref["w"], axis=1).max() / scale(np.linalg.norm(ref["w"], axis=1))),
            "orientation": float(relative_angle(ref["p"], m["p"]).max()),
            "displacement": float(np.abs(m["d"] - ref["d"]).max() / scale(ref["d"], floor[0])),
            "stress_peak": abs(m["s"] - ref["s"]) / scale(ref["s"], floor[1])}


def prove(a: Analysis, advice: ModeAdvice, loads: InertiaLoads, names, progress=None,
          rtols: tuple[float, ...] = RTOLS) -> ModeSetProof:
    """Run ``names`` on every basis (``bases``) at ``rtols`` (their last, the tightest, judges: RTOLS[-1] by
    default; fewer only make the chart shorter) and judge the advised basis."""
    body = a.body
    if loads.U is None or body.fe is None or body.fe.material is None:
        raise FFRFError("modes --verify: expected nodal FE data with the material (the bases are compared in "
                        "nodal displacements and stresses)")
    all_bases = bases(body, advice, loads)
    terms, floor = advice.terms, floors(a)
    runs, rk4 = [], {}
    scenes = make_scenes(names, a)
    total, done = len(scenes) * (1 + (len(all_bases) - 1) * len(rtols)), 0
    for sc in scenes:
        ref = _run(all_bases["reference"], terms, sc, REF_RTOL, EXPONENTIAL)  # verify's reference integrator
        ref_m = _measures(all_bases["reference"], ref.y)
        for name, b in all_bases.items():
            rk4[(name, sc.label)] = sc.duration / rk4_limit(b.eigenvalues) * 4 * rhs_cost(terms, b.nf)
            for rtol in (rtols if name != "reference" else ()):
                run = _run(b, terms, sc, rtol)
                errs = ({k: np.inf for k in MEASURES} if run.failed or len(run.t) != len(ref.t)
                        else _errors(_measures(b, run.y), ref_m, floor))
                runs.append(BasisRun(name, b.nf, sc.label, rtol, errs, run.nfev, run.nfev * rhs_cost(terms, b.nf)))
                done += 1
                if progress is not None:
                    progress(f"{name}, {sc.label}, rtol {rtol:g}", done, total)
    worst = max((max(r.errors.values()) for r in runs if r.basis == "advised" and r.rtol == rtols[-1]),
                default=0.0)
    ok = worst <= advice.tolerance
    text = (f"the advised basis ({all_bases['advised'].nf} vectors) stays within {advice.tolerance:g} of the "
            f"reference ({all_bases['reference'].nf} vectors) in every scene: largest error {worst:.2g}" if ok else
            f"the advised basis misses the reference by {worst:.2g} > {advice.tolerance:g}")
    return ModeSetProof(advice.tolerance, terms, {n: b.nf for n, b in all_bases.items()}, rk4, runs,
                        "verified" if ok else "unsafe", text)


def _run(body: FlexibleBody, terms, scene, rtol: float, integrator: str = "dop853"):
    """``scene`` (built for the analysed body) on ``body``: the same drive, its modes at rest."""
    zero = np.zeros(body.nf)
    return run_scene(build_model(body, terms, scene.damping), replace(scene, q0=zero, qd0=zero), integrator, rtol=rtol)
