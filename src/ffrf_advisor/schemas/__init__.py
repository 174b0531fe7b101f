"""The JSON schemas of the commands' ``--json`` output, shipped in the package (``ffrf-advisor schema NAME``)."""
from __future__ import annotations

import json
from importlib import resources

from ..names import SCHEMA_COMMANDS as COMMANDS


def schema_text(command: str) -> str:
    """The schema of ``command``'s JSON as text (KeyError for an unknown command)."""
    if command not in COMMANDS:
        raise KeyError(command)
    return resources.files(__package__).joinpath(f"{command}.json").read_text(encoding="utf-8")


def schema(command: str) -> dict:
    """The schema of ``command``'s JSON."""
    return json.loads(schema_text(command))
