"""The error family of optdesign.

Every message names the item (file, table, key, construction, sweep value), shows what was
found and says what to do.  All of them derive from :class:`OptdesignError`, and each also
derives from the builtin exception a Python user would expect (``ValueError``).
"""


class OptdesignError(Exception):
    """Base class of all errors raised on purpose by optdesign."""


class SceneError(OptdesignError, ValueError):
    """A scene that does not parse or does not validate (file, table, key, line)."""


class ExpressionError(SceneError):
    """An expression that does not parse or names something unknown."""


class AssemblyError(OptdesignError, ValueError):
    """A construction that cannot be assembled at some sweep value, or reaches its limit
    (lock-up) position there.  ``construction`` names it and ``s`` is the located sweep value
    (both None when not known)."""

    def __init__(self, message, construction=None, s=None):
        super().__init__(message)
        self.construction, self.s = construction, s

    def __reduce__(self):  # keep the attributes through pickling (study workers)
        return type(self), (str(self), self.construction, self.s)


class DeadCentreError(OptdesignError, ValueError):
    """The drive coordinate stops moving inside the stroke (k = dq/ds vanishes); ``s`` is the
    located sweep value (None when not known)."""

    def __init__(self, message, s=None):
        super().__init__(message)
        self.s = s

    def __reduce__(self):
        return type(self), (str(self), self.s)


class ArgumentError(OptdesignError, ValueError):
    """A value handed to a front door (a function argument, a command-line option) that is out
    of range, not finite, or too large for this machine; the message names the argument."""


class ResultError(OptdesignError, ValueError):
    """A result that holds NaN or inf: the message names the quantity (and body, point or
    constraint) and the first stroke position where it appears."""


class SolverError(OptdesignError, RuntimeError):
    """A numerical solver that failed (IPOPT, an integrator)."""
