"""What a report says, once, for both renderers (report.html, report.pdf): sections of blocks.

A block is one of
  ("fields", [(name, value), ...])        name-value lines
  ("table", (header, rows))               rows of strings
  ("items", [text, ...])                  a list (warnings, notes)
  ("figure", (title, make | Path))        a function that makes a matplotlib figure (made when drawn, one
                                          open at a time), or a PNG file of a verification
Every number carries its unit; every string from a body file is plain text here (the renderers escape).
"""
from __future__ import annotations

import datetime as _dt
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path

import numpy as np

from .. import __version__
from ..analysis import Analysis
from ..io import sha256
from ..predict import KINDS
from ..terms import lagrangian_status
from ..solver_settings import adams_settings
from . import paper_figures as pf
from .json_out import analysis_json


@dataclass
class Section:
    title: str
    blocks: list = field(default_factory=list)
    verdict: bool = False  # drawn as the box on top


@dataclass
class Document:
    title: str
    sections: list[Section]
    meta: list[tuple[str, str]]


def _num(x, unit: str = "", fmt: str = ".4g") -> str:
    if x is None or (isinstance(x, float) and not np.isfinite(x)):
        return "-" if x is None else f"{x} {unit}".strip()
    return f"{x:{fmt}} {unit}".strip()


def _vec(v, unit: str, fmt: str = ".4g") -> str:
    return "[" + ", ".join(f"{x:{fmt}}" for x in np.ravel(v)) + f"] {unit}".rstrip()


def header(a: Analysis, source: str) -> Section:
    """Body, file and its SHA-256, units, mass, CoM, I0, provenance (theory sections 2-4)."""
    b, u = a.body, a.body.units
    p = b.provenance
    fields = [("body", b.name), ("file", source), ("SHA-256", sha256(source)), ("units", str(u)),
              ("mass", _num(b.mass, u.mass, ".6g")), ("CoM", _vec(b.com, u.length)),
              ("I0 (diagonal, principal frame)", _vec(np.diag(b.I0), f"{u.mass} {u.length}^2", ".6g")),
              ("modes", f"{b.nf} flexible, f1 = {_num(b.frequencies_hz[0], u.frequency)}"),
              ("mass matrix", p.mass_matrix), ("method", p.method), ("source", p.source)]
    if b.fe is not None:
        fields.append(("mesh", f"{b.fe.mesh.n_cells} cells ({', '.join(b.fe.mesh.cells)}), {b.fe.mesh.n_nodes} nodes"))
    if b.fe is not None and b.fe.material is not None:
        m = b.fe.material
        fields.append(("material", f"{m.name}: E = {m.E:g} {u.stress}, nu = {m.nu:g}, rho = {m.rho:g} "
                                   f"{u.mass}/{u.length}^3"))
    blocks = [("fields", fields)]
    if p.notes:
        blocks.append(("items", list(p.notes)))
    return Section(f"Body: {b.name}", blocks)


def options_section(a: Analysis, d: dict) -> Section:
    """Every option and threshold the advice used (theory section 8); ``d`` is the analysis JSON."""
    d = d["situation"]
    amp = a.options.amplitudes
    u = a.body.units
    fields = [("speed w_op", _num(d["speed_rad_s"], "rad/s")), ("f_sys", _num(d["f_sys_hz"], "Hz")),
              ("connection", d["connection"]), ("widening", str(d["widening"])),
              ("spin axis", "principal axes" if d["spin_axis"] is None else str(d["spin_axis"])),
              ("sigma_allow", _num(amp.sigma_allow, u.stress)), ("q_cap", _num(amp.q_cap, "(body units)")),
              ("deflection cap", _num(amp.deflection_cap, "of the largest dimension")),
              ("n_ratio", str(a.significance.n_ratio))]
    fields += [(f"threshold {k}", f"{v:g}") for k, v in d["thresholds"].items()]
    return Section("Options and thresholds", [("fields", fields)])


