"""``ffrf-advisor`` and ``python -m ffrf_advisor``: the command line (cli.app).

``ffrf-advisor --version`` alone is answered here, before the CLI is built: typer introspects every
command's parameters to build the group before it parses any option (about 40 ms), which the version
line does not need. The cyclic garbage collector stays off while the tool starts (collector).
"""
import os
import sys

from . import collector

# OpenBLAS's idle worker threads spin for 2^n cycles before they sleep (n = 28 by default: about 0.1 s) after
# each multithreaded BLAS call. The commands then run LAPACK on their own threads (the predicted errors' two
# eigenproblems at a time, predict.linearised_spectra) and compiled kernels, and a spinning worker takes a core
# from them: on the 100-mode bar analyze took 1.61x the import floor, 1.46x with the spin cut short
# (benchmarks/bench_analyze.py). 2^16 cycles (tens of microseconds) still keeps workers awake between
# back-to-back BLAS calls. A value the user set is kept; OpenBLAS reads it when numpy loads it.
BLAS_SPIN = ("OPENBLAS_THREAD_TIMEOUT", "16")


def rest_idle_blas_workers() -> None:
    """Give OpenBLAS's idle workers a short spin (BLAS_SPIN) unless the environment sets one."""
    os.environ.setdefault(*BLAS_SPIN)


def main() -> None:
    """Run the command line on sys.argv."""
    if sys.argv[1:] == ["--version"]:
        from . import version_line
        print(version_line())
        return
    rest_idle_blas_workers()
    collector.pause()
    from .cli import app
    app(prog_name="ffrf-advisor")


if __name__ == "__main__":
    main()
