"""The CI gate: analyse many bodies (in parallel) and compare their level with the model's."""
from __future__ import annotations

import xml.etree.ElementTree as ET
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

from rich.console import Console
from rich.progress import Progress

from .analysis import Options, analyze
from .errors import FFRFError
from .guidelines import LEVELS
from .io import read_body
from .report.json_out import analysis_json

PROGRESS_FROM = 5  # show a progress bar from this many bodies on


def gate_one(path: str, options: Options, max_level: str) -> dict:
    """One body's gate record; bad input becomes an 'error' entry instead of an exception."""
    try:
        result = analysis_json(analyze(read_body(path, load_fe=True), options), path)
    except Exception as e:  # noqa: BLE001 - one broken body is reported, never ends the run
        message = str(e) if isinstance(e, FFRFError) else f"{path}: unexpected {type(e).__name__}: {str(e)[:300]}"
        return {"file": path, "level": None, "within": False, "error": message, "evidence": [], "warnings": [],
                "analysis": None}
    evidence = [f"rule {r['rule']} {r['name']}: {r['reason']}" for r in result["rules"]
                if r["fired"] and r["rule"] != "I"]
    return {"file": path, "level": result["level"], "error": None, "evidence": evidence,
            "warnings": list(result["warnings"]), "analysis": result,
            "within": LEVELS.index(result["level"]) <= LEVELS.index(max_level)}


def run_gate(paths: list[str], options: Options, max_level: str, jobs: int, console: Console) -> list[dict]:
    show = len(paths) >= PROGRESS_FROM
    with Progress(console=console, disable=not show, transient=True) as progress:
        task = progress.add_task("analysing bodies", total=len(paths))
        if jobs == 1:
            results = []
            for p in paths:
                results.append(gate_one(p, options, max_level))
                progress.advance(task)
            return results
        with ProcessPoolExecutor(max_workers=jobs) as pool:
            futures = [pool.submit(gate_one, p, options, max_level) for p in paths]
            for f in futures:
                f.add_done_callback(lambda _: progress.advance(task))
            return [f.result() for f in futures]


def write_junit(results: list[dict], max_level: str, path: Path) -> None:
    """JUnit XML: one test case per body; failure text is the deciding evidence; every warning of the body
    goes to the case's system-out (and into the failure text), so a pass decided without some measure says so."""
    suite = ET.Element("testsuite", name="ffrf-advisor gate", tests=str(len(results)),
                       failures=str(sum(1 for r in results if not r["error"] and not r["within"])),
                       errors=str(sum(1 for r in results if r["error"])))
    for r in results:
        case = ET.SubElement(suite, "testcase", classname="ffrf-advisor.gate", name=r["file"])
        if r["error"]:
            ET.SubElement(case, "error", message=r["error"]).text = r["error"]
        elif not r["within"]:
            failure = ET.SubElement(case, "failure", message=f"level {r['level']} exceeds {max_level}")
            failure.text = "\n".join(r["evidence"] + [f"warning: {w}" for w in r["warnings"]])
        if r["warnings"]:
            ET.SubElement(case, "system-out").text = "\n".join(f"warning: {w}" for w in r["warnings"])
    ET.ElementTree(suite).write(path, encoding="utf-8", xml_declaration=True)