def verdict(a: Analysis, d: dict, study: dict | None = None) -> Section:
    """Level, term set, operating point, the verification's verdict, Lagrangian or not, the evidence per rule,
    every warning, softening, basis, solver; ``d`` is the analysis JSON (report.json_out), ``study`` the verify
    JSON when the report carries a verification."""
    sig = d["significance"]
    checked = ("not run (report --verify, or --verification FILE)" if study is None else
               f"{study['verdict']['verdict']}: {study['verdict']['text']}")
    fields = [("level", d["level"]), ("advised set", ", ".join(d["terms"])), ("operating point", d["operating_point"]),
              ("decided by", d["decided_by"]), ("verification", checked),
              ("Lagrangian", lagrangian_status(d["terms"]))]
    if lagrangian_status(d["terms"]) == "not Lagrangian":
        sup = d["lagrangian_superset"]
        fields.append(("consistent alternative", "none (geo_stiff lies outside the kinetic energy)" if sup is None
                       else f"{', '.join(sup)} (cost x{d['lagrangian_superset_cost']:.3g})"))
    settings = adams_settings(a.advice.terms)
    fields += [("Adams", f"{settings['statement']} ({settings['formulation']})")]
    rules = [(r["rule"], r["name"], _num(r["value"]), _num(r["threshold"]),
              {True: "fired", False: "not fired", None: "not evaluated"}[r["fired"]], ", ".join(r["terms"]) or "-",
              r["reason"]) for r in d["rules"]]
    soft = [(str(k + 1), _num(sig["s_crit"][k] if sig["s_crit"] else None, "rad/s"),
             _num(sig["s_crit_stiffened"][k] if sig["s_crit_stiffened"] else None, "rad/s"),
             str(sig["softening_situation"][k]) if sig["softening_situation"] else "-") for k in range(3)]
    blocks = [("fields", fields)]
    if d["candidates"]:
        tol = d["situation"]["tolerance"]
        blocks.append(("items", [f"Rows I, II, III and IV are the paper's level sets; the advised set is the cheapest "
                                 f"set whose predicted errors stay within {tol:g} / 2, named by the level its terms "
                                 "reach (docs/advice.md)."]))
        blocks.append(("table", (("term set (docs/advice.md)", "level", "rhs cost", *KINDS, f"within {tol:g} / 2"),
                                 [(c["label"], c["level"], f"{c['cost']:.2f}", *(_num(c["errors"][k]) for k in KINDS),
                                   "yes" if c["adequate"] else "no")
                                  for c in sorted(d["candidates"], key=lambda c: c["cost"])])))
    blocks += [("table", (("rule", "measure", "value", "threshold", "outcome", "terms", "reason"), rules)),
              ("table", (("axis", "s_crit", "s_crit with G", "situation (theory 9)"), soft))]
    if d["basis_adequacy"]:
        unit = a.body.units.stress
        blocks.append(("table", (("axis", "energy-norm error", f"widening exact [{unit}]", f"from modes [{unit}]"),
                                 [(str(r["axis"]), _num(r["energy_error"]), _num(r["sigma_exact"]),
                                   _num(r["sigma_modal"])) for r in d["basis_adequacy"]])))
    missing = [f"not evaluable (missing invariants): {name}" for name in sig["not_evaluable"]]
    blocks.append(("items", d["warnings"] + missing or ["no warnings"]))
    return Section(f"Verdict for {a.body.name}: level {d['level']}", blocks, verdict=True)


def paper_tables(analyses: list[Analysis]) -> Section:
    """Tables 2-5 of the paper, one row per body; the sign-independent ratios beside the paper's."""
    def mags(a, name):
        m = a.significance.magnitudes.get(name)
        return ("-", "-", "-") if m is None else (_num(m.max_abs), _num(m.mean_nonzero), _num(m.frobenius))

    def ratio(r):
        return "-" if r is None or r.value is None else _num(r.value)

    t2 = [(a.body.name, *mags(a, "W1"), mags(a, "I0")[2]) for a in analyses]
    t3 = [(a.body.name, *mags(a, "W2"), *mags(a, "W3")) for a in analyses]
    t45 = [(a.body.name, ratio(a.significance.coriolis), ratio(a.significance.coriolis_paper),
            ratio(a.significance.centrifugal), ratio(a.significance.centrifugal_paper)) for a in analyses]
    return Section("Paper tables 2-5", [
        ("table", (("body", "max |W1|", "mean |W1| (nonzero)", "||W1||", "||I0||"), t2)),
        ("table", (("body", "max |W2|", "mean |W2|", "||W2||", "max |W3|", "mean |W3|", "||W3||"), t3)),
        ("table", (("body", "Coriolis ratio (worst signs)", "as in the paper (in phase)",
                    "centrifugal ratio (worst signs)", "as in the paper"), t45)),
    ])


def paper_figures(analyses: list[Analysis]) -> Section:
    return Section("Paper figures" + (" across bodies" if len(analyses) > 1 else ""), [
        ("figure", ("Eigenfrequencies (Fig. 3)", partial(pf.frequencies, analyses))),
        ("figure", ("Maximum von Mises stress per mode (Fig. 5)", partial(pf.stresses, analyses))),
        ("figure", ("q_max per mode with the governing criterion (Fig. 7)", partial(pf.q_max, analyses))),
        ("figure", ("dI_L and dI_Q per mode and axis (Fig. 8)", partial(pf.inertia_change, analyses))),
        ("figure", ("Coupling measures dI_fT, dI_Tf (Fig. 10)", partial(pf.coupling, analyses))),
    ])


def pictures(a: Analysis) -> Section:
    if a.body.W2 is None or a.body.W3 is None:
        blocks = [("items", ["Campbell diagram not drawn: the full FFRF set needs W2 and W3, which this body "
                             "does not carry (an invariants file without I9 or I5)"])]
    else:
        blocks = [("figure", ("Campbell diagram with s_crit", partial(pf.campbell_diagram, a)))]
    if a.body.fe is not None and a.body.fe.mesh.cells:
        blocks.insert(0, ("figure", ("Mesh and first modes at q_max", partial(pf.mesh_and_modes, a))))
    elif a.body.fe is not None:
        blocks.insert(0, ("items", [f"no solid cells to draw ({a.body.fe.mesh.n_nodes} nodes of beams, shells or "
                                    "point masses)"]))
    return Section("Pictures", blocks)


