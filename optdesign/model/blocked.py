"""C source for an SX Function evaluated over many sweep values at once: the loop turned inside
out, in blocks.

CasADi's code generator writes a Function for one sweep value; run over a stroke it is called
once per sample and its straight-line code runs one value at a time.  Here the loop is turned
inside out as in :mod:`.vectorised`, but in C: the instructions of the SX graph run as loops over
a block of ``BLOCK`` samples (which the C compiler vectorises), ``SEGMENT`` instructions per loop,
instructions that do not depend on the sweep value (the parameters' own work) are done once per
block as scalars, and the block's working arrays stay in the processor's cache.  Same instructions, in the same order, as
CasADi's virtual machine, with IEEE arithmetic (no fast-math, no contraction into fused
multiply-adds): the numbers are the VM's (tests/test_compiled.py).

The file is a CasADi external (``ca.external``): ``NAME(s[1 x BLOCK], p) -> outputs[1 x BLOCK]``,
every output a scalar of the original Function broadcast to the block.  :class:`BlockedFunction`
pads a stroke to whole blocks and maps it over them; :func:`stroke_evaluator` gives it from the
disk cache (:mod:`.compiled`), or numpy's :class:`~.vectorised.VectorisedSX` while there is none.
"""
from __future__ import annotations

import math

import casadi as ca
import numpy as np

from . import compiled
from .vectorised import VectorisedSX

BLOCK = 64     # samples per block
CHUNK = 64     # blocks per mapped call over many cases (BlockedFunction.ragged)
# the blocks compiled at -O2, not FLAGS' -O1: the truck crane's model over its 161 samples 0.087 ->
# 0.025 ms per case (256 cases, compiled code alone; the same numbers bit for bit: no fast-math, no
# contraction), compiling its 18 kB of C 0.33 -> 0.42 s
LEVEL = "-O2"
SEGMENT = 16   # instructions per loop (level-luffing crane, CPU time per call at 10,001 samples:
#                one instruction per loop 3.5 ms, 16 per loop 2.3 ms, 32 or 64 2.5 ms; compiling
#                1.7 s -> 0.4 s)

_BINARY = {
    "OP_ADD": "({a}+{b})", "OP_SUB": "({a}-{b})", "OP_MUL": "({a}*{b})", "OP_DIV": "({a}/{b})",
    "OP_ATAN2": "atan2({a},{b})", "OP_LE": "({a}<={b})", "OP_LT": "({a}<{b})", "OP_EQ": "({a}=={b})",
    "OP_NE": "({a}!={b})", "OP_POW": "pow({a},{b})", "OP_CONSTPOW": "pow({a},{b})",
    "OP_FMIN": "fmin({a},{b})", "OP_FMAX": "fmax({a},{b})", "OP_AND": "({a}&&{b})", "OP_OR": "({a}||{b})",
    "OP_COPYSIGN": "copysign({a},{b})", "OP_FMOD": "fmod({a},{b})", "OP_HYPOT": "hypot({a},{b})",
    "OP_IF_ELSE_ZERO": "({a}?{b}:0)",
}
_UNARY = {
    "OP_NEG": "(-{a})", "OP_SQ": "({a}*{a})", "OP_TWICE": "(2.*{a})", "OP_SQRT": "sqrt({a})",
    "OP_SIN": "sin({a})", "OP_COS": "cos({a})", "OP_TAN": "tan({a})", "OP_ASIN": "asin({a})",
    "OP_ACOS": "acos({a})", "OP_ATAN": "atan({a})", "OP_EXP": "exp({a})", "OP_LOG": "log({a})",
    "OP_FABS": "fabs({a})", "OP_SIGN": "({a}<0 ? -1. : {a}>0 ? 1. : {a})", "OP_INV": "(1./{a})",
    "OP_NOT": "(!{a})", "OP_TANH": "tanh({a})", "OP_SINH": "sinh({a})", "OP_COSH": "cosh({a})",
    "OP_FLOOR": "floor({a})", "OP_CEIL": "ceil({a})", "OP_LOG1P": "log1p({a})", "OP_EXPM1": "expm1({a})",
    "OP_ASSIGN": "({a})", "OP_ERF": "erf({a})",
}
BINARY = {getattr(ca, k): f for k, f in _BINARY.items() if hasattr(ca, k)}
UNARY = {getattr(ca, k): f for k, f in _UNARY.items() if hasattr(ca, k)}
# library calls: a loop of their own (they keep the compiler from vectorising a loop)
CALLS = {getattr(ca, k) for k in (
    "OP_SIN", "OP_COS", "OP_TAN", "OP_ASIN", "OP_ACOS", "OP_ATAN", "OP_EXP", "OP_LOG", "OP_ATAN2", "OP_POW",
    "OP_CONSTPOW", "OP_FMOD", "OP_HYPOT", "OP_TANH", "OP_SINH", "OP_COSH", "OP_LOG1P", "OP_EXPM1", "OP_ERF",
    "OP_FMIN", "OP_FMAX", "OP_COPYSIGN", "OP_FLOOR", "OP_CEIL") if hasattr(ca, k)}


