"""Start-up of `ffrf-advisor` as a process, against floors measured side by side in the same run (issue 24, item 5).

- `--version` and `--help` against `python -c "import typer"` (the interpreter plus typer, which the CLI
  cannot do without; `--version` alone is answered before typer loads, ffrf_advisor.__main__);
  `python -c pass` shown for scale. Target: at most 1.2x.
- `analyze` of sample_bodies/beam.ffrf.h5 against the import floor `python -c "import numpy, scipy.sparse,
  h5py"`. Target: at most 1.3x; when missed, the largest imports of the command by `-X importtime`.

Every command runs serially, the commands in turn within each repeat (drift hits all alike); the minimum
wall time over the repeats counts. Bytecode is cached (in a scratch PYTHONPYCACHEPREFIX, after one warm-up
run), as in an installation, even where PYTHONDONTWRITEBYTECODE is set.
Run: python benchmarks/bench_startup.py [--repeat N]
"""
from __future__ import annotations

import argparse
import re
import subprocess
import sys
import tempfile
from pathlib import Path

from timing import installed_env, interleaved, wall

BEAM = Path(__file__).resolve().parent.parent / "sample_bodies" / "beam.ffrf.h5"
SCRIPT = Path(sys.executable).with_name("ffrf-advisor")  # the console script users run
CLI = [sys.executable, str(SCRIPT)] if SCRIPT.is_file() else [sys.executable, "-m", "ffrf_advisor"]
ENV: dict[str, str] = {}  # timing.installed_env, set in main
RUNS = {
    "python -c pass": [sys.executable, "-c", "pass"],
    "import typer": [sys.executable, "-c", "import typer"],
    "--version": [*CLI, "--version"],
    "--help": [*CLI, "--help"],
    "analyze --help": [*CLI, "analyze", "--help"],
    "import numpy, scipy.sparse, h5py": [sys.executable, "-c", "import numpy, scipy.sparse, h5py"],
    "analyze beam": [*CLI, "analyze", str(BEAM)],
}
TARGETS = [("--version", "import typer", 1.2), ("--help", "import typer", 1.2),
           ("analyze beam", "import numpy, scipy.sparse, h5py", 1.3)]


def import_tree(command: list[str]) -> list[tuple[str, float, str]]:
    """(module, self ms, what brought it in: the nearest ffrf_advisor module above it, else the first import of
    its chain) of every import of ``command`` by -X importtime."""
    env = {**ENV, "PYTHONPROFILEIMPORTTIME": "1"}
    text = subprocess.run(command, env=env, capture_output=True, text=True, check=True).stderr
    rows = re.findall(r"import time:\s+(\d+) \|\s+\d+ \|( *)(\S+)", text)
    stack: list[str] = []  # the chain of imports down to this module
    out = []  # -X importtime prints a module after what it imported: reversed, the importer comes first
    for self_us, indent, module in reversed(rows):
        depth = (len(indent) - 1) // 2
        stack[depth:] = [module]
        via = next((m for m in reversed(stack) if m.startswith("ffrf_advisor")), stack[0])
        out.append((module, int(self_us) / 1e3, via))
    return out


def extra_imports(command: list[str], floor: list[str]) -> tuple[float, list[tuple[float, str, str]]]:
    """(ms of all imports of ``command`` beyond those of ``floor``, the same by package (two name levels) and by
    what brought them in, largest first)."""
    seen = {module for module, _, _ in import_tree(floor)}
    sums: dict[tuple[str, str], float] = {}
    for module, ms, via in import_tree(command):
        if module not in seen:
            key = (".".join(module.split(".")[:2]), via)
            sums[key] = sums.get(key, 0.0) + ms
    return sum(sums.values()), sorted(((ms, package, via) for (package, via), ms in sums.items()), reverse=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=15, help="runs of each command (the minimum counts)")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="bench-startup-pyc-") as cache:
        ENV.update(installed_env(cache))
        for command in RUNS.values():
            wall(command, env=ENV)  # warm-up: bytecode written
        report(interleaved({name: lambda c=command: wall(c, env=ENV) for name, command in RUNS.items()}, args.repeat))


def report(best: dict[str, float]) -> None:
    """The times, each ratio against its target and, where one is missed, the imports beyond its floor."""
    for name, t in best.items():
        print(f"{name:34s} {t * 1e3:7.1f} ms")
    missed = []
    for name, floor, target in TARGETS:
        ratio = best[name] / best[floor]
        print(f"{name} / {floor}: {ratio:.2f}x (target at most {target}x)")
        if ratio > target:
            missed.append((name, floor))
    for name, floor in missed:
        total, largest = extra_imports(RUNS[name], RUNS[floor])
        print(f"`{name}`: {total:.0f} ms of imports beyond `{floor}` (-X importtime, which inflates them); "
              "the largest, by package and what brought them in:")
        for ms, package, via in largest[:12]:
            print(f"  {ms:7.1f} ms  {package:28s} via {via}")


if __name__ == "__main__":
    main()
