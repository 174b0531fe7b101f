"""``ffrf-advisor`` and ``python -m ffrf_advisor``: the command line (cli.app).

``ffrf-advisor --version`` alone is answered here, before the CLI is built: typer introspects every
command's parameters to build the group before it parses any option (about 40 ms), which the version
line does not need.
"""
import sys


def main() -> None:
    """Run the command line on sys.argv."""
    if sys.argv[1:] == ["--version"]:
        from . import version_line
        print(version_line())
        return
    from .cli import app
    app(prog_name="ffrf-advisor")


if __name__ == "__main__":
    main()
