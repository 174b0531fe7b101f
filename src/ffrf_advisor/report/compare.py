"""The paper-style comparison of several bodies (G Figs. 3, 5, 7, 8, 10, Tables 2-5): `compare`."""
from __future__ import annotations

from rich.markup import escape
from rich.table import Table

from ..analysis import Analysis
from ..units import TIME, Units
from .console import shown
from .json_out import SCHEMA_VERSION, json_array, json_number, json_ratio

N_SHOWN = 10  # the paper's figures show the first ten modes


def comparison(analyses: list[Analysis], sources: list[str]) -> dict:
    """One record per body: frequencies, stress, q_max, inertia and coupling measures, norm ratios."""
    bodies = []
    for a, source in zip(analyses, sources):
        b, amp, sig = a.body, a.amplitudes, a.significance
        n = min(N_SHOWN, b.nf)
        bodies.append({
            "file": source, "name": b.name, "units": str(b.units), "mass": b.mass,
            "largest_dimension": json_number(b.largest_dimension()),
            "frequencies": json_array(b.frequencies_hz[:n] / float(TIME[b.units.time])),  # Hz whatever the units
            "sigma_max": json_array(None if b.sigma_max is None else b.sigma_max[:n]),
            "q_max": json_array(amp.q_max[:n]), "q_max_governs": list(amp.governs[:n]),
            "dI_L": json_array(sig.max_first("dI_L")), "dI_Q": json_array(sig.max_first("dI_Q")),
            "dI_fT": json_array(sig.max_first("dI_fT")),
            "dI_Tf": None if sig.dI_Tf is None else json_number(sig.max_first("dI_Tf")),
            "norms": {k: m.frobenius for k, m in sig.magnitudes.items()},
            "coriolis_ratio": json_ratio(sig.coriolis), "centrifugal_ratio": json_ratio(sig.centrifugal),
            "level": a.advice.level, "terms": list(a.advice.terms), "warnings": list(a.advice.warnings),
        })
    return {"schema_version": SCHEMA_VERSION, "shown_modes": N_SHOWN, "bodies": bodies}


def _fmt(x) -> str:
    return "-" if x is None else f"{x:.3g}"


def _vector(xs) -> str:
    return "-" if xs is None else " ".join(_fmt(x) for x in xs)


def comparison_table(data: dict) -> Table:
    """Bodies as columns, quantities as rows (per-mode lists wrap inside their cell)."""
    bodies = data["bodies"]
    table = Table(title=f"comparison (first {data['shown_modes']} modes; measures at q_max, max over modes)",
                  show_lines=True)
    table.add_column("quantity", overflow="fold")
    for b in bodies:
        table.add_column(shown(b["name"], 40), overflow="fold")
    u = _shared_units(bodies)
    rows = [
        ("units", lambda b: b["units"]),
        (f"mass [{u.mass if u else 'units'}]", lambda b: _fmt(b["mass"])),
        (f"largest dimension [{u.length if u else 'units'}]", lambda b: _fmt(b["largest_dimension"])),
        ("f [Hz]", lambda b: _vector(b["frequencies"])),
        (f"sigma_vM at q=1 [{u.stress if u else 'units'}]", lambda b: _vector(b["sigma_max"])),
        (f"q_max [{f'sqrt({u.mass}) {u.length}' if u else 'units'}]", lambda b: _vector(b["q_max"])),
        ("q_max,1 governed by", lambda b: b["q_max_governs"][0]),
        ("dI_L axes 1 2 3", lambda b: _vector(b["dI_L"])),
        ("dI_Q axes 1 2 3", lambda b: _vector(b["dI_Q"])),
        ("dI_fT axes 1 2 3", lambda b: _vector(b["dI_fT"])),
        ("dI_Tf", lambda b: _fmt(b["dI_Tf"])),
        ("|I0| |W1| |W2| |W3|", lambda b: _vector([b["norms"].get(k) for k in ("I0", "W1", "W2", "W3")])),
        ("Coriolis ratio", lambda b: _ratio_text(b["coriolis_ratio"])),
        ("centrifugal ratio", lambda b: _ratio_text(b["centrifugal_ratio"])),
        ("level", lambda b: b["level"]),
    ]
    for label, cell in rows:
        table.add_row(escape(label), *(escape(cell(b)) for b in bodies))  # "[t]" is not markup
    return table


def _shared_units(bodies: list[dict]) -> Units | None:
    """The bodies' common unit system (labels then carry it), None when they differ (see the units row)."""
    names = {b["units"] for b in bodies}
    return Units.parse(names.pop()) if len(names) == 1 else None


def _ratio_text(r: dict | None) -> str:
    if r is None:
        return "n/a"
    if r["both_vanish"]:
        return "both vanish"
    return "inf" if r["value"] is None else _fmt(r["value"])
