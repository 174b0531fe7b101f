"""A body written for another multibody code, with a script that runs it there (docs/export.md)."""
