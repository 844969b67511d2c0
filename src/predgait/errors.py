"""User-facing errors.

Every error a user can cause (bad file, bad option, infeasible problem, diverged
simulation) is raised as a :class:`PredgaitError` subclass with a message that names
the file, field or time and says what to do. The CLI prints the message without a
traceback and exits non-zero.
"""


class PredgaitError(Exception):
    """Base class of errors reported to the user as one clear message."""


class InputError(PredgaitError):
    """A file, option or parameter given by the user is missing or invalid."""


class SimulationDiverged(PredgaitError):
    """A forward simulation produced NaN or blew up; carries the partial result."""

    def __init__(self, message: str, partial=None):
        super().__init__(message)
        self.partial = partial


class SolveFailed(PredgaitError):
    """An optimisation did not converge or was infeasible; carries the best point."""

    def __init__(self, message: str, best=None):
        super().__init__(message)
        self.best = best
