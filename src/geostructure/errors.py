"""The one exception type for mistakes a user can fix (bad file, bad parameter)."""


class GeoStructureError(Exception):
    """A user-facing error: the message is one sentence that names the file or the value.

    The command line prints it without a traceback and exits with status 2.
    """
