"""Command line: argument parsing only; every command calls the public Python API.

``options`` holds what commands share (option types, the measuring options, the frame and
parameters they give); ``measure`` the commands on clouds and output folders; ``reconstruct``
the commands from video or photos; ``rockmass`` the commands on a rock mass's planes (sets). Each depends on ``options`` and the library, never on
this module.
"""

from __future__ import annotations

import argparse
import re
import sys
import warnings
from pathlib import Path

from geostructure import __version__
from geostructure.cli.measure import add_measure_commands
from geostructure.cli.reconstruct import add_reconstruct_commands
from geostructure.cli.rockmass import add_rockmass_commands
from geostructure.errors import GeoStructureError, GeoStructureNote, GeoStructureWarning, raised_by_interrupt
from geostructure.io.outdir import folder_state

EXIT_USER_ERROR = 2


def main(argv=None, parser=None) -> int:
    parser = parser or build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "command", None):
        parser.print_help()
        return EXIT_USER_ERROR
    with warnings.catch_warnings():
        warnings.simplefilter("always")
        # Python's own default: a file left open by an interrupted import or reader is the
        # interpreter's to close, not a message for the user ("unclosed file" on Ctrl-C)
        warnings.simplefilter("ignore", ResourceWarning)
        warnings.showwarning = _warning_printer(quiet=getattr(args, "quiet", False))
        outdir = getattr(args, "outdir", None)
        before = folder_state(outdir)
        try:
            return run_reading_interrupts(args)
        except GeoStructureError as exc:
            print(f"geostructure: error: {one_line(as_options(str(exc)))}", file=sys.stderr)
            return EXIT_USER_ERROR
        except OSError as exc:  # the machine's, not the data's: a disk, a permission, a device
            where = f"{exc.filename}: " if exc.filename else ""
            print(f"geostructure: error: {one_line(f'{where}{exc.strerror or exc}')}.", file=sys.stderr)
            return EXIT_USER_ERROR
        except KeyboardInterrupt:
            print(f"geostructure: interrupted; {interrupted_folder(outdir, before)}", file=sys.stderr)
            return 130


def run_reading_interrupts(args) -> int:
    """Run the command; an error Python raised because of an interrupt (a Ctrl-C inside a
    class being made, which Python wraps in a ``RuntimeError``) is raised as the interrupt,
    before any handler can read it as a failure of the data or the machine."""
    try:
        return args.run(args) or 0
    except Exception as exc:
        if raised_by_interrupt(exc):
            raise KeyboardInterrupt from exc
        raise


def interrupted_folder(outdir, before: tuple) -> str:
    """What an interrupted command leaves in its output folder, read from the folder: the
    commit finishes once begun (:func:`~geostructure.io.atomic.signals_deferred`), so it
    holds the previous set or the new one whole, and the message says which."""
    if outdir is None:
        return "nothing was written."
    if folder_state(outdir) != before:
        return f"{outdir} holds this run's new set, whole (the interrupt came after it was written)."
    return f"{outdir} keeps its previous set (no half-written files)."


def one_line(message: str) -> str:
    """A message as one printable line: a control character quoted from the user's file (a
    vertical tab in a number, say) is written as its escape, not as a break in the line.

    Examples
    --------
    >>> print(one_line("line 2: '5" + chr(11) + "0006' is not a number."))
    line 2: '5\\x0b0006' is not a number.
    """
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in message)


#: `name=value` in a library message: a parameter, written here as its option.
_PARAMETER = re.compile(r"`(\w+)(?:=([^`]*))?`")
_QUOTES_AND_PARENS = "'\"()"


def as_options(message: str) -> str:
    """A library message as a command-line user reads it: the parameters it names in
    backticks become options (`filter='none'` -> --filter none, `mesh=False` -> --no-mesh).

    Examples
    --------
    >>> as_options("try `filter='none'`, `mesh=False`, `up=(X, Y, Z)` or `assume_level=True`.")
    'try --filter none, --no-mesh, --up X Y Z or --assume-level.'
    """

    def option(match: re.Match) -> str:
        flag = "--" + match.group(1).replace("_", "-")
        value = match.group(2)
        if value is None or value == "True":
            return flag
        if value == "False":
            return "--no-" + flag[2:]
        return f"{flag} {value.strip(_QUOTES_AND_PARENS).replace(',', '')}"

    return _PARAMETER.sub(option, message)


def _warning_printer(quiet: bool = False):
    """``warnings.showwarning`` for one command: each message once, however often a value is
    checked (warnings' own "once" forgets whenever a filter changes); notes not when ``quiet``."""
    shown = set()

    def show(message, category, filename, lineno, file=None, line=None):
        if str(message) in shown:
            return
        shown.add(str(message))
        if issubclass(category, GeoStructureNote):
            if not quiet:
                print(f"geostructure: note: {one_line(str(message))}", file=sys.stderr)
        elif issubclass(category, GeoStructureWarning):
            print(f"geostructure: warning: {one_line(str(message))}", file=sys.stderr)
        else:  # a library's own warning got past us: our defect, said as such, never passed off as advice
            print(
                f"geostructure: internal warning (please report it): {category.__name__} at "
                f"{Path(filename).name}:{lineno}: {message}",
                file=sys.stderr,
            )

    return show


class BriefParser(argparse.ArgumentParser):
    """argparse, whose slips are one line and where to read more: its default printed the
    whole usage (some 25 lines for ``measure``) above the one line that says what is wrong."""

    def error(self, message: str):
        self.exit(2, f"{self.prog}: error: {message}; see '{self.prog} --help'.\n")

    def parse_args(self, args=None, namespace=None):
        """argparse's, but an unknown option is reported by its command's parser, whose
        ``--help`` lists the options (argparse's own reports it from the top)."""
        parsed, extras = self.parse_known_args(args, namespace)
        if extras:
            commands = getattr(self, "commands", {})  # the subcommands' parsers, set by build_parser
            commands.get(getattr(parsed, "command", None), self).error(f"unrecognized arguments: {' '.join(extras)}")
        return parsed


def build_parser() -> argparse.ArgumentParser:
    parser = BriefParser(
        prog="geostructure",
        description=("Measure strike, dip and dip direction of the planar surfaces in a point cloud."),
    )
    parser.add_argument("--version", action="version", version=f"geostructure {__version__}")
    sub = parser.add_subparsers(dest="command")

    add_measure_commands(sub)
    add_reconstruct_commands(sub)
    add_rockmass_commands(sub)
    parser.commands = dict(sub.choices)
    return parser
