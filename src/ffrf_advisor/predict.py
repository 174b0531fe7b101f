"""Predicted response errors of term sets at an operating point (docs/advice.md; theory sections 5-10).

For a spin ``s`` about a unit axis ``a`` each candidate set T is compared
with the reference set R (the full FFRF, with ``geo_stiff`` where the body
carries G) by linear algebra alone, no time integration. Each prediction
bounds one response error of ``verify`` (verify.measures), on its scales:

- ``frequency``: both sets linearised at steady spin (sim.linearise), their
  mode spectra matched by mode shape (MAC of the modal parts, so that a
  degenerate pair split by the spin counts); ``max |f_T - f_R| / f_R``.
  Bounds the response error of a run that drifts in phase.
- ``mixing``: the shape change by the flexible gyroscopic matrix
  ``Gy = 2 s sum_k a_k W3k^T`` (term ``cor_coupling``) that T lacks: released
  alone at q_max, mode q drives every mode p of the linear gyroscopic system
  (exactly, by its eigenvectors), at most by ``|Gy_pq| T / 2`` within the
  response time T; as stress moved between the modes, the released modes'
  contributions combined by the ten-percent rule (absolute sum where
  frequencies are within 10 %, root-sum-square otherwise). Bounds the change
  of peak stress where frequencies barely move (close modes; a degenerate
  pair's whirl).
- ``static``: the static centrifugal deflection of each set at spin s
  (``q`` with flexible force 0), its stress ``sum_p sigma_p |dq_p|`` and
  deflection ``|dq|``, times the dynamic load factor 2 of a sudden load,
  over the scales of verify (``max(2 sigma(q_R), FLOOR sigma_allow)``,
  ``max(2 |q_R|, FLOOR |q_max|)``); a set without cf1 also misses the
  exact static FE solution's stress where the body carries it (theory 11:
  the modes may not span the widening).
- ``rigid``: the relative error of w. A free spin keeps ``I w + C q'``:
  the inertia change (``I_TT - C C^T``, theory 7) that T leaves out, at the
  deformation of the spinning body (static deflection plus every mode at
  q_max), ``max_k |dI e_k| / I0_kk``, and how far the internal angular
  momentum of the vibrating modes ``C q'``, which a set without the W3 group
  leaves out, moves within the response time, over ``I0_kk s`` (large at
  low spin); both bounded by the triangle inequality over the modes. A
  stiffly connected body's rotation is imposed: no rigid error then.

The modes' amplitude (``excitation``): ``"vibration"`` (default) lets every
mode vibrate at q_max (theory 6), whatever excites it; ``"inertial"`` says
the modes respond only to the body's own rigid motion (spin-up, torque
pulses, slow manoeuvres): their amplitude is then the reference's static
centrifugal deflection times the dynamic load factor, and ``mixing`` and
``rigid`` are evaluated at it (the scales and floors stay on q_max).

At rest (s = 0) every set has the frequencies Omega and no load: all four
vanish (a torque pulse from rest leaves the modes at rest to first order).
"""
from __future__ import annotations

from dataclasses import dataclass
from itertools import combinations

import numpy as np

from .body import FlexibleBody
from .pool import cpus, one_blas_thread, threads
from .sim import equations as eq
from .sim.cost import rhs_cost
from .sim.linearise import best_pairs, modal_spectrum, spin_vector, static_deflection
from .sim.model import Model, build_model
from .terms import BY_ID, FULL, GROUPS, LEVEL_SETS, is_lagrangian, lagrangian_superset, ordered

KINDS = ("frequency", "mixing", "static", "rigid")
MARGIN = 2.0   # a set is adequate when every prediction is below tolerance / MARGIN (first-order estimates add)
DLF = 2.0      # dynamic load factor of a sudden load (theory 10, spin-up and torque pulse)
FLOOR = 0.1    # of |q_max| and sigma_allow: the floors of verify.measures (tested equal)
TERM_LEVEL = {"gyro0": "I", "cf1": "II", "inertia_lin": "II", "cor1": "II", "inertia_quad": "III", "cf2": "III",
              "coupling": "III", "geo_stiff": "III", "cor_quad": "IV", "cor_coupling": "IV"}


