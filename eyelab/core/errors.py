"""Errors raised for user mistakes.

Every error names the offending field and the allowed range, so that the apps
can print it and exit with status 2 instead of showing a traceback.
"""


class SpecError(ValueError):
    """Invalid user input: a spec field, a prescription string, a CLI argument.

    Parameters
    ----------
    field : str
        Dotted name of the offending field, e.g. ``"eye.pupil_diameter_mm"``.
    message : str
        What is wrong and what is allowed.
    """

    def __init__(self, field: str, message: str):
        self.field = field
        self.message = message
        super().__init__(f"{field}: {message}")
