"""Command-line values coerced without pydantic: text, numbers and paths, alone or repeated.

typer 0.29 coerces every parameter through a pydantic TypeAdapter, built
when the command line is parsed: importing pydantic and building the
adapters costs a command about 60 ms, more than reading and analysing a
cached body. Every parameter of this CLI (and typer's own --help and
completion flags) is ``bool``, ``str``, ``int``, ``float``, ``Path`` or a
list of one of them; for those, ``plain_runtime_param`` gives typer's parameter the
runtime coercion it would build on first use, with click's messages
("'x' is not a valid integer.", "0 is not in the range x>=1.") and typer's
own path checks. Any other annotation keeps typer's coercion.
"""
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, get_args, get_origin

from typer._click.exceptions import BadParameter
from typer._coercion import RuntimeParam
from typer._param_types import coerce_cli_path

NUMBER_WORDS = {int: "integer", float: "number"}
BOOL_WORDS = {"1": True, "true": True, "t": True, "yes": True, "y": True, "on": True,
              "0": False, "false": False, "f": False, "no": False, "n": False, "off": False, "": False}


@dataclass(frozen=True)
class PlainRuntimeParam(RuntimeParam):
    """Coercion of one leaf type (bool, str, int, float, Path), or of each item of a list of it."""

    leaf: type

    def _coerce_value(self, value: Any, param, ctx) -> Any:
        if isinstance(value, (list, tuple)):
            return [self._leaf(item, param, ctx) for item in value]
        return self._leaf(value, param, ctx)

    def _leaf(self, value: Any, param, ctx) -> Any:
        if self.leaf is str:
            return str(value)
        if self.leaf is bool:
            return self._bool(value, param, ctx)
        if self.leaf is Path:
            path_type = self.parameter_info.path_type or Path
            return coerce_cli_path(value if isinstance(value, Path) else Path(value), self.parameter_info,
                                   path_type=path_type, param=param, ctx=ctx)
        return self._number(value, param, ctx)

    @staticmethod
    def _bool(value: Any, param, ctx) -> bool:
        if isinstance(value, bool):
            return value
        word = str(value).strip().lower()
        if word not in BOOL_WORDS:
            raise BadParameter(f"{value!r} is not a valid boolean.", ctx=ctx, param=param)
        return BOOL_WORDS[word]

    def _number(self, value: Any, param, ctx):
        try:
            number = value if type(value) is self.leaf else self.leaf(value)
        except (TypeError, ValueError):
            raise BadParameter(f"{value!r} is not a valid {NUMBER_WORDS[self.leaf]}.", ctx=ctx, param=param) from None
        if not math.isfinite(number):  # inf and nan parse as floats: --f-max inf wrote Infinity into JSON
            raise BadParameter(f"expected a finite number, got {value!r}.", ctx=ctx, param=param)
        low, high = self.parameter_info.min, self.parameter_info.max
        if (low is not None and number < low) or (high is not None and number > high):
            bounds = " and ".join(b for b in (low is not None and f"x>={low}", high is not None and f"x<={high}")
                                  if b)
            raise BadParameter(f"{number} is not in the range {bounds}.", ctx=ctx, param=param)
        return number


def plain_runtime_param(param) -> PlainRuntimeParam | None:
    """The pydantic-free coercion of typer parameter ``param`` (module docstring), None where typer's own is
    needed (other types, parsers, clamped ranges, paths given as str or bytes)."""
    descriptor = param.type_descriptor
    info, annotation = descriptor.parameter_info, descriptor.annotation
    leaf = (get_args(annotation) or (None,))[0] if get_origin(annotation) is list else annotation
    if (leaf not in (bool, str, int, float, Path) or info.parser is not None or info.clamp
            or descriptor.file_annotation is not None or (leaf is Path and info.path_type not in (None, Path))):
        return None
    return PlainRuntimeParam(parameter_info=info, annotation=annotation, leaf=leaf)
