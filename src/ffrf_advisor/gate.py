"""The CI gate: analyse many bodies (in parallel) and compare their level with the model's."""
from __future__ import annotations

import importlib
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

from .errors import FFRFError
from .io import check_reader_options, read_body
from .io.atomic import refuse_inputs
from .io.guard import importing_meanwhile
from .names import LEVELS
from .pool import mapper, workers
from .report.junit import xml_text

if TYPE_CHECKING:
    from .situation import Options

# what a body's record needs after its read, imported while the first reading child parses (as analyze does)
AFTER_READ = ("ffrf_advisor.analysis", "ffrf_advisor.report.json_out")


def gate_one(path: str, options: Options, max_level: str, read_options: dict | None = None,
             after_read: tuple[str, ...] = ()) -> dict:
    """One body's gate record with its wall time; bad input becomes an 'error' entry instead of an exception.
    ``after_read``: modules the caller needs after the run, imported with AFTER_READ while the body is read."""
    start = time.perf_counter()
    record = _gate_record(path, options, max_level, read_options or {}, AFTER_READ + after_read)
    return {**record, "time": time.perf_counter() - start}


def _gate_record(path: str, options: Options, max_level: str, read_options: dict, after_read: tuple) -> dict:
    try:
        check_reader_options(path, read_options)
        with importing_meanwhile(*(m for m in after_read if m not in sys.modules)):  # none: the file libraries
            body = read_body(path, load_fe="summary", **read_options)
        from .analysis import analyze
        from .report.json_out import analysis_json
        result = analysis_json(analyze(body, options), path)
    except Exception as e:  # noqa: BLE001 - one broken body is reported, never ends the run
        message = str(e) if isinstance(e, FFRFError) else f"{path}: unexpected {type(e).__name__}: {str(e)[:300]}"
        return {"file": path, "level": None, "within": False, "error": message, "evidence": [], "warnings": [],
                "analysis": None}
    evidence = [f"rule {r['rule']} {r['name']}: {r['reason']}" for r in result["rules"]
                if r["fired"] and r["rule"] != "I"]
    return {"file": path, "level": result["level"], "error": None, "evidence": evidence,
            "warnings": list(result["warnings"]), "analysis": result,
            "within": LEVELS.index(result["level"]) <= LEVELS.index(max_level)}


CHUNK = 2  # bodies per hand-out: a pickled round trip (about 1 ms) per two bodies, and at the end a worker
# waits for the other's last chunk only (chunks of 7, a quarter of each worker's share, left 1.55-1.59x
# for 60 bodies at --jobs 2; chunks of 2 gave 1.81x, benchmarks/bench_gate.py)


def run_gate(paths: list[str], options: Options, max_level: str, jobs: int, read_options: dict | None = None,
             progress: Callable[[str, int, int], None] | None = None, after_read: tuple[str, ...] = ()) -> list[dict]:
    """Each body's gate record (gate_one) in order, at most ``jobs`` processes (pool.workers) handing out bodies
    ``CHUNK`` at a time; ``progress(file, done, total)`` after each body when given; ``after_read``: modules the
    caller needs after the run (the report's), imported while the first body is read where it is read here."""
    results, jobs = [], workers(jobs, len(paths), CHUNK)
    if jobs > 1:  # the workers fork with them imported
        for name in AFTER_READ:
            importlib.import_module(name)
    args = (options, max_level, read_options, after_read if jobs == 1 else ())
    with mapper(jobs, chunksize=CHUNK, tasks=len(paths)) as map_:
        for record in map_(gate_one, paths, *([x] * len(paths) for x in args)):
            results.append(record)
            if progress is not None:
                progress(record["file"], len(results), len(paths))
    return results


def check_junit_target(path: Path, inputs: list[Path], force: bool) -> None:
    """The JUnit report never replaces a body of the same run, and replaces another file only when it is a
    JUnit report already or with --force."""
    target = Path(path)
    refuse_inputs(target, inputs, "--junit names a body of this run; refusing to overwrite it")
    if target.is_file() and not force and not _is_junit(target):
        raise FFRFError(f"{target}: exists and is not a JUnit report; refusing to overwrite (use --force)")


def _is_junit(path: Path) -> bool:
    import xml.etree.ElementTree as ET
    try:
        return ET.parse(path).getroot().tag in ("testsuites", "testsuite")
    except (ET.ParseError, OSError, ValueError):
        return False


def write_junit(results: list[dict], max_level: str, path: Path) -> None:
    """JUnit XML: <testsuites> with one <testsuite>, one test case per body (with its time); failure text is
    the deciding evidence; every warning of the body goes to the case's system-out (and into the failure
    text), so a pass decided without some measure says so. Names and texts are made valid XML."""
    import xml.etree.ElementTree as ET
    failures = sum(1 for r in results if not r["error"] and not r["within"])
    errors = sum(1 for r in results if r["error"])
    total = f"{sum(r.get('time', 0.0) for r in results):.3f}"
    root = ET.Element("testsuites", name="ffrf-advisor gate", tests=str(len(results)), failures=str(failures),
                      errors=str(errors), time=total)
    suite = ET.SubElement(root, "testsuite", name="ffrf-advisor gate", tests=str(len(results)),
                          failures=str(failures), errors=str(errors), time=total)
    for r in results:
        case = ET.SubElement(suite, "testcase", classname="ffrf-advisor.gate", name=xml_text(r["file"]),
                             time=f"{r.get('time', 0.0):.3f}")
        if r["error"]:
            ET.SubElement(case, "error", message=xml_text(r["error"])).text = xml_text(r["error"])
        elif not r["within"]:
            failure = ET.SubElement(case, "failure", message=f"level {r['level']} exceeds {max_level}")
            failure.text = xml_text("\n".join(r["evidence"] + [f"warning: {w}" for w in r["warnings"]]))
        if r["warnings"]:
            ET.SubElement(case, "system-out").text = xml_text("\n".join(f"warning: {w}" for w in r["warnings"]))
    ET.ElementTree(root).write(path, encoding="utf-8", xml_declaration=True)