def _literal(x: float) -> str:
    """An exact C literal of a double."""
    if math.isnan(x):
        return "NAN"
    if math.isinf(x):
        return "INFINITY" if x > 0 else "(-INFINITY)"
    return f"{float(x).hex()}"


def supports(func: ca.Function) -> bool:
    """Whether :func:`blocked_source` can write ``func``: an SX Function (s, p) with a scalar s
    and scalar outputs, of operations it knows."""
    if not func.is_a("SXFunction") or func.n_in() != 2 or func.nnz_in(0) != 1:
        return False
    if any(func.nnz_out(j) != 1 for j in range(func.n_out())):
        return False
    known = {ca.OP_INPUT, ca.OP_OUTPUT, ca.OP_CONST, *BINARY, *UNARY}
    return all(func.instruction_id(k) in known for k in range(func.n_instructions()))


def blocked_source(func: ca.Function, name: str, block: int = BLOCK, segment: int = SEGMENT) -> str:
    """C source of ``func`` (see :func:`supports`) as the external ``name``: (s[1 x block],
    p) -> each output over the block.  Raises ``NotImplementedError`` for what it cannot write.

    The parameters' own work comes first, as scalars.  The work that varies with s follows as
    loops over the block, each running up to ``segment`` consecutive instructions per sample
    (values inside a loop stay in registers; a value used by a later loop is kept in an array of
    the block, arrays reused once their value is dead).  A library call (sin, atan2, pow, ...)
    gets a loop of its own, so that every other loop can be vectorised by the compiler."""
    if not supports(func):
        raise NotImplementedError(f"{func.name()}: not an SX Function (s, p) with scalar outputs of known operations")
    value = {}       # CasADi work slot -> ("c", scalar name) | ("s",) | ("v", instruction)
    scalars = []     # C statements on the parameters alone
    items = []       # ("op", k, template, operands, call) | ("out", j, operand): what varies with s
    for k in range(func.n_instructions()):
        op = func.instruction_id(k)
        i, o = func.instruction_input(k), func.instruction_output(k)
        if op == ca.OP_INPUT:
            if i[0] == 0:
                value[o[0]] = ("s",)
            else:
                scalars.append(f"  const casadi_real c{k} = arg[1] ? arg[1][{i[1]}] : 0;")
                value[o[0]] = ("c", f"c{k}")
        elif op == ca.OP_CONST:
            scalars.append(f"  const casadi_real c{k} = {_literal(float(func.instruction_constant(k)))};")
            value[o[0]] = ("c", f"c{k}")
        elif op == ca.OP_OUTPUT:
            items.append(("out", o[0], value[i[0]]))
        else:
            template = BINARY.get(op) or UNARY[op]
            operands = [value[i[0]], value[i[1]]] if op in BINARY else [value[i[0]]]
            if all(v[0] == "c" for v in operands):
                scalars.append(f"  const casadi_real c{k} = {template.format(**dict(zip('ab', (v[1] for v in operands))))};")
                value[o[0]] = ("c", f"c{k}")
            else:
                items.append(("op", k, template, operands, op in CALLS))
                value[o[0]] = ("v", k)
    segments, current = [], []
    for item in items:
        if item[0] == "op" and item[4]:
            segments += [current, [item]] if current else [[item]]
            current = []
            continue
        current.append(item)
        if len(current) >= segment:
            segments.append(current)
            current = []
    if current:
        segments.append(current)
    defined, last_use = {}, {}
    for n, seg in enumerate(segments):
        for item in seg:
            if item[0] == "op":
                defined[item[1]] = n
            for v in (item[3] if item[0] == "op" else [item[2]]):
                if v[0] == "v":
                    last_use[v[1]] = n
    array, free, n_arrays, body = {}, [], 0, []
    for n, seg in enumerate(segments):
        for k in [k for k in array if last_use[k] < n]:   # dead before this loop: its array is free
            free.append(array.pop(k))
        local, lines = set(), []

        def ref(v):
            if v[0] == "c":
                return v[1]
            if v[0] == "s":
                return "s[i]"
            return f"t{v[1]}" if v[1] in local else f"w{array[v[1]]}[i]"

        for item in seg:
            if item[0] == "out":
                lines.append(f"r{item[1]}[i] = {ref(item[2])};")
                continue
            _, k, template, operands, _ = item
            lines.append(f"const casadi_real t{k} = {template.format(**dict(zip('ab', (ref(v) for v in operands))))};")
            local.add(k)
            if last_use.get(k, n) > n:   # used by a later loop: kept in an array
                if free:
                    array[k] = free.pop()
                else:
                    array[k], n_arrays = n_arrays, n_arrays + 1
                lines.append(f"w{array[k]}[i] = t{k};")
        body.append(f"  for (i=0; i<{block}; ++i) {{\n    " + "\n    ".join(lines) + "\n  }")
    n_p, outs = func.nnz_in(1), func.n_out()
    pointers = "".join(f"  casadi_real* w{j} = w + {j * block};\n" for j in range(n_arrays))
    results = "".join(f"  casadi_real* r{j} = res[{j}] ? res[{j}] : w + {n_arrays * block};\n" for j in range(outs))
    names_out = "".join(f'    case {j}: return "{func.name_out(j)}";\n' for j in range(outs))
    names_in = "".join(f'    case {j}: return "{func.name_in(j)}";\n' for j in range(2))
    return f"""/* {name}: {func.name()} over blocks of {block} sweep values, the loop turned inside out
   (optdesign/model/blocked.py).  Generated; do not edit. */
#include <math.h>
#define casadi_real double
#define casadi_int long long int
#define EXPORT __attribute__((visibility("default")))

static const casadi_int sp_s[3] = {{1, {block}, 1}};
static const casadi_int sp_p[3] = {{{n_p}, 1, 1}};

EXPORT int {name}(const casadi_real** arg, casadi_real** res, casadi_int* iw, casadi_real* w, int mem) {{
  int i;
  const casadi_real* s = arg[0];
  casadi_real zero[{block}];
  if (!s) {{ for (i=0; i<{block}; ++i) zero[i] = 0; s = zero; }}
{pointers}{results}{chr(10).join(scalars)}
{chr(10).join(body)}
  return 0;
}}

EXPORT casadi_int {name}_n_in(void) {{ return 2; }}
EXPORT casadi_int {name}_n_out(void) {{ return {outs}; }}
EXPORT const char* {name}_name_in(casadi_int i) {{
  switch (i) {{
{names_in}    default: return 0;
  }}
}}
EXPORT const char* {name}_name_out(casadi_int i) {{
  switch (i) {{
{names_out}    default: return 0;
  }}
}}
EXPORT const casadi_int* {name}_sparsity_in(casadi_int i) {{ return i == 0 ? sp_s : i == 1 ? sp_p : 0; }}
EXPORT const casadi_int* {name}_sparsity_out(casadi_int i) {{ return i >= 0 && i < {outs} ? sp_s : 0; }}
EXPORT int {name}_work(casadi_int* sz_arg, casadi_int* sz_res, casadi_int* sz_iw, casadi_int* sz_w) {{
  if (sz_arg) *sz_arg = 2;
  if (sz_res) *sz_res = {outs};
  if (sz_iw) *sz_iw = 0;
  if (sz_w) *sz_w = {(n_arrays + 1) * block};
  return 0;
}}
EXPORT int {name}_checkout(void) {{ return 0; }}
EXPORT void {name}_release(int mem) {{ }}
EXPORT void {name}_incref(void) {{ }}
EXPORT void {name}_decref(void) {{ }}
"""