@dataclass(frozen=True)
class Candidate:
    """A term set, its predicted errors (the worst over the axes and speeds) and where, and its cost."""

    label: str
    terms: tuple[str, ...]
    errors: dict[str, float]
    axes: dict[str, int]        # index into the axes evaluated, per kind
    cost: float                 # right-hand-side cost over that of the reference (sim.cost)

    @property
    def worst(self) -> tuple[str, float]:
        kind = max(KINDS, key=lambda k: self.errors[k])
        return kind, self.errors[kind]

    def meets(self, tolerance: float) -> bool:
        return self.worst[1] <= tolerance / MARGIN


def level_of(terms) -> str:
    """The guideline level of a term set: the highest level any of its terms belongs to (theory 8)."""
    return max((TERM_LEVEL[t] for t in terms), key=("I", "II", "III", "IV").index)


def reference_terms(body: FlexibleBody) -> tuple[str, ...]:
    """The richest set the body carries: the full FFRF (less groups whose invariants are missing), with
    geo_stiff where the body has G (theory 9)."""
    missing = body.integrals.missing
    terms = [t for t in FULL if not any(g in missing for g in ("W2", "W3") if t in GROUPS[g])]
    return ordered(terms + (["geo_stiff"] if body.geometric is not None and "cf2" in terms else []))


def candidate_sets(body: FlexibleBody, stiff: bool) -> list[tuple[str, tuple[str, ...]]]:
    """(label, terms): the canonical levels (closed to whole energy groups unless the body is stiffly
    connected) and every Lagrangian set, within what the body carries; geo_stiff joins cf2 (theory 9)."""
    allowed = set(reference_terms(body))
    out: dict[tuple[str, ...], str] = {}

    def add(label, terms):
        terms = set(terms) | ({"geo_stiff"} if "cf2" in terms and "geo_stiff" in allowed else set())
        if terms <= allowed:
            out.setdefault(ordered(terms), label)

    for terms in LEVEL_SETS.values():
        terms = terms if stiff else lagrangian_superset(terms)
        add(level_of(terms), terms)
    for n in range(4):
        for groups in combinations(("W1", "W2", "W3"), n):
            add("gyro0" + "".join(f"+{g}" for g in groups), {"gyro0", *(t for g in groups for t in GROUPS[g])})
    return [(label, terms) for terms, label in out.items()]


def _matched_error(f_ref: np.ndarray, V_ref: np.ndarray, f: np.ndarray, V: np.ndarray) -> float:
    """Largest relative frequency error after pairing the modes by shape (MAC), ties by frequency."""
    if len(f) != len(f_ref):
        return np.inf
    if not len(f):
        return 0.0
    A = V_ref / np.linalg.norm(V_ref, axis=0)
    B = V / np.linalg.norm(V, axis=0)
    mac = np.abs(A.conj().T @ B) ** 2
    rel = np.abs(f[None, :] - f_ref[:, None]) / f_ref[:, None]
    rows, cols = best_pairs(mac - 1e-3 * np.minimum(rel, 1.0))
    return float(np.max(rel[rows, cols]))


SAME_EIGENVALUE = 1e-9  # eigenvalues this close (of the largest) are one frequency: far above eigh's round-off (about
# 1e-16 x 2 nf), far below a split that beats within any response time (1e-9 of the top frequency)


def response_time(f1: float, s: float) -> float:
    """How long a response is watched: a few periods of mode 1 and of the rotation, at most 50 of mode 1 (the
    free-spin scene of verify, theory 10); ``f1`` in 1/time, ``s`` in rad/time."""
    return min(max(5 / f1, 3 * 2 * np.pi / s), 50 / f1)


def gyroscopic_transfer(om: np.ndarray, Gy: np.ndarray) -> np.ndarray:
    """(nf, nf): the largest ``|q_p| / A`` that mode q released from ``A`` at rest reaches in the linear system
    ``q'' + Gy q' + diag(om^2) q = 0``: the sum over its frequencies of the moduli of their contributions (exact
    for the system, all modes coupled at once). In ``z = (om q, q')`` the system is ``z' = S z`` with S real skew
    (Gy being skew), so ``-i S`` is Hermitian with real eigenvalues and orthonormal eigenvectors U (``eigh``, no
    inverse): ``q_p(t) = (om_q / om_p) A sum_k U_pk conj(U_qk) exp(i lambda_k t)``. Eigenvalues equal within
    SAME_EIGENVALUE add before the modulus: the result is the same whatever basis the solver picks within a
    degenerate eigenspace (docs/advice.md)."""
    nf = len(om)
    O = np.diag(om)
    lam, U = np.linalg.eigh(-1j * np.block([[np.zeros((nf, nf)), O], [-O, -Gy]]))
    Uq = U[:nf]
    transfer = np.abs(Uq) @ np.abs(Uq).T
    starts = np.flatnonzero(np.diff(lam) > SAME_EIGENVALUE * max(np.abs(lam).max(), 1e-300)) + 1
    for c in np.split(np.arange(2 * nf), starts):
        if len(c) > 1:  # one frequency: its contributions add coherently
            transfer += np.abs(Uq[:, c] @ Uq[:, c].conj().T) - np.abs(Uq[:, c]) @ np.abs(Uq[:, c]).T
    return transfer * om[None, :] / om[:, None]


