"""A verification the report includes from a file: the JSON of `verify --json` (schema verify.json), and only
the figures that lie beside it."""
from __future__ import annotations

import json
from pathlib import Path

from ..errors import FFRFError

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
SCHEMA_VERSION = 3  # of `verify --json` (report.verify_json); 3: work_precision, stability, campbell null with --quick
READABLE = (2, SCHEMA_VERSION)  # version 2 is version 3 without the nulls


def read_verification(path: Path) -> dict:
    """The verify JSON at ``path`` with its figures resolved by ``figures_beside``."""
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
        if not isinstance(data, dict) or data.get("schema_version") not in READABLE or "verdict" not in data:
            raise ValueError(f"not the JSON of `verify --json` (schema_version {' or '.join(map(str, READABLE))})")
    except (OSError, ValueError) as e:
        raise FFRFError(f"{path}: --verification: expected the JSON of `verify --json`, got {e}") from None
    figures = data.get("figures")
    data["figures"] = figures_beside(figures if isinstance(figures, list) else [], path.parent)
    return data


def figures_beside(paths: list, folder: Path) -> list[str]:
    """The PNG files among ``paths`` that lie inside ``folder`` (the JSON's folder and below): a relative path
    resolves against the folder, then by its name in it. Others are left out: a JSON must not make the report
    embed files from anywhere on disk."""
    root = folder.resolve()
    found = []
    for text in paths:
        p = Path(str(text))
        for candidate in ([p] if p.is_absolute() else [root / p, root / p.name]):
            c = candidate.resolve()
            if c.is_relative_to(root) and c.suffix == ".png" and _is_png(c):
                found.append(str(c))
                break
    return found


def _is_png(path: Path) -> bool:
    try:
        with open(path, "rb") as f:
            return path.is_file() and f.read(len(PNG_SIGNATURE)) == PNG_SIGNATURE
    except OSError:
        return False
