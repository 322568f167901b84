"""C source for an SX Function evaluated over many sweep values at once: the loop turned inside
out, in blocks (run by :mod:`.blocked`).

CasADi's code generator writes a Function for one sweep value; run over a stroke it is called
once per sample and its straight-line code runs one value at a time.  Here the loop is turned
inside out as in :mod:`.vectorised`, but in C: the instructions of the SX graph run as loops over
a block of samples (which the C compiler vectorises), ``SEGMENT`` instructions per loop,
instructions that do not depend on the sweep value (the parameters' own work) are done once per
block as scalars, and the block's working arrays stay in the processor's cache.  Same
instructions, in the same order, as CasADi's virtual machine, with IEEE arithmetic (no fast-math,
no contraction into fused multiply-adds): the numbers are the VM's (tests/test_compiled.py).

The file is a CasADi external (``ca.external``): ``NAME(s[1 x block], p) -> outputs[1 x block]``,
every output a scalar of the original Function broadcast to the block.  With ``varied`` (the
parameters that differ between the cases of a batch, e.g. a study's axes) it also holds
``NAME_cases``: one sweep row for many parameter rows that differ in those parameters only; per
block of the row, the instructions that depend on the sweep value and not on the varied
parameters (the kinematics of a study that varies masses: 197 of the truck crane's 284) run once,
then the others once per case, each instruction on the same operands as in ``NAME`` (the same
numbers, bit for bit)."""
from __future__ import annotations

import math

import casadi as ca

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




def _program(func: ca.Function, varied) -> tuple:
    """(scalars, items) of ``func``: the C statements on the parameters alone, in program order,
    each (statement, whether it depends on a varied parameter); the work that varies with s,
    ("op", k, template, operands, call, varied) | ("out", j, operand), in program order.  A value
    is ("c", name, varied) | ("s",) | ("v", instruction, varied)."""
    value, scalars, items = {}, [], []
    for k in range(func.n_instructions()):
        op = func.instruction_id(k)
        i, o = func.instruction_input(k), func.instruction_output(k)
        if op == ca.OP_INPUT:
            if i[0] == 0:
                value[o[0]] = ("s",)
            else:
                mine = i[1] in varied
                scalars.append((f"  const casadi_real c{k} = {'p' if mine else 'p0'} ? {'p' if mine else 'p0'}[{i[1]}] : 0;",
                                mine))
                value[o[0]] = ("c", f"c{k}", mine)
        elif op == ca.OP_CONST:
            scalars.append((f"  const casadi_real c{k} = {_literal(float(func.instruction_constant(k)))};", False))
            value[o[0]] = ("c", f"c{k}", False)
        elif op == ca.OP_OUTPUT:
            items.append(("out", o[0], value[i[0]]))
        else:
            template = BINARY.get(op) or UNARY[op]
            operands = [value[i[0]], value[i[1]]] if op in BINARY else [value[i[0]]]
            mine = any(v[0] != "s" and v[2] for v in operands)
            if all(v[0] == "c" for v in operands):
                statement = template.format(**dict(zip('ab', (v[1] for v in operands))))
                scalars.append((f"  const casadi_real c{k} = {statement};", mine))
                value[o[0]] = ("c", f"c{k}", mine)
            else:
                items.append(("op", k, template, operands, op in CALLS, mine))
                value[o[0]] = ("v", k, mine)
    return scalars, items


def _loops(items, block: int, segment: int, array: dict, sizes: list, keep=()) -> list:
    """The C loops over a block of ``items`` (see :func:`_program`), up to ``segment``
    instructions per loop, a library call in a loop of its own.  A value used by a later loop
    (or in ``keep``: by a later phase) is kept in an array of the block: ``array`` (instruction ->
    array, shared between phases: a value of an earlier phase is read from its array),
    ``sizes[0]`` the arrays in use so far; arrays are reused once their value is dead (never those
    of ``keep``)."""
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
    last_use = {k: len(segments) for k in keep}
    for n, seg in enumerate(segments):
        for item in seg:
            for v in (item[3] if item[0] == "op" else [item[2]]):
                if v[0] == "v" and v[1] not in keep:
                    last_use[v[1]] = n
    mine, free, body = set(), [], []
    for n, seg in enumerate(segments):
        for k in [k for k in mine if last_use[k] < n]:   # dead before this loop: its array is free
            mine.discard(k)
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
            k, template, operands = item[1:4]
            lines.append(f"const casadi_real t{k} = {template.format(**dict(zip('ab', (ref(v) for v in operands))))};")
            local.add(k)
            if last_use.get(k, n) > n:   # used by a later loop: kept in an array
                if free:
                    array[k] = free.pop()
                else:
                    array[k], sizes[0] = sizes[0], sizes[0] + 1
                mine.add(k)
                lines.append(f"w{array[k]}[i] = t{k};")
        body.append(f"  for (i=0; i<{block}; ++i) {{\n    " + "\n    ".join(lines) + "\n  }")
    return body


