"""The errors simroad raises, one class per situation a caller may want to catch apart.

Every one derives from :class:`SimroadError`; each also derives from the built-in
exception a Python caller would expect for its situation, so ``except ValueError``
keeps working for a bad value and ``except ImportError`` for a missing extra.

=========================  ==========================================  =====================
class                      raised when                                 also a
=========================  ==========================================  =====================
InvalidParameterError      an argument has the wrong type or value     ValueError, TypeError
MissingDependencyError     an optional extra (e.g. Ray) is not         ImportError
                           installed
ResetNeededError           an object was used before ``reset()``       RuntimeError
OutputInUseError           another run holds the output folder         RuntimeError
ModelFileError             a model file is missing, damaged or not     ValueError
                           a simroad model
DetectorFailedError        a detector raised, or returned no mask,     RuntimeError
                           while running (its cause chained)
=========================  ==========================================  =====================

The message of each says what was expected, what came, and how to fix it.
"""

from __future__ import annotations

__all__ = [
    "DetectorFailedError",
    "InvalidParameterError",
    "MissingDependencyError",
    "ModelFileError",
    "OutputInUseError",
    "ResetNeededError",
    "SimroadError",
]


class SimroadError(Exception):
    """Base class of every error simroad raises on purpose, with the fix in its message."""


class InvalidParameterError(SimroadError, ValueError, TypeError):
    """An argument of the wrong type or value (scikit-learn's ``InvalidParameterError``)."""


class MissingDependencyError(SimroadError, ImportError):
    """An optional dependency that the call needs is not installed; the message names the extra."""


class ResetNeededError(SimroadError, RuntimeError):
    """A stateful object (an environment, a noise model) was used before ``reset()``."""


class OutputInUseError(SimroadError, RuntimeError):
    """Another process is writing to the same output folder."""


class ModelFileError(SimroadError, ValueError):
    """A model file is missing, truncated, damaged, or not a simroad model."""


class DetectorFailedError(SimroadError, RuntimeError):
    """A detector raised, or returned something that is not a road mask, while running
    (the command line's exit status 3: a component failed, not a bad input)."""
