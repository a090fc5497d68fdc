"""Errors raised for user mistakes.

Every error names the offending field and the allowed range, so that the apps
can print it and exit with status 2 instead of showing a traceback.
"""

import contextlib


class SpecError(ValueError):
    """Invalid user input: a spec field, a prescription string, a CLI argument.

    A :class:`ValueError`; its text is ``"field: message"``, the one line the commands
    print before they exit with status 2. The functions and classes of :mod:`eyelab`
    raise it for a bad spec, value or argument, naming the field (:func:`eyelab.render`
    before it renders anything).

    Parameters
    ----------
    field : str
        Dotted name of the offending field, e.g. ``"eye.pupil_diameter_mm"``.
    message : str
        What is wrong and what is allowed.

    Examples
    --------
    >>> import eyelab
    >>> try:
    ...     eyelab.render(None, width=0)
    ... except eyelab.SpecError as error:
    ...     print(error)
    ...     print(error.field)
    render.width: must be an integer in [16, 4096], got 0
    render.width
    """

    def __init__(self, field: str, message: str):
        self.field = field
        self.message = message
        super().__init__(f"{field}: {message}")


@contextlib.contextmanager
def renamed(names: dict | None):
    """Within the block, a :class:`SpecError` of a field in ``names`` (the engine's field
    -> what the caller typed: a CLI flag, an argument) is raised again under that name."""
    try:
        yield
    except SpecError as e:
        if names and e.field in names:
            raise SpecError(names[e.field], e.message) from None
        raise
