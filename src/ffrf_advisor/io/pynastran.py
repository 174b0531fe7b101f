"""Calls into pyNastran (the optional extra ``ffrf-advisor[nastran]``): its log, prints and warnings
silenced, its dumps of an input deck switched off, and whatever it raises on a damaged file one line naming
that file."""
from __future__ import annotations

import contextlib
import io
import warnings

from ..errors import BodyFileError


def quietly(path, expected: str, read, *args, **kwargs):
    """``read(*args, log=..., **kwargs)`` with pyNastran silenced; any exception -> BodyFileError(path, "file",
    expected, ...)."""
    from cpylog import SimpleLogger  # installed with pyNastran (nastran._load says when it is missing)

    try:
        with warnings.catch_warnings(), contextlib.redirect_stdout(io.StringIO()), \
                contextlib.redirect_stderr(io.StringIO()), _no_deck_dumps():
            warnings.simplefilter("ignore")
            return read(*args, log=SimpleLogger(level="critical"), **kwargs)
    except (Exception, SystemExit) as e:  # pyNastran raises many kinds on damaged input (struct, assertions)
        raise BodyFileError(path, "file", expected, f"{type(e).__name__}: {' '.join(str(e).split())[:160]}") \
            from None


@contextlib.contextmanager
def _no_deck_dumps():
    """pyNastran's deck reader writing nothing: it has no option to stop dumping the lines read so far into
    the working directory (BDFInputPy._dump_file: pyNastran_crash.bdf on a bad INCLUDE, pyNastran_dump.bdf
    when the deck says ``$pyNastran: dumplines=True``), overwriting a file of that name."""
    from pyNastran.bdf.bdf_interface.pybdf import BDFInputPy

    dump = BDFInputPy._dump_file
    BDFInputPy._dump_file = lambda self, *args: None
    try:
        yield
    finally:
        BDFInputPy._dump_file = dump
