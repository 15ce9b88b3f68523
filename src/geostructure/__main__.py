"""``python -m geostructure`` and the ``geostructure`` command: the command line, with an
interrupt during start-up (while numpy and friends load, or the options are built) answered
as one during work."""

import ctypes
import faulthandler
import os
import signal
import sys
import threading


def prefer_small_pages() -> None:
    """Ask numpy for ordinary 4 KB pages instead of transparent huge pages, unless the user
    chose (``NUMPY_MADVISE_HUGEPAGE``, numpy's own switch, read when numpy is imported).

    On a virtual machine that hands freed memory back to its host (free page reporting:
    Firecracker and many cloud VMs), first touching a huge page costs about 10 ms a
    megabyte against 0.4 ms for small pages (256 MB: 2.6 s against 0.11 s), which made
    a third of a measure's time. On a physical machine huge pages save a fraction of
    that small cost. Set here, at the command's start, and inherited by the worker
    processes it starts; the library itself sets nothing (``docs/design.md``, "Reused memory").
    """
    choice = os.environ.setdefault("NUMPY_MADVISE_HUGEPAGE", "0")
    numpy = sys.modules.get("numpy")
    if numpy is not None:  # imported already (run() called from Python): numpy's own setter
        core = getattr(numpy, "_core", None) or getattr(numpy, "core", None)
        setter = getattr(getattr(core, "multiarray", None), "_set_madvise_hugepage", None)
        if setter is not None and choice.strip() in ("0", "1"):
            setter(choice.strip() == "1")


#: glibc's malloc options: one arena, no memory mapped per allocation, and the heap's freed
#: top kept up to 2 GiB. Each as ``mallopt``'s number (M_ARENA_MAX, M_MMAP_MAX,
#: M_TRIM_THRESHOLD) and the environment variable the children read, with its value.
_MALLOC_OPTIONS = ((-8, "MALLOC_ARENA_MAX", 1), (-4, "MALLOC_MMAP_MAX_", 0), (-1, "MALLOC_TRIM_THRESHOLD_", 2**31 - 1))


def reuse_freed_memory() -> bool:
    """Have glibc's malloc keep the memory numpy frees and hand it out again, unless the user
    chose (any ``MALLOC_*`` variable, or ``GLIBC_TUNABLES``).

    glibc maps every allocation over 32 MB afresh and unmaps it when freed, so each large
    array touches new pages: 2.5 million page faults (10 GB) in a measure of 8M points, 5 of
    its 20 CPU seconds in the kernel on a virtual machine. With one arena and nothing mapped
    per allocation, freed arrays are reused: 0.4 million faults, the measure 0.83 of the
    time, its peak within 2%; 0.97 of the time at 0.3M and 0.7M points
    (docs/design.md, "Reused memory"). Set for this process through ``mallopt``, and in
    the environment for the worker processes it starts; the library sets nothing. Elsewhere
    than glibc (macOS, musl), nothing is done. Returns whether it was set.
    """
    if "GLIBC_TUNABLES" in os.environ or any(name.startswith("MALLOC_") for name in os.environ):
        return False
    if not sys.platform.startswith("linux"):
        return False
    try:
        mallopt = ctypes.CDLL("libc.so.6").mallopt
    except (OSError, AttributeError):  # not glibc
        return False
    if not all(mallopt(option, value) == 1 for option, _, value in _MALLOC_OPTIONS):
        return False
    os.environ.update({name: str(value) for _, name, value in _MALLOC_OPTIONS})
    return True


def stacks_on_request() -> None:
    """``kill -USR1 PID`` prints where every thread of a running command is, on stderr, and
    the command goes on: how a run that seems stuck tells what it is doing (the kill test
    asks a run that outlives an interrupt for it)."""
    if hasattr(signal, "SIGUSR1"):  # not on Windows
        faulthandler.register(signal.SIGUSR1, all_threads=True, chain=False)


#: How long after a swallowed interrupt it is sent again (the hook has long returned by then).
REDELIVERY_DELAY_S = 0.05


def interrupts_never_swallowed() -> None:
    """An interrupt that lands where Python cannot raise it (a weak reference's callback, an
    object's finaliser, the garbage collector) is raised again in the main thread.

    Python prints such an exception as "Exception ignored in ..." with its traceback, and
    goes on: a Ctrl-C in a weakref callback while a report was drawn printed Python's
    ``KeyboardInterrupt`` traceback, and the command ran on to exit 0 as if never
    interrupted. Here the signal is raised once more, so the next line of the command's own
    code meets it and the command ends as any interrupt ends it (exit 130, the folder's
    previous set whole). Any other such exception goes to Python's own hook.
    """
    previous = sys.unraisablehook

    def hook(unraisable) -> None:
        if isinstance(unraisable.exc_value, KeyboardInterrupt):
            # Sent again from a thread of its own a moment later, once this hook has returned:
            # raised inside the hook, it would be swallowed again.
            threading.Timer(REDELIVERY_DELAY_S, os.kill, (os.getpid(), signal.SIGINT)).start()
            return
        previous(unraisable)

    sys.unraisablehook = hook


def _interrupt(error: BaseException) -> bool:
    """:func:`geostructure.errors.raised_by_interrupt`, imported only when an error came."""
    from geostructure.errors import raised_by_interrupt  # lazy: the start-up keeps its imports few

    return raised_by_interrupt(error)


def run(argv=None) -> int:
    prefer_small_pages()  # before numpy is imported: it reads the switch then
    reuse_freed_memory()
    stacks_on_request()
    interrupts_never_swallowed()
    try:
        from geostructure.cli import build_parser, main  # lazy on purpose: the import itself may be interrupted

        parser = build_parser()  # and so may the building of the options
    except Exception as exc:  # an interrupt Python wrapped in an error (a class made mid-import)
        if not _interrupt(exc):
            raise
        print("geostructure: interrupted while starting; nothing was written.", file=sys.stderr)
        return 130
    except KeyboardInterrupt:
        print("geostructure: interrupted while starting; nothing was written.", file=sys.stderr)
        return 130
    try:
        code = main(argv, parser=parser)
    except KeyboardInterrupt:  # between the start and the work (main answers one during it)
        print("geostructure: interrupted; nothing was written.", file=sys.stderr)
        code = 130
    # The command has said how it ended; an interrupt while the interpreter shuts down (its
    # threads joined, its memory freed: a second or more after a large run) came out as
    # exit 0 or a death by SIGINT with no word, the outputs whole either way.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    return code


if __name__ == "__main__":
    sys.exit(run())
