"""User-facing errors: one line naming the file, the field and what was expected."""
from __future__ import annotations


class FFRFError(Exception):
    """An error the CLI reports as one line with exit code 2."""


class BodyFileError(FFRFError):
    """A body file that cannot be read: which file, which field, what was expected."""

    def __init__(self, path, field: str, expected: str, got: str | None = None):
        self.path, self.field, self.expected, self.got = str(path), field, expected, got
        text = f"{path}: {field}: expected {expected}" + (f", got {got}" if got is not None else "")
        super().__init__(" ".join(text.split()))  # one line, whatever the cause said

    def __reduce__(self):  # travels from the reading child (io.guard) with its fields
        return (BodyFileError, (self.path, self.field, self.expected, self.got))
