"""The element table of `formats` and docs/elements.md names what each reader's own tables carry (issue 48)."""
from __future__ import annotations

import pytest

from ffrf_advisor.fe import structural
from ffrf_advisor.fe.elements import ELEMENT_TYPES
from ffrf_advisor.io import ansys_cells, calculix, calculix_frd, nastran_mass, nastran_solids, support


def _said(reader: str) -> str:
    return " ".join(kinds[reader] for kinds in support.ELEMENTS.values())


@pytest.mark.parametrize("reader, names", [
    ("calculix", [n.strip() for t in calculix_frd.FRD_TYPES.values() if t.meshio in calculix_frd.SOLIDS
                  for n in t.names.split(" (")[0].split(",")] + list(calculix.EXPANDED) + list(calculix.UNCARRIED)),
    ("meshio", [*ELEMENT_TYPES, *structural.SHELLS, *structural.BEAMS, "vertex"]),
    ("nastran", [*nastran_solids.SOLIDS, *nastran_mass.LINES, "CQUAD4", "CQUAD8", "CTRIA3", "CTRIA6", "CONM2"]),
    ("ansys", [*ansys_cells.SOLIDS, "MASS21"]),
])
def test_every_element_a_reader_carries_is_in_the_table(reader, names):
    said = _said(reader)
    assert [n for n in names if n not in said] == []


def test_the_refusals_the_readers_make_are_in_the_table():
    assert "C3D8R, C3D8I: read with a .mas only" in _said("calculix")
    assert all(f"{name}: " in _said("ansys") or f"{name}, " in _said("ansys")
               for name in ("SHELL181", "SHELL281", "BEAM188", "BEAM189", "MPC184"))


def test_the_console_table_fits_80_columns_and_names_every_reader():
    lines = support.console_lines(80)
    assert max(map(len, lines)) <= 80
    assert sum(line.startswith("  calculix ") for line in lines) == len(support.ELEMENTS)
