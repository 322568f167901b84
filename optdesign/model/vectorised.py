"""Evaluating an SX Function over a whole stroke with numpy, one instruction at a time.

CasADi's SX virtual machine runs the instruction list once per sample; here the loop is turned
inside out: each instruction is one numpy operation over all samples.  Same graph, same
operations in the same order, so the same numbers (to round-off: measured <= 6e-16 relative on
every shipped scene); on the level-luffing crane over 10,001 samples it is about 6 times faster
than the mapped VM (benchmarks/bench_reduced_model.py).  Inputs that do not vary with the
sample (the parameters) stay scalars, so work that depends on them alone is done once.
"""
from __future__ import annotations

import casadi as ca
import numpy as np

_BINARY = {
    "OP_ADD": np.add, "OP_SUB": np.subtract, "OP_MUL": np.multiply, "OP_DIV": np.divide,
    "OP_ATAN2": np.arctan2, "OP_LE": np.less_equal, "OP_LT": np.less, "OP_EQ": np.equal,
    "OP_NE": np.not_equal, "OP_POW": np.power, "OP_CONSTPOW": np.power, "OP_FMIN": np.fmin,
    "OP_FMAX": np.fmax, "OP_AND": np.logical_and, "OP_OR": np.logical_or,
    "OP_COPYSIGN": np.copysign, "OP_FMOD": np.fmod, "OP_HYPOT": np.hypot,
    "OP_IF_ELSE_ZERO": lambda c, x: np.where(c != 0, x, 0.0),
}
_UNARY = {
    "OP_NEG": np.negative, "OP_SQ": np.square, "OP_TWICE": lambda x: 2.0 * x, "OP_SQRT": np.sqrt,
    "OP_SIN": np.sin, "OP_COS": np.cos, "OP_TAN": np.tan, "OP_ASIN": np.arcsin,
    "OP_ACOS": np.arccos, "OP_ATAN": np.arctan, "OP_EXP": np.exp, "OP_LOG": np.log,
    "OP_FABS": np.abs, "OP_SIGN": np.sign, "OP_INV": np.reciprocal, "OP_NOT": np.logical_not,
    "OP_TANH": np.tanh, "OP_SINH": np.sinh, "OP_COSH": np.cosh, "OP_FLOOR": np.floor,
    "OP_CEIL": np.ceil, "OP_LOG1P": np.log1p, "OP_EXPM1": np.expm1, "OP_ASSIGN": lambda x: x,
}
BINARY = {getattr(ca, k): f for k, f in _BINARY.items() if hasattr(ca, k)}
UNARY = {getattr(ca, k): f for k, f in _UNARY.items() if hasattr(ca, k)}


def instruction_program(func: ca.Function) -> list:
    """The instruction list of an SX Function as (kind, a, b, c) tuples that a numpy loop runs:
    0 input (input a, nonzero b -> work c), 1 output (output a, nonzero b <- work c), 2 constant
    a -> work c, 3 binary numpy function a of works b -> work c, 4 unary a of work b -> work c.
    Raises ``NotImplementedError`` for an operation without a numpy counterpart."""
    program = []
    for k in range(func.n_instructions()):
        op, i, o = func.instruction_id(k), func.instruction_input(k), func.instruction_output(k)
        if op == ca.OP_INPUT:
            program.append((0, i[0], i[1], o[0]))
        elif op == ca.OP_OUTPUT:
            program.append((1, o[0], o[1], i[0]))
        elif op == ca.OP_CONST:
            program.append((2, float(func.instruction_constant(k)), None, o[0]))
        elif op in BINARY:
            program.append((3, BINARY[op], (i[0], i[1]), o[0]))
        elif op in UNARY:
            program.append((4, UNARY[op], i[0], o[0]))
        else:
            raise NotImplementedError(f"CasADi operation {op} has no numpy counterpart here")
    return program


def run_program(program, n_work, load, store):
    """Run an :func:`instruction_program` with numpy: ``load(input, nonzero)`` gives an input's
    value (an array over the samples or designs, or a scalar), ``store(output, nonzero, value)``
    takes an output's."""
    work = [None] * n_work
    with np.errstate(all="ignore"):  # like CasADi's VM: nan/inf without warnings
        for kind, a, b, c in program:
            if kind == 3:
                work[c] = a(work[b[0]], work[b[1]])
            elif kind == 4:
                work[c] = a(work[b])
            elif kind == 2:
                work[c] = a
            elif kind == 0:
                work[c] = load(a, b)
            else:
                store(a, b, work[c])


class VectorisedSX:
    """A scalar-output SX Function (s, p) -> outputs, run over a row of sweep values.

    Raises ``NotImplementedError`` at construction for an operation it does not know or an
    output that is not a scalar; callers then keep CasADi's own map."""

    def __init__(self, func: ca.Function):
        if not func.is_a("SXFunction"):
            raise NotImplementedError("only SX Functions can be vectorised")
        if any(func.nnz_out(j) != 1 for j in range(func.n_out())):
            raise NotImplementedError("only scalar outputs are vectorised")
        self.names = [func.name_out(j) for j in range(func.n_out())]
        self.n_work = func.sz_w()
        self.program = instruction_program(func)

    def __call__(self, s_row, p) -> dict:
        inputs = (np.asarray(s_row, float).ravel(), np.asarray(p, float).ravel())
        out = {}

        def store(j, _, value):
            out[self.names[j]] = value

        run_program(self.program, self.n_work, lambda i, k: inputs[0] if i == 0 else inputs[1][k], store)
        return out

    def ragged(self, s, counts, P) -> dict:
        """{output name: array over ``s``}: the first ``counts[0]`` values of ``s`` with the
        parameters ``P[0]``, the next ``counts[1]`` with ``P[1]``, ... (element by element)."""
        s = np.asarray(s, float).ravel()
        rows = np.repeat(np.atleast_2d(np.asarray(P, float)), counts, axis=0)
        out = {}

        def store(j, _, value):
            out[self.names[j]] = np.broadcast_to(value, s.shape).copy()

        run_program(self.program, self.n_work, lambda i, k: s if i == 0 else rows[:, k], store)
        return out

    def many(self, s_row, P) -> dict:
        """{output name: array cases x sweep values}: the row ``s_row`` for every parameter row
        of ``P`` (cases x parameters), element by element (a case's numbers do not depend on
        the others')."""
        s = np.asarray(s_row, float).ravel()[None, :]
        P = np.atleast_2d(np.asarray(P, float))
        shape = (P.shape[0], s.shape[1])
        out = {}

        def store(j, _, value):
            out[self.names[j]] = np.broadcast_to(value, shape).copy()

        run_program(self.program, self.n_work, lambda i, k: s if i == 0 else P[:, k:k + 1], store)
        return out
