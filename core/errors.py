"""Errors the user can act on.

Every failure a user can cause (bad file, wrong classes, missing CRS, a grid too
large for memory, cancellation) raises :class:`UrbanvoxError` with a message that
says what is wrong and what to do; the Processing algorithms show it verbatim.
"""


class UrbanvoxError(Exception):
    """A problem with the input or parameters, explained for the user."""


class Cancelled(UrbanvoxError):
    """The user cancelled the run; nothing was written."""

    def __init__(self, message: str = "Cancelled by the user; no output was written.") -> None:
        super().__init__(message)
