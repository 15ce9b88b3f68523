"""Exceptions for mistakes a user can fix: a bad file, a bad parameter, an unusable folder.

Every one is a :class:`GeoStructureError`, whose message is one sentence naming the file or
the value; the command line prints it without a traceback and exits with status 2. Catch
a subclass to handle one kind of failure only.
"""


class GeoStructureError(Exception):
    """A user-facing error: the message is one sentence that names the file or the value.

    Examples
    --------
    >>> from geostructure import read_cloud
    >>> try:
    ...     read_cloud("missing.xyz")
    ... except GeoStructureError as error:
    ...     print(error)
    missing.xyz: no such file.
    """


class InputError(GeoStructureError):
    """An input file cannot be used: missing, unreadable, malformed, or without a plane in it.

    Examples
    --------
    >>> issubclass(InputError, GeoStructureError)
    True
    """


class ParameterError(GeoStructureError, ValueError):
    """A parameter or option value is impossible (not finite, out of range, the wrong shape).

    Examples
    --------
    >>> from geostructure import Params
    >>> try:
    ...     Params(psi=float("inf"))
    ... except ParameterError as error:
    ...     print(error)
    psi must be a finite number, not inf.
    """


class OutputError(GeoStructureError):
    """The output folder cannot be written, or holds a set of files that is not one run's.

    Examples
    --------
    >>> from geostructure import verified_record
    >>> try:
    ...     verified_record("no-such-folder")
    ... except OutputError as error:
    ...     print(error)
    no-such-folder/run.json: no such file; run 'geostructure measure' first.
    """


class GeoStructureWarning(UserWarning):
    """Something the user should know that does not stop the run; the command line prints
    these as ``geostructure: warning: ...``. A warning of any other class reaching the
    command line is a defect of this program and is labelled so.

    Examples
    --------
    >>> import warnings
    >>> from geostructure import Params
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     _ = Params(theta=45)
    >>> issubclass(caught[0].category, GeoStructureWarning)
    True
    """


class GeoStructureNote(GeoStructureWarning):
    """Something the run did as asked or as the file asks, worth knowing but not a problem
    (points a LAS file marks withheld or as noise, left out). The command line prints these
    as ``geostructure: note: ...``, and not at all under ``-q``. A note is a
    :class:`GeoStructureWarning`: code that catches those catches notes too.

    Examples
    --------
    >>> import warnings
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     warnings.warn("scan.las: 12 point(s) left out, as the file marks them: 12 withheld.", GeoStructureNote)
    >>> issubclass(caught[0].category, GeoStructureWarning)
    True
    """


def raised_by_interrupt(error: BaseException) -> bool:
    """Whether an exception is an interrupt (Ctrl-C) or was raised because of one.

    Python wraps an exception raised while a class is made (``__set_name__``) in a
    ``RuntimeError`` of its own: a Ctrl-C that landed while matplotlib's axes were imported,
    in the middle of drawing a report, came out as that error, exit 1 and Python's
    traceback. Any exception whose chain of causes holds a ``KeyboardInterrupt`` is read as
    the interrupt it is.

    Examples
    --------
    >>> try:
    ...     try:
    ...         raise KeyboardInterrupt
    ...     except KeyboardInterrupt as interrupt:
    ...         raise RuntimeError("Error calling __set_name__") from interrupt
    ... except RuntimeError as error:
    ...     print(raised_by_interrupt(error), raised_by_interrupt(ValueError()))
    True False
    """
    link: BaseException | None = error
    seen = set()
    while link is not None and id(link) not in seen:
        if isinstance(link, KeyboardInterrupt):
            return True
        seen.add(id(link))
        link = link.__cause__ or link.__context__
    return False