def ten_percent(R: np.ndarray, om: np.ndarray) -> float:
    """Modal responses R_i at frequencies om_i combined by the ten-percent rule of modal combination:
    ``sqrt(sum R_i^2 + 2 sum_{i<j close} |R_i R_j|)``, close where the frequencies differ by at most 10 %
    (absolute sum within a close group, root-sum-square across well-separated ones)."""
    R = np.abs(R)
    close = np.abs(om[:, None] - om[None, :]) <= 0.1 * np.minimum(om[:, None], om[None, :])
    return float(np.sqrt(R @ close @ R))


def moved_by_mixing(body: FlexibleBody, a: np.ndarray, s: float, amplitude: np.ndarray) -> np.ndarray | None:
    """``R_q``, what mode q released from ``amplitude_q`` at rest moves into the other modes within the response
    time T at spin s about a (``mixing``): ``sum_p sigma_p c_pq amplitude_q``, or ``|c_q| amplitude_q`` without
    stress data, with ``c_pq = min(transfer_pq, |Gy_pq| T / 2)``; None where nothing mixes (one mode, no spin,
    no W3, Gy = 0)."""
    nf = body.nf
    if nf < 2 or s <= 0 or "W3" in body.integrals.missing:
        return None
    W3k = body.integrals.W3().reshape(3, nf, nf)
    Gy = 2 * s * np.einsum("k,krs->sr", a, W3k)
    if not Gy.any():
        return None
    om = np.sqrt(np.abs(body.eigenvalues))
    T = response_time(om[0] / (2 * np.pi), s)
    c = np.minimum(gyroscopic_transfer(om, Gy), np.abs(Gy) * T / 2)
    np.fill_diagonal(c, 0.0)
    if body.sigma_max is None:
        return np.linalg.norm(c, axis=0) * amplitude
    return (np.asarray(body.sigma_max) @ c) * amplitude


def mixing(body: FlexibleBody, a: np.ndarray, s: float, q_max: np.ndarray, sigma_allow: float,
           amplitude: np.ndarray | None = None) -> float:
    """Stress the flexible gyroscopic matrix at spin s about a moves between the modes at their amplitude
    (default q_max) within the response time (``moved_by_mixing``; the resonant growth caps the transfer), the
    released modes' R_q combined by the ten-percent rule over their frequencies, over the scale of verify (at
    least FLOOR of sigma_allow or of |q_max|)."""
    amplitude = np.abs(q_max) if amplitude is None else amplitude
    R = moved_by_mixing(body, a, s, amplitude)
    if R is None:
        return 0.0
    om = np.sqrt(np.abs(body.eigenvalues))
    if body.sigma_max is None:
        return ten_percent(R, om) / max(np.linalg.norm(amplitude), FLOOR * np.linalg.norm(q_max), 1e-300)
    sigma = np.asarray(body.sigma_max)
    return ten_percent(R, om) / max(sigma @ amplitude, FLOOR * sigma_allow, 1e-300)


def most_mixed_mode(body: FlexibleBody, a: np.ndarray, s: float, q_max: np.ndarray) -> int:
    """The mode whose release from q_max the spin mixes most into the others (0-based; mode 1 when none mixes):
    the worst single released mode of the ``mixing`` prediction."""
    R = moved_by_mixing(body, a, s, np.abs(q_max))
    return 0 if R is None or not np.any(R > 0) else int(np.argmax(R))


def _stress(body: FlexibleBody, q: np.ndarray) -> float:
    return float(np.asarray(body.sigma_max) @ np.abs(q))


