"""``python -m geostructure`` and the ``geostructure`` command: the command line, with an
interrupt during start-up (while numpy and friends load) answered as one during work."""

import sys


def run() -> int:
    try:
        from .cli import main  # lazy on purpose: the import itself may be interrupted
    except KeyboardInterrupt:
        print("geostructure: interrupted while starting; nothing was written.", file=sys.stderr)
        return 130
    return main()


if __name__ == "__main__":
    sys.exit(run())
