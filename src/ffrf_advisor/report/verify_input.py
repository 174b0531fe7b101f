"""A verification the report includes from a file: the JSON of `verify --json` (schema verify.json), and only
the figures that lie beside it."""
from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING

from ..errors import FFRFError

if TYPE_CHECKING:
    from ..analysis import Analysis
    from ..situation import Situation

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


def operating_point(sit: "Situation") -> dict:
    """The operating point as asked, as ``verify --json`` states it and ``check_matches`` compares it."""
    return {"speed_rad_s": sit.w_op, "speed_range_rad_s": None if sit.speed_range is None else list(sit.speed_range),
            "spin_axis": None if sit.spin_axis is None else list(sit.spin_axis), "principal_axis": sit.principal_axis,
            "connection": sit.connection, "excitation": sit.excitation, "rules": sit.rules}


def check_matches(data: dict, a: "Analysis", body_sha256: str, path: Path) -> None:
    """Refuse (one line) a verification of another body file, operating point, tolerance or advised term set
    than the report's: its verdict would vouch for advice it never checked. The term sets are compared where
    the verification's advice is at the operating point asked (``verify`` analyses again at the scenes' spin
    where that is higher; then its set is the one for that speed)."""
    def refuse(what: str, expected, got) -> None:
        raise FFRFError(f"{path}: --verification {what}: expected {expected} (the report's), got {got}")

    sit = a.options.situation
    given_sha = data.get("body", {}).get("sha256")
    if given_sha != body_sha256:
        refuse("body", f"SHA-256 {body_sha256[:16]}...", "no SHA-256 (run verify --json again)" if given_sha is None
               else f"{data['body'].get('file')} with SHA-256 {str(given_sha)[:16]}...")
    asked = json.loads(json.dumps(operating_point(sit)))
    if data.get("operating_point") != asked:
        refuse("operating point", asked, data.get("operating_point"))
    if data.get("tolerance") != sit.tolerance:
        refuse("tolerance", sit.tolerance, data.get("tolerance"))
    advice = data.get("advice", {})
    if advice.get("speed_rad_s") == sit.w_op and advice.get("excitation") == sit.excitation \
            and advice.get("terms") != list(a.advice.terms):
        refuse("advised terms", "+".join(a.advice.terms), "+".join(map(str, advice.get("terms", []))))