def exact_widening(body: FlexibleBody, a: np.ndarray, s: float) -> float:
    """Largest von Mises stress of the exact static FE solution at spin s about a principal axis a (theory 11;
    the modes may miss it), 0 where the body carries none or a is no principal axis."""
    if body.static_centrifugal is None:
        return 0.0
    k = int(np.argmax(np.abs(a)))
    return float(body.static_centrifugal.sigma[k] * s**2) if abs(abs(a[k]) - 1) < 1e-9 else 0.0


def static_error(body: FlexibleBody, q: np.ndarray, q_ref: np.ndarray, q_max: np.ndarray,
                 sigma_allow: float, missed: float = 0.0) -> float:
    """Static centrifugal response error with the dynamic load factor, on the scales of verify; ``missed``:
    a stress the set leaves out beyond the modes' (the exact widening stress, for a set without cf1)."""
    dq = q - q_ref
    e = DLF * np.linalg.norm(dq) / max(DLF * np.linalg.norm(q_ref), FLOOR * np.linalg.norm(q_max), 1e-300)
    if body.sigma_max is not None:
        ref = max(_stress(body, q_ref), missed)
        e = max(e, DLF * max(_stress(body, dq), missed) / max(DLF * ref, FLOOR * sigma_allow, 1e-300))
    return float(e)


def inertia_parts(ref: Model, D: np.ndarray, E: np.ndarray | None = None) -> dict[str, np.ndarray]:
    """Elementwise bounds (3, 3) of the groups of ``ref``'s inertia ``I_TT - C C^T`` ("inertia_lin",
    "inertia_quad", "coupling": those ref carries) over every deformation ``sum_i +-D[i]`` (rows: the parts of
    the deformation), by the triangle inequality: the linear terms once per part, the quadratic ones once per
    ordered pair (i, j) (symmetric in i, j: twice per pair i < j). With ``E``: the quadratic terms of the pairs
    of a row of D with a row of E alone, each once (the parts of the rows of D and E together are those of D,
    of E and twice these)."""
    F = D if E is None else E
    parts = {}
    if ref.on("inertia_lin") and E is None:
        parts["inertia_lin"] = np.abs(eq.linear_inertia(ref, D)).sum(axis=0)
    if ref.on("inertia_quad"):
        parts["inertia_quad"] = np.abs(eq.quadratic_inertia(ref, D, F, pairs=True)).sum(axis=(0, 1))  # all pairs
    if ref.on("coupling"):
        CC = np.tensordot(eq.coupling_matrix(ref, D), eq.coupling_matrix(ref, F), axes=([2], [2]))
        CC = CC.transpose(0, 2, 1, 3)  # C_i C_j^T for every pair (i, j, k, l)
        parts["coupling"] = np.abs(0.5 * (CC + np.swapaxes(CC, 2, 3))).sum(axis=(0, 1))
    return parts


def deformation_inertia(ref: Model, amplitude: np.ndarray, q_static: np.ndarray, modal: dict | None = None):
    """``inertia_parts`` over every mode at its amplitude (any signs) plus the static deflection: those of the
    modes alone (``modal``: ``inertia_parts`` of ``diag(amplitude)`` where the caller has them, the same at
    every point of one amplitude), of the static deflection alone and twice those of their pairs."""
    modes, static = np.diag(amplitude), q_static[None, :]
    modal = inertia_parts(ref, modes) if modal is None else modal
    own, pairs = inertia_parts(ref, static), inertia_parts(ref, modes, static)
    return {k: modal[k] + own[k] + 2 * pairs.get(k, 0.0) for k in modal}


def inertia_bound(ref: Model, model: Model, D: np.ndarray) -> np.ndarray:
    """Elementwise bound (3, 3) of ``(I_TT - C C^T)`` of ``ref`` minus that of ``model`` over every deformation
    ``sum_i +-D[i]``: the ``inertia_parts`` of the groups model leaves out."""
    return _left_out(inertia_parts(ref, D), model)


def _left_out(parts: dict[str, np.ndarray], model: Model) -> np.ndarray:
    """The sum of the ``inertia_parts`` of the groups ``model`` does not carry."""
    bound = np.zeros((3, 3))
    for group, part in parts.items():
        if not model.on(group):
            bound += part
    return bound


