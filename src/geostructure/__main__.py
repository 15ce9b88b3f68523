"""``python -m geostructure`` and the ``geostructure`` command: the command line, with an
interrupt during start-up (while numpy and friends load, or the options are built) answered
as one during work."""

import faulthandler
import os
import signal
import sys


def prefer_small_pages() -> None:
    """Ask numpy for ordinary 4 KB pages instead of transparent huge pages, unless the user
    chose (``NUMPY_MADVISE_HUGEPAGE``, numpy's own switch, read when numpy is imported).

    On a virtual machine that hands freed memory back to its host (free page reporting:
    Firecracker and many cloud VMs), first touching a huge page costs about 10 ms a
    megabyte against 0.4 ms for small pages (256 MB: 2.6 s against 0.11 s), which made
    a third of a measure's time. On a physical machine huge pages save a fraction of
    that small cost. Set here, at the command's start, and inherited by the worker
    processes it starts; the library itself sets nothing (``docs/architecture.md``).
    """
    choice = os.environ.setdefault("NUMPY_MADVISE_HUGEPAGE", "0")
    numpy = sys.modules.get("numpy")
    if numpy is not None:  # imported already (run() called from Python): numpy's own setter
        core = getattr(numpy, "_core", None) or getattr(numpy, "core", None)
        setter = getattr(getattr(core, "multiarray", None), "_set_madvise_hugepage", None)
        if setter is not None and choice.strip() in ("0", "1"):
            setter(choice.strip() == "1")


def stacks_on_request() -> None:
    """``kill -USR1 PID`` prints where every thread of a running command is, on stderr, and
    the command goes on: how a run that seems stuck tells what it is doing (the kill test
    asks a run that outlives an interrupt for it)."""
    if hasattr(signal, "SIGUSR1"):  # not on Windows
        faulthandler.register(signal.SIGUSR1, all_threads=True, chain=False)


def run(argv=None) -> int:
    prefer_small_pages()  # before numpy is imported: it reads the switch then
    stacks_on_request()
    try:
        from .cli import build_parser, main  # lazy on purpose: the import itself may be interrupted

        parser = build_parser()  # and so may the building of the options
    except KeyboardInterrupt:
        print("geostructure: interrupted while starting; nothing was written.", file=sys.stderr)
        return 130
    try:
        return main(argv, parser=parser)
    except KeyboardInterrupt:  # between the start and the work (main answers one during it)
        print("geostructure: interrupted; nothing was written.", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(run())
