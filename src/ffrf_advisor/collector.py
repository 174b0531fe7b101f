"""Python's cyclic garbage collector while the tool starts: off from the command line's start
(ffrf_advisor.__main__) until its first forked child is done (io.atomic.forked_child), then on with what
start-up made frozen out of its scans.

Start-up makes tens of thousands of long-lived objects (modules, classes, functions) and no garbage, yet the
collector scanned them again and again, in the tool and, touching their pages, in the reading child it forks:
about 50 ms of every command (analyze of the beam and of the 100-mode bar 0.33 s against 0.38 s and 0.35 s
against 0.40 s, minima of 15 runs). This is the pattern Python's gc documentation gives for processes that
fork: the collector off early, gc.freeze() right before the fork, on again in the child. Only a pause of the
tool's own is resumed: a program that uses the package with the collector off keeps it off.
"""
import gc

_paused = [False]


def pause() -> None:
    """The collector off while the tool starts (the command line only)."""
    gc.disable()
    _paused[0] = True


def before_fork() -> None:
    """Where start-up holds the collector off: what exists frozen, so that the child's collections leave the
    parent's objects, and so their pages, alone."""
    if _paused[0]:
        gc.freeze()


def resume() -> None:
    """The collector on again after the tool's start-up (``pause``), what exists then frozen out of its scans;
    nothing where it was not paused."""
    if _paused[0]:
        _paused[0] = False
        gc.freeze()
        gc.enable()
