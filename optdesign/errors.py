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
    """A construction that cannot be assembled at some sweep value."""


class DeadCentreError(OptdesignError, ValueError):
    """The drive coordinate stops moving inside the stroke (dk = dq/ds passes through zero)."""


class SolverError(OptdesignError, RuntimeError):
    """A numerical solver that failed (IPOPT, an integrator)."""