def blocked_source(func: ca.Function, name: str, block: int, segment: int = SEGMENT, varied=None) -> str:
    """C source of ``func`` (see :func:`supports`) as the external ``name``: (s[1 x block],
    p) -> each output over the block; with ``varied`` (parameter indices) also ``name``_cases (see
    the module's doc).  Raises ``NotImplementedError`` for what it cannot write.

    The parameters' own work comes first, as scalars.  The work that varies with s follows as
    loops over the block, each running up to ``segment`` consecutive instructions per sample
    (values inside a loop stay in registers; a value used by a later loop is kept in an array of
    the block, arrays reused once their value is dead).  A library call (sin, atan2, pow, ...)
    gets a loop of its own, so that every other loop can be vectorised by the compiler."""
    if not supports(func):
        raise NotImplementedError(f"{func.name()}: not an SX Function (s, p) with scalar outputs of known operations")
    scalars, items = _program(func, set(varied or ()))
    sizes = [0]
    body = _loops(items, block, segment, {}, sizes)
    n_p, outs, n_arrays = func.nnz_in(1), func.n_out(), sizes[0]
    pointers = "".join(f"  casadi_real* w{j} = w + {j * block};\n" for j in range(n_arrays))
    results = "".join(f"  casadi_real* r{j} = res[{j}] ? res[{j}] : w + {n_arrays * block};\n" for j in range(outs))
    names_out = "".join(f'    case {j}: return "{func.name_out(j)}";\n' for j in range(outs))
    names_in = "".join(f'    case {j}: return "{func.name_in(j)}";\n' for j in range(2))
    return f"""/* {name}: {func.name()} over blocks of {block} sweep values, the loop turned inside out
   (optdesign/model/blocked_c.py).  Generated; do not edit. */
#include <math.h>
#define casadi_real double
#define casadi_int long long int
#define EXPORT __attribute__((visibility("default")))

static const casadi_int sp_s[3] = {{1, {block}, 1}};
static const casadi_int sp_p[3] = {{{n_p}, 1, 1}};

EXPORT int {name}(const casadi_real** arg, casadi_real** res, casadi_int* iw, casadi_real* w, int mem) {{
  int i;
  const casadi_real* s = arg[0];
  const casadi_real* p0 = arg[1];
  const casadi_real* p = p0;
  casadi_real zero[{block}];
  if (!s) {{ for (i=0; i<{block}; ++i) zero[i] = 0; s = zero; }}
{pointers}{results}{chr(10).join(line for line, _ in scalars)}
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
""" + (_cases_source(name, scalars, items, block, segment, outs) if varied is not None else "")


def _cases_source(name: str, scalars, items, block: int, segment: int, outs: int) -> str:
    """``name``_cases(s, n, P, cases, n_p, res, w): the row ``s`` of ``n`` sweep values (whole
    blocks) with each of the ``cases`` parameter rows of ``P`` (cases x n_p; they differ in the
    varied parameters only: the others are read from the first row), output j of case c at
    ``res[j] + c * n``; ``w`` holds ``name``_cases_work() values."""
    shared = [item for item in items if item[0] == "op" and not item[5]]
    own = [item for item in items if not (item[0] == "op" and not item[5])]
    keep = {v[1] for item in own for v in (item[3] if item[0] == "op" else [item[2]]) if v[0] == "v" and not v[2]}
    array, sizes = {}, [0]
    first = _loops(shared, block, segment, array, sizes, keep)
    second = _loops(own, block, segment, array, sizes)
    n_arrays = sizes[0]
    pointers = "".join(f"  casadi_real* w{j} = w + {j * block};\n" for j in range(n_arrays))
    results = "".join(f"      casadi_real* r{j} = res[{j}] + c * n + b;\n" for j in range(outs))
    fixed = "\n".join(line for line, mine in scalars if not mine)
    per_case = "\n".join("    " + line for line, mine in scalars if mine)
    return f"""
EXPORT casadi_int {name}_cases_work(void) {{ return {max(n_arrays, 1) * block}; }}

EXPORT int {name}_cases(const casadi_real* s_all, casadi_int n, const casadi_real* P, casadi_int cases,
                        casadi_int n_p, casadi_real* const* res, casadi_real* w) {{
  int i;
  casadi_int b, c;
  const casadi_real* p0 = P;
{pointers}{fixed}
  for (b = 0; b + {block} <= n; b += {block}) {{
    const casadi_real* s = s_all + b;
{chr(10).join(first)}
    for (c = 0; c < cases; ++c) {{
      const casadi_real* p = P + c * n_p;
{results}{per_case}
{chr(10).join(second)}
    }}
  }}
  return 0;
}}
"""