def momentum_exchange(W3k: np.ndarray, om: np.ndarray, amplitude: np.ndarray, q_static: np.ndarray,
                      T: float) -> np.ndarray:
    """(3,): bound on how far the internal angular momentum ``h_k = q^T W3k[k] q'`` (theory 5; W3k[k] skew)
    of modes vibrating at ``amplitude`` (any phases) about ``q_static`` moves from its start within ``T``
    (docs/advice.md): a pair p, q contributes ``|W_pq| a_p a_q (|dOm| + (Om_p + Om_q) / 2 min(2, |dOm| T))``
    (a part at Om_p + Om_q of amplitude |dOm| a_p a_q / 2, moving by twice that, and a slow beat at
    dOm = Om_q - Om_p, constant for an equal pair: a whirl keeps its own angular momentum), a static
    deflection p with a vibrating mode q ``2 |W_pq| |q_static,p| a_q Om_q``."""
    a, d = np.abs(amplitude), np.abs(om[None, :] - om[:, None])
    pair = np.outer(a, a) * (d + (om[:, None] + om[None, :]) / 2 * np.minimum(2.0, d * T))
    static = 2 * np.outer(np.abs(q_static), a * om)
    return np.einsum("kpq,pq->k", np.abs(W3k), pair / 2 + static)  # pair / 2: each pair is counted twice


def rigid_error(ref: Model, model: Model, q_static: np.ndarray, amplitude: np.ndarray, s: float,
                parts: dict | None = None) -> float:
    """Relative error of w: ``max_k |dI e_k| / I0_kk`` at the static deflection plus every mode at its
    amplitude (any signs), and without the W3 group the internal angular momentum the vibrating modes exchange
    with the rigid motion within the response time (``momentum_exchange``), over ``I0_kk s``; ``parts``: the
    ``deformation_inertia`` where the caller has it (one point, many sets)."""
    parts = deformation_inertia(ref, amplitude, q_static) if parts is None else parts
    I0 = np.diag(ref.I0)
    e = float(np.max(np.linalg.norm(_left_out(parts, model), axis=0) / I0))
    if ref.on("coupling") and not model.on("coupling"):
        om = np.sqrt(np.abs(ref.eigenvalues))
        h = momentum_exchange(ref.W3k, om, amplitude, q_static, response_time(om.min() / (2 * np.pi), s))
        e = max(e, float(np.max(h / (I0 * s))))
    return e


def predictions(body: FlexibleBody, sets: list[tuple[str, tuple[str, ...]]], axes, speeds, q_max: np.ndarray,
                sigma_allow: float, stiff: bool, excitation: str = "vibration") -> list[Candidate]:
    """Every set's predicted errors, the worst over ``axes`` (unit vectors) and ``speeds`` (rad per body time
    unit), against the reference set, with the modes at the ``excitation``'s amplitude; cost relative to the
    reference's right-hand side."""
    ref_terms = reference_terms(body)
    ref = build_model(body, ref_terms)
    models = [build_model(body, terms) for _, terms in sets]
    acting = acting_terms(body)
    keys = [acting(terms) for _, terms in sets]
    distinct = [k for k in dict.fromkeys(keys) if k != acting(ref_terms)]  # the reference's dynamics: errors 0
    own = [keys.index(k) for k in distinct]  # the first set of each distinct dynamics is linearised
    points = [(i_axis, np.asarray(a, float) / np.linalg.norm(a), s)
              for i_axis, a in enumerate(axes) for s in speeds if s > 0]
    errors = np.zeros((len(sets), len(KINDS)))
    where = np.zeros((len(sets), len(KINDS)), dtype=int)
    modal = (None if stiff or excitation != "vibration"  # the modes' own inertia parts: the same at every point
             else inertia_parts(ref, np.diag(modal_amplitude(excitation, q_max, None))))
    for i_axis, a, s in points:
        settled = [bool(np.isinf(errors[i, KINDS.index("frequency")])) for i in own]
        ref_spectrum, rest = _point_spectra(ref, [models[i] for i in own], settled, a, s)
        e = _at(body, ref, models, a, s, q_max, sigma_allow, stiff, excitation, ref_spectrum, modal,
                {i: rest[distinct.index(key)] for i, key in enumerate(keys) if key in distinct})
        worse = e > errors
        errors = np.where(worse, e, errors)
        where = np.where(worse, i_axis, where)
    full = rhs_cost(ref_terms, body.nf)
    return [Candidate(label, terms, dict(zip(KINDS, map(float, errors[i]))), dict(zip(KINDS, map(int, where[i]))),
                      rhs_cost(terms, body.nf) / full) for i, (label, terms) in enumerate(sets)]


