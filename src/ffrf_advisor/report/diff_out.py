"""`diff` of two body revisions (revision.py) as text, JSON (schema ``diff``) and JUnit XML."""
from __future__ import annotations

import xml.etree.ElementTree as ET

from rich.console import Console

from ..revision import RevisionDiff
from .console import fitted_table, shown
from .json_out import json_number
from .junit import xml_text

SCHEMA_VERSION = 1


def diff_json(d: RevisionDiff, old: str, new: str) -> dict:
    return {"schema_version": SCHEMA_VERSION, "old": old, "new": new, "tolerance": d.tolerance, "same": d.same,
            "paired_by": d.paired_by,
            "pairs": [{"old": a + 1, "new": b + 1, "mac": json_number(m)} for a, b, m in d.pairs],
            "changes": [{"quantity": c.quantity, "difference": c.difference, "exceeds": c.exceeds, "text": c.text}
                        for c in d.changes]}


def diff_report(console: Console, d: RevisionDiff, old: str, new: str) -> None:
    fitted_table(console, f"{shown(old)} -> {shown(new)} (relative changes, tolerance {d.tolerance:g})",
                 ("quantity", "change", "status", "what"),
                 [(c.quantity, f"{c.difference:.3g}", "CHANGED" if c.exceeds else "same", shown(c.text))
                  for c in d.changes], left=("quantity", "status"), prose="what")
    changed = [c.quantity for c in d.changes if c.exceeds]
    console.print("the same model for the multibody code" if d.same else
                  f"a different model: {', '.join(changed)}", highlight=False)


def write_diff_junit(d: RevisionDiff, old: str, new: str, path) -> None:
    """One test case per compared quantity, a failure where it changed beyond the tolerance."""
    failures = sum(c.exceeds for c in d.changes)
    name = xml_text(f"ffrf-advisor diff {old} {new}")
    root = ET.Element("testsuites", name=name, tests=str(len(d.changes)), failures=str(failures), errors="0")
    suite = ET.SubElement(root, "testsuite", name=name, tests=str(len(d.changes)), failures=str(failures),
                          errors="0")
    for c in d.changes:
        case = ET.SubElement(suite, "testcase", classname="ffrf-advisor.diff", name=xml_text(c.quantity))
        if c.exceeds:
            ET.SubElement(case, "failure", message=f"{c.difference:.3g} > {d.tolerance:g}").text = xml_text(c.text)
    ET.ElementTree(root).write(path, encoding="utf-8", xml_declaration=True)
