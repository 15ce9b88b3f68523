"""``python -m geostructure`` and the ``geostructure`` command: the command line, with an
interrupt during start-up (while numpy and friends load, or the options are built) answered
as one during work."""

import sys


def run() -> int:
    try:
        from .cli import build_parser, main  # lazy on purpose: the import itself may be interrupted

        parser = build_parser()  # and so may the building of the options
    except KeyboardInterrupt:
        print("geostructure: interrupted while starting; nothing was written.", file=sys.stderr)
        return 130
    try:
        return main(parser=parser)
    except KeyboardInterrupt:  # between the start and the work (main answers one during it)
        print("geostructure: interrupted; nothing was written.", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(run())