def acting_terms(body: FlexibleBody):
    """``terms -> frozenset``: the terms of a set that act on this body; a term whose invariants are all exactly
    zero adds exact zeros (W3 of a body whose modes all move along one direction: a bar bending in one plane, a
    plate's out-of-plane modes), so sets with the same acting terms have the same dynamics and share their
    linearisations."""
    ints = body.integrals
    inert = {g for g, W in (("W1", ints.W1()), ("W2", ints.W2()), ("W3", ints.W3())) if W is not None and not W.any()}
    return lambda terms: frozenset(t for t in terms if BY_ID[t].group not in inert)


def modal_amplitude(excitation: str, q_max: np.ndarray, q_static: np.ndarray) -> np.ndarray:
    """The modes' amplitudes: q_max where they may vibrate freely, the static deflection times the dynamic load
    factor where only the rigid motion drives them (module docstring)."""
    return np.abs(q_max) if excitation == "vibration" else DLF * np.abs(q_static)


THREADED_STATES = 100  # linearisations of at least this many states (nf >= 49) run on two threads


def linearised_spectra(tasks: list[tuple[Model, np.ndarray, float]]) -> list[tuple]:
    """``modal_spectrum`` of each (model, axis, spin). Large ones run on two threads with one BLAS thread each:
    LAPACK's eigensolver releases the GIL, and two eigenproblems of 203 states at once took half the time of
    one after the other, where two BLAS threads for each gained nothing (numpy with OpenBLAS, 2 cores)."""
    workers = min(2, cpus())
    if not tasks or workers < 2 or 2 * tasks[0][0].nf + 3 < THREADED_STATES:
        return [modal_spectrum(*task) for task in tasks]
    with one_blas_thread(), threads(workers) as map_:
        return list(map_(lambda task: modal_spectrum(*task), tasks))


def _point_spectra(ref: Model, models: list[Model], settled: list[bool], a, s: float) -> tuple[tuple, list[tuple]]:
    """(the reference's ``modal_spectrum``, each model's) at spin s about a. A ``settled`` model's frequency
    error is already infinite (its mode count differed at an earlier point: no later point can raise it), so it
    gets only its static deflection, as (None, None, q), and so does the reference where every model is settled:
    the same errors for fewer eigenproblems."""
    everyone, done = (ref, *models), (all(settled), *settled)
    found = iter(linearised_spectra([(m, a, s) for m, skip in zip(everyone, done) if not skip]))
    spectra = [(None, None, static_deflection(m, spin_vector(a, s)[1])) if skip else next(found)
               for m, skip in zip(everyone, done)]
    return spectra[0], spectra[1:]


def _at(body, ref: Model, models, a, s, q_max, sigma_allow, stiff, excitation, ref_spectrum, modal: dict | None,
        spectra) -> np.ndarray:
    """(sets, KINDS) predictions at one spin s about one axis a, from the ``modal_spectrum`` at (a, s) of the
    reference and of each set by its index (``spectra``; a set missing there has the reference's acting terms:
    0; frequencies None: a settled set's, ``_point_spectra``); ``modal``: the modes' own ``inertia_parts`` where
    their amplitudes are the same at every point (``deformation_inertia``)."""
    f_ref, V_ref, q_ref = ref_spectrum
    amplitude = modal_amplitude(excitation, q_max, q_ref)
    mix = mixing(body, a, s, q_max, sigma_allow, amplitude)
    widening = exact_widening(body, a, s)
    parts = None if stiff else deformation_inertia(ref, amplitude, q_ref, modal)  # shared by the sets
    out = np.zeros((len(models), len(KINDS)))
    for i, (f, V, q) in spectra.items():
        model = models[i]
        out[i] = (np.inf if f is None else _matched_error(f_ref, V_ref, f, V),
                  0.0 if model.on("cor_coupling") or not ref.on("cor_coupling") else mix,
                  static_error(body, q, q_ref, q_max, sigma_allow,
                               widening if ref.on("cf1") and not model.on("cf1") else 0.0),
                  0.0 if stiff else rigid_error(ref, model, q_ref, amplitude, s, parts))
    return out


def cheapest(candidates: list[Candidate], tolerance: float) -> Candidate:
    """The cheapest adequate candidate (ties: fewer terms, then the order given); the reference always is."""
    ok = [c for c in candidates if c.meets(tolerance)]
    return min(ok, key=lambda c: (round(c.cost, 9), len(c.terms)))