def mode_set_section(a: Analysis) -> Section:
    """Which modes the inertial scenes need (theory 12, the command ``modes``): the advice, per scene, per mode,
    per load case."""
    from ..modeset import INERTIAL_SCENES, advise_modes
    from .modes_out import modes_json
    d = modes_json(advise_modes(a, INERTIAL_SCENES), a.body.name, "")
    pair = lambda x, y: f"{_num(x)} / {_num(y)}"  # noqa: E731
    return Section("Mode set (theory 12)", [
        ("fields", [("advice", d["summary"]), ("loads", d["loads_source"]), ("band", f"{d['band']:g} x f_exc")]),
        *([("items", d["notes"])] if d["notes"] else []),
        ("table", (("scene", "load cases", "f_exc", "set by", "predicted error without / with residual vectors"),
                   [(s["scene"], " ".join(s["cases"]), _num(s["f_exc_hz"], "Hz"), s["excited_by"],
                     pair(s["predicted_error"], s["predicted_error_with_residual_vectors"])) for s in d["scenes"]])),
        ("table", (("mode", "f", "static energy share", "stress share", "decision"),
                   [(str(m["mode"]), _num(m["f_hz"], "Hz"), _num(m["energy_share"]), _num(m["stress_share"]),
                     m["reason"]) for m in d["modes"]])),
        ("table", (("load case", "energy error", "stress error", "residual vector"),
                   [(c["case"], _num(c["energy_error"]), _num(c["stress_error"]),
                     "yes" if c["residual_vector"] else "no") for c in d["cases"]])),
    ])


def verification_section(study: dict) -> Section:
    """The verification (verify JSON, schema verify.json) and its figures."""
    v = study["verdict"]
    rows = [(r["set"], r["scene"], "failed" if r["failed"] else _num(max(
        (e for e in r["errors"].values() if e is not None), default=None)), "yes" if r["meets"] else "no",
        _num(r["energy_drift"]), _num(r["wall_s"], "s"), _num(r.get("speedup"), "x")) for r in study["results"]]
    b, op = study["body"], study.get("operating_point") or {}
    speed = op.get("speed_rad_s")
    blocks = [("fields", [("body", f"{b['name']} ({b['file']})"), ("SHA-256", b.get("sha256", "not stated")),
                          ("speed asked", "not given (at rest)" if speed is None else _num(speed, "rad/s")),
                          ("advice checked at", _num(study["advice"]["speed_rad_s"], "rad/s")),
                          ("date", study.get("date", "not stated")),
                          ("verdict", v["verdict"]), ("statement", v["text"]),
                          ("criterion", study["criterion"]), ("tolerance", _num(study["tolerance"]))]),
              ("table", (("set", "scene", "worst error", "meets", "energy drift", "wall time", "speed-up"), rows))]
    stab = study["stability"]
    if stab is None:
        blocks.append(("items", ["quick verification: no work-precision, stability or Campbell studies"]))
    else:
        blocks.append(("table", (("stability finding", "measured", "predicted"),
                                 [(k, _num(stab[k]["measured"]), _num(stab[k]["predicted"]))
                                  for k in ("rk4_limit_rest", "rk4_limit_spin", "euler_growth") if k in stab])))
    for path in study["figures"]:
        if str(path).endswith(".png") and Path(path).is_file():
            blocks.append(("figure", (Path(path).stem.replace("_", " "), Path(path))))
    return Section("Verification by simulation", blocks)


def body_sections(a: Analysis, source: str, study: dict | None = None, figures: bool = True) -> list[Section]:
    """One body's part; ``figures=False`` in a set, whose comparison already draws every body's series."""
    d = analysis_json(a, source)
    sections = [verdict(a, d, study), header(a, source), options_section(a, d), paper_tables([a]),
                mode_set_section(a)]
    sections += [paper_figures([a]), pictures(a)] if figures else [pictures(a)]
    if study is not None:
        sections.append(verification_section(study))
    return sections


def meta() -> list[tuple[str, str]]:
    return [("tool", f"ffrf-advisor {__version__}"),
            ("date", _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"))]


def single(a: Analysis, source: str, study: dict | None = None) -> Document:
    return Document(f"ffrf-advisor report: {a.body.name}", body_sections(a, source, study), meta())


def collection(analyses: list[Analysis], sources: list[str], studies: list[dict | None]) -> Document:
    """The paper-style comparison across bodies, then one part per body."""
    overview = Section("Levels", [("table", (("body", "file", "level", "terms"),
                                             [(a.body.name, s, a.advice.level, ", ".join(a.advice.terms))
                                              for a, s in zip(analyses, sources)]))], verdict=True)
    sections = [overview, paper_tables(analyses), paper_figures(analyses)]
    for a, s, st in zip(analyses, sources, studies):
        sections += body_sections(a, s, st, figures=False)
    return Document(f"ffrf-advisor report: {len(analyses)} bodies", sections, meta())