class BlockedFunction:
    """A library written by :func:`blocked_source` run over a row of sweep values: the row padded
    to whole blocks (with its last value), CasADi's map over the blocks through its buffer
    interface, the padding dropped.  Called like :class:`~.vectorised.VectorisedSX`: (s_row, p)
    -> {output name: array over the row}.  Not for concurrent use (one buffer per block count)."""

    def __init__(self, external: ca.Function, block: int = BLOCK):
        self.external, self.block = external, block
        self.names = [external.name_out(j) for j in range(external.n_out())]
        self._maps = {}

    def __call__(self, s_row, p) -> dict:
        s = np.asarray(s_row, float).ravel()
        n = len(s)
        blocks = max(-(-n // self.block), 1)
        if blocks not in self._maps:
            mapped = self.external.map(f"{self.external.name()}_{blocks}", "serial", blocks, [1], [])
            buffer, run = mapped.buffer()
            s_in, p_in = np.zeros(blocks * self.block), np.zeros(self.external.nnz_in(1))
            buffer.set_arg(0, memoryview(s_in))
            buffer.set_arg(1, memoryview(p_in))
            self._maps[blocks] = (mapped, buffer, run, s_in, p_in)
        mapped, buffer, run, s_in, p_in = self._maps[blocks]
        s_in[:n] = s
        s_in[n:] = s[-1] if n else 0.0
        p_in[:] = np.asarray(p, float).ravel()
        outs = [np.empty(blocks * self.block) for _ in self.names]   # fresh: the caller keeps them
        for j, out in enumerate(outs):
            buffer.set_res(j, memoryview(out))
        run()
        return {name: out[:n] for name, out in zip(self.names, outs)}

    def many(self, s_row, P) -> dict:
        """{output name: array cases x sweep values}: the row ``s_row`` for every parameter row
        of ``P`` (cases x parameters), each case padded to whole blocks as :meth:`__call__` pads
        it, every block with its case's parameters: a case's numbers are those of its own call,
        whatever the other cases."""
        s = np.asarray(s_row, float).ravel()
        P = np.atleast_2d(np.asarray(P, float))
        return self._rows(np.broadcast_to(s, (len(P), len(s))), P, flat=False)

    def _rows(self, S, P, flat=True) -> dict:
        """{output name: values over ``S.ravel()``}: row i of ``S`` (cases x values) with the
        parameters ``P[i]``, each row in blocks of its own padded with its last value.  ``flat``
        False: each output cases x values, a view of the padded blocks (not copied: a batch's
        outputs are megabytes, each copy in fresh memory)."""
        cases, n = S.shape
        per = max(-(-n // self.block), 1)
        rows = np.empty((cases, per * self.block))   # a case's blocks: its row padded with its last value
        rows[:, :n] = S
        rows[:, n:] = S[:, -1:] if n else 0.0
        outs = self._run(rows.reshape(-1), np.repeat(P, per, axis=0))
        if not flat:
            return {k: v.reshape(cases, per * self.block)[:, :n] for k, v in outs.items()}
        return {k: v.reshape(cases, per * self.block)[:, :n].reshape(-1) for k, v in outs.items()}

    def ragged(self, s, counts, P) -> dict:
        """{output name: array over ``s``}: the first ``counts[0]`` values of ``s`` with the
        parameters ``P[0]``, the next ``counts[1]`` with ``P[1]``, ...: each case's values in
        blocks of its own (padded with its last value), mapped calls of at most CHUNK blocks."""
        s = np.asarray(s, float).ravel()
        counts = np.asarray(counts, int)
        P = np.atleast_2d(np.asarray(P, float))
        if len(counts) and counts[0] > 0 and np.all(counts == counts[0]):   # as many values each: many()'s layout
            return self._rows(s.reshape(len(counts), counts[0]), P)
        block = self.block
        per = -(-counts // block)
        first = np.cumsum(per) - per
        ends = np.cumsum(counts)
        case = np.repeat(np.arange(len(counts)), counts)
        where = first[case] * block + np.arange(len(s)) - (ends - counts)[case]
        last = np.where(counts > 0, s[np.maximum(ends - 1, 0)] if len(s) else 0.0, 0.0)
        s_in = np.repeat(last, per * block)
        s_in[where] = s
        return {name: values[where] for name, values in self._run(s_in, np.repeat(P, per, axis=0)).items()}

    def _run(self, s_in, p_in) -> dict:
        """{output name: values over ``s_in``} (whole blocks; block j with the parameters
        ``p_in[j]``), in mapped calls of CHUNK blocks that read and write the arrays in place,
        the rest of at most CHUNK blocks through :meth:`_blocks`."""
        block, total = self.block, len(p_in)
        outs = {name: np.empty(total * block) for name in self.names}
        full = total // CHUNK * CHUNK
        if full:
            buffer, run = self._direct()
            p_in = np.ascontiguousarray(p_in)
            for start in range(0, full, CHUNK):
                at = slice(start * block, (start + CHUNK) * block)
                buffer.set_arg(0, memoryview(s_in[at]))
                buffer.set_arg(1, memoryview(p_in[start:start + CHUNK].reshape(-1)))
                for j, name in enumerate(self.names):
                    buffer.set_res(j, memoryview(outs[name][at]))
                run()
        if full < total:
            part = self._blocks(s_in[full * block:], p_in[full:])
            for name, values in part.items():
                outs[name][full * block:] = values
        return outs

    def _direct(self):
        """The mapped Function of CHUNK blocks whose buffer :meth:`_run` points at its arrays."""
        if "direct" not in self._maps:
            mapped = self.external.map(f"{self.external.name()}_blocks_{CHUNK}", "serial", CHUNK, [], [])
            self._maps["direct"] = mapped.buffer()
        return self._maps["direct"]

    def _blocks(self, s_in, p_rows) -> dict:
        """The outputs over whole blocks ``s_in``, block j with the parameters ``p_rows[j]`` (at
        most CHUNK blocks: one mapped Function per power of two of blocks, the call padded)."""
        n = len(p_rows)
        size = 1 << max(n - 1, 0).bit_length()
        if ("chunk", size) not in self._maps:
            mapped = self.external.map(f"{self.external.name()}_blocks_{size}", "serial", size, [], [])
            buffer, run = mapped.buffer()
            s_buf, p_buf = np.zeros(size * self.block), np.zeros(size * self.external.nnz_in(1))
            outs = [np.zeros(size * self.block) for _ in self.names]
            buffer.set_arg(0, memoryview(s_buf))
            buffer.set_arg(1, memoryview(p_buf))
            for j, out in enumerate(outs):
                buffer.set_res(j, memoryview(out))
            self._maps[("chunk", size)] = (buffer, run, s_buf, p_buf, outs)
        buffer, run, s_buf, p_buf, outs = self._maps[("chunk", size)]
        s_buf[:len(s_in)], s_buf[len(s_in):] = s_in, s_in[-1]
        p_buf[:p_rows.size] = p_rows.ravel()
        p_buf[p_rows.size:] = np.tile(p_rows[-1], size - n)
        run()
        return {name: out[:n * self.block].copy() for name, out in zip(self.names, outs)}


def stroke_evaluator(func: ca.Function, wait: bool | None = None):
    """The fastest evaluator of ``func`` (s, p) over a whole stroke that is at hand: the
    compiled blocks from the disk cache (:mod:`.compiled`; on a miss they are compiled, in the
    background unless ``wait``), else numpy's :class:`~.vectorised.VectorisedSX`, else None
    (MX graphs: CasADi's map)."""
    if supports(func):
        external = compiled.external(func, "optdesign_blocked", lambda name: blocked_source(func, name), wait, LEVEL)
        if external is not None:
            return BlockedFunction(external)
    try:
        return VectorisedSX(func)
    except NotImplementedError:
        return None
