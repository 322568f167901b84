"""An instruction program (:func:`.vectorised.instruction_program`) run by compiled C over many
columns at once, in blocks that stay in the processor's cache: the same numbers as the numpy
loop of :func:`.vectorised.run_program`, bit for bit, in a fraction of its time.

The numpy loop (:mod:`optdesign.design.screening`) runs one instruction at a time over every
column (crane_luffing_drive's screening rows: 143,000 instructions over 2,048 designs, their
working arrays ~90 MB, far outside the cache); here one C function runs the same instructions
in the same order over blocks of ``BLOCK`` columns, a value that does not depend on the columns
kept as one number.  The C is one small interpreter, the same for every program, compiled once
through the disk cache (:mod:`.compiled`, at its first use: about a second of gcc); the program
is its arrays of integers, read from the cache folder as they are stored (:mod:`.programs`),
without building a Python list.

Same numbers: the arithmetic the C does itself is exact IEEE arithmetic as numpy's (+, -, *, /,
negation, square, doubling, reciprocal, absolute value, square root, comparisons, the logical
operations and the select of ``if_else_zero``: no fast-math, no contraction into fused
multiply-adds); every other operation (sin, tanh, atan2, pow, fmin, sign, ...) is numpy's own
float64 loop, called through its address in the ufunc (numpy's tanh is not the C library's:
they differ in the last bit on a quarter of the values).  Each of those loops is checked once
per process against its ufunc on a thousand values (:func:`_loops`); a program with an operation
that does not pass, or whose comparisons' truth values would reach an operation where numpy
computes in another type (booleans added, or a square root of one: numpy's float16), runs in
numpy as before (:func:`program`: None)."""
from __future__ import annotations

import ctypes
import os
import time

import casadi as ca
import numpy as np

from . import compiled

NAME = "optdesign_program"
# columns per block (at most the C's BLOCK_MAX): each instruction's dispatch is paid once per block, so
# longer blocks cost less although crane_luffing_drive's screening program (5,630 working values x 256
# x 8 B) no longer fits the L2 cache: its rows at 2,048 designs 0.28 -> 0.21 s of CPU against 64 (128: 0.24,
# 512: 0.20, 2048: 0.27; the same bits at every block length, each column's operations being the same)
BLOCK = 256
RETRY_S = 2.0

# the C's own operations: code -> CasADi operation
_OWN = ["OP_ADD", "OP_SUB", "OP_MUL", "OP_DIV", "OP_NEG", "OP_SQ", "OP_TWICE", "OP_SQRT", "OP_FABS", "OP_INV",
        "OP_LE", "OP_LT", "OP_EQ", "OP_NE", "OP_AND", "OP_OR", "OP_NOT", "OP_IF_ELSE_ZERO", "OP_ASSIGN"]
OWN = {getattr(ca, k): code for code, k in enumerate(_OWN) if hasattr(ca, k)}
UNARY_LOOP, BINARY_LOOP = 100, 101   # numpy's loop (its index in the table passed in)
# numpy's ufunc of each operation the C leaves to numpy (as in vectorised.py)
LOOPS = {"OP_ATAN2": np.arctan2, "OP_POW": np.power, "OP_CONSTPOW": np.power, "OP_FMIN": np.fmin,
         "OP_FMAX": np.fmax, "OP_COPYSIGN": np.copysign, "OP_FMOD": np.fmod, "OP_HYPOT": np.hypot,
         "OP_SIN": np.sin, "OP_COS": np.cos, "OP_TAN": np.tan, "OP_ASIN": np.arcsin, "OP_ACOS": np.arccos,
         "OP_ATAN": np.arctan, "OP_EXP": np.exp, "OP_LOG": np.log, "OP_SIGN": np.sign, "OP_TANH": np.tanh,
         "OP_SINH": np.sinh, "OP_COSH": np.cosh, "OP_FLOOR": np.floor, "OP_CEIL": np.ceil,
         "OP_LOG1P": np.log1p, "OP_EXPM1": np.expm1}
LOOPS = {getattr(ca, k): f for k, f in LOOPS.items() if hasattr(ca, k)}
_BOOL_OUT = {"OP_LE", "OP_LT", "OP_EQ", "OP_NE", "OP_AND", "OP_OR", "OP_NOT"}
# where a truth value may go and give numpy's number: what treats it as 0/1 in float64 (or keeps it a truth value)
_BOOL_SAFE = {"OP_MUL", "OP_AND", "OP_OR", "OP_NOT", "OP_IF_ELSE_ZERO", "OP_LE", "OP_LT", "OP_EQ", "OP_NE",
              "OP_ASSIGN", "OP_TWICE", "OP_SQ"}

SOURCE = r"""
#include <math.h>
#include <string.h>
#include <stdint.h>
typedef void (*loop_t)(char **args, const intptr_t *dims, const intptr_t *steps, void *data);
enum {ADD, SUB, MUL, DIV, NEG, SQ, TWICE, SQRT, FABS, INV, LE, LT, EQ, NE, AND, OR, NOT, IFZ, ASSIGN};
#define BLOCK_MAX 256

static double own(int code, double x, double y) {
  switch (code) {
    case ADD: return x + y;  case SUB: return x - y;  case MUL: return x * y;  case DIV: return x / y;
    case NEG: return -x;  case SQ: return x * x;  case TWICE: return 2. * x;  case SQRT: return sqrt(x);
    case FABS: return fabs(x);  case INV: return 1. / x;  case LE: return x <= y;  case LT: return x < y;
    case EQ: return x == y;  case NE: return x != y;  case AND: return (x != 0) && (y != 0);
    case OR: return (x != 0) || (y != 0);  case NOT: return !(x != 0);  case IFZ: return x != 0 ? y : 0.;
    default: return x;
  }
}

#define LOOP(expr) \
  if (sx && sy) { for (long j = 0; j < n; j++) { double x = px[j], y = py[j]; (void)y; r[j] = (expr); } } \
  else if (sx) { double y = *py; (void)y; for (long j = 0; j < n; j++) { double x = px[j]; r[j] = (expr); } } \
  else { double x = *px; for (long j = 0; j < n; j++) { double y = py[j]; (void)y; r[j] = (expr); } }

static void own_block(int code, long n, const double *px, long sx, const double *py, long sy, double *r) {
  switch (code) {
    case ADD: LOOP(x + y) break;  case SUB: LOOP(x - y) break;  case MUL: LOOP(x * y) break;
    case DIV: LOOP(x / y) break;  case NEG: LOOP(-x) break;  case SQ: LOOP(x * x) break;
    case TWICE: LOOP(2. * x) break;  case SQRT: LOOP(sqrt(x)) break;  case FABS: LOOP(fabs(x)) break;
    case INV: LOOP(1. / x) break;
    default: for (long j = 0; j < n; j++) r[j] = own(code, px[j * sx], py[j * sy]);
  }
}

/* The program (n instructions: kind, code, x, y, dst, block flags) over m columns.
   kind 0: input x's nonzero y (an input with cols[x] is nonzeros x m, row-major; else one value per nonzero);
   1: output x's nonzero y <- work dst (written to row where[where_at[x] + y] of output x, numel x m);
   2: constant consts[y] -> dst; 3 binary, 4 unary (code < 100: own; 100/101: numpy's loop number loop[i]).
   flags: bit 0 the first operand is a block, bit 1 the second; the result is a block when either is. */
int optdesign_program(long n, const int *kind, const int *code, const int *x, const int *y, const int *dst,
                      const unsigned char *flags, const int *loop, const double *consts,
                      const double **in, const int *cols, double **out, const long *where, const long *where_at,
                      long m, long block, double *ws, double *wb, void **loops, void **loop_data) {
  if (block > BLOCK_MAX) return 1;
  double zero = 0.;
  for (long j0 = 0; j0 < m; j0 += block) {
    long nb = m - j0 < block ? m - j0 : block;
    for (long i = 0; i < n; i++) {
      int k = kind[i], f = flags[i];
      double *r = wb + (long)dst[i] * block;
      if (k == 0) {
        if (cols[x[i]]) memcpy(r, in[x[i]] + (long)y[i] * m + j0, nb * sizeof(double));
        else ws[dst[i]] = in[x[i]][y[i]];
      } else if (k == 2) {
        ws[dst[i]] = consts[y[i]];
      } else if (k == 1) {
        double *o = out[x[i]] + where[where_at[x[i]] + y[i]] * m + j0;
        if (f & 1) memcpy(o, wb + (long)dst[i] * block, nb * sizeof(double));
        else for (long j = 0; j < nb; j++) o[j] = ws[dst[i]];
      } else {
        int a = x[i], b = k == 3 ? y[i] : x[i];
        const double *pa = (f & 1) ? wb + (long)a * block : ws + a;
        const double *pb = (f & 2) ? wb + (long)b * block : ws + b;
        long sa = (f & 1) ? 1 : 0, sb = (f & 2) ? 1 : 0, len = f ? nb : 1;
        double *res = f ? r : ws + dst[i];
        if (code[i] < 100) {
          if (f) own_block(code[i], len, pa, sa, pb, sb, res);
          else ws[dst[i]] = own(code[i], *pa, *pb);
        } else {
          double tmp[BLOCK_MAX];
          double *target = (res == pa || res == pb) ? tmp : res;
          intptr_t dims[1] = {len};
          if (code[i] == 100) {
            char *args[2] = {(char *)pa, (char *)target};
            intptr_t steps[2] = {sa * 8, 8};
            ((loop_t)loops[loop[i]])(args, dims, steps, loop_data[loop[i]]);
          } else {
            char *args[3] = {(char *)pa, (char *)pb, (char *)target};
            intptr_t steps[3] = {sa * 8, sb * 8, 8};
            ((loop_t)loops[loop[i]])(args, dims, steps, loop_data[loop[i]]);
          }
          if (target != res) memcpy(res, target, len * sizeof(double));
        }
      }
    }
  }
  (void)zero;
  return 0;
}

/* In program order: whether each instruction's operands vary with the column (flags, as above)
   and whether a truth value reaches an operation that is not safe for one (cls: bit 0 the
   operation gives a truth value, bit 1 it takes one as numpy does, bit 2 it keeps one).
   0, or 1 for a truth value where numpy would change type, 2 for an operand out of range. */
int optdesign_program_flags(long n, const int *kind, const int *x, const int *y, const int *dst, const int *cols,
                            long n_in, const unsigned char *cls, long work, unsigned char *flags,
                            unsigned char *block, unsigned char *truth) {
  for (long i = 0; i < n; i++) {
    int k = kind[i], d = dst[i];
    if (d < 0 || d >= work) return 2;
    if (k == 0) {
      if (x[i] < 0 || x[i] >= n_in) return 2;
      block[d] = cols[x[i]] != 0; truth[d] = 0;
    } else if (k == 2) {
      block[d] = 0; truth[d] = 0;
    } else if (k == 1) {
      flags[i] = block[d];
    } else {
      int a = x[i], b = k == 3 ? y[i] : x[i];
      if (a < 0 || a >= work || b < 0 || b >= work) return 2;
      if ((truth[a] || truth[b]) && !(cls[i] & 2)) return 1;
      flags[i] = (block[a] ? 1 : 0) | ((k == 3 && block[b]) ? 2 : 0);
      unsigned char t = (cls[i] & 1) || ((cls[i] & 4) && truth[a] && truth[b]);
      block[d] = flags[i] != 0; truth[d] = t;
    }
  }
  return 0;
}
"""

_function = {}   # the loaded C function (one per process)
_tried = [-np.inf]
_checked = {}    # ufunc -> (loop address, data address) or None when it does not pass


def _ufunc_loop(ufunc):
    """(address of numpy's float64 loop of ``ufunc``, its data) read from the ufunc object
    (numpy's PyUFuncObject: functions at 32, data at 40, ntypes at 48, types at 64 bytes), or
    None when its layout is not the one expected (its name at 56 must be the ufunc's)."""
    if ctypes.sizeof(ctypes.c_void_p) != 8 or not np.__version__.startswith("2."):
        return None   # the offsets are numpy 2's on a 64-bit build; elsewhere the numpy loop runs
    nargs = ufunc.nin + ufunc.nout
    base = id(ufunc)
    read = lambda offset, t: t.from_address(base + offset).value   # noqa: E731
    name = read(56, ctypes.c_void_p)
    if not name or ctypes.string_at(name).decode() != ufunc.__name__:
        return None
    if (read(16, ctypes.c_int), read(20, ctypes.c_int)) != (ufunc.nin, ufunc.nout):
        return None
    ntypes, types = read(48, ctypes.c_int), read(64, ctypes.c_void_p)
    if not types or ntypes <= 0:
        return None
    codes = ctypes.string_at(types, ntypes * nargs)
    double = np.dtype(np.float64).num
    for i in range(ntypes):
        if all(c == double for c in codes[i * nargs:(i + 1) * nargs]):
            functions, data = read(32, ctypes.c_void_p), read(40, ctypes.c_void_p)
            return (ctypes.c_void_p.from_address(functions + 8 * i).value,
                    ctypes.c_void_p.from_address(data + 8 * i).value if data else None)
    return None


def _check_values():
    """A thousand float64 values of every kind the operations meet (both signs, tiny, huge,
    zeros, infinities, NaN, near multiples of pi/2 and near 1)."""
    rng = np.random.default_rng(20261129)
    v = np.r_[rng.normal(0, 1, 300), rng.normal(0, 30, 200), rng.uniform(-1, 1, 200) * 10.0 ** rng.integers(-300, 300, 200),
              np.pi / 2 * np.arange(-20, 21) + rng.normal(0, 1e-9, 41), 1 + rng.normal(0, 1e-6, 100),
              [0.0, -0.0, np.inf, -np.inf, np.nan, 1.0, -1.0, 0.5, 2.0, 3.0]]
    return v


def _loops(ufuncs):
    """Each ufunc's (loop address, data address), checked: called on the check values (and
    pairs of them) as the C calls it, the same bits as the ufunc; None for one that is not."""
    out = {}
    for u in ufuncs:
        if u not in _checked:
            _checked[u] = _check(u)
        out[u] = _checked[u]
    return out


def _check(u):
    try:
        found = _ufunc_loop(u)
    except (ValueError, UnicodeDecodeError, OSError):
        return None
    if found is None or found[0] is None:
        return None
    loop_t = ctypes.CFUNCTYPE(None, ctypes.POINTER(ctypes.c_void_p), ctypes.POINTER(ctypes.c_ssize_t),
                              ctypes.POINTER(ctypes.c_ssize_t), ctypes.c_void_p)
    call = loop_t(found[0])
    v = _check_values()
    ins = [v] if u.nin == 1 else [np.repeat(v, 7), np.tile(v, 7)[::-1].copy()]
    for strides in ([8] * u.nin, [0] + [8] * (u.nin - 1), [8] * (u.nin - 1) + [0]):
        args = [a if s else np.full_like(a, a[len(a) // 3]) for a, s in zip(ins, strides)]
        r = np.empty_like(args[0])
        argv = (ctypes.c_void_p * (u.nin + 1))(*[a.ctypes.data for a in args], r.ctypes.data)
        call(argv, (ctypes.c_ssize_t * 1)(len(r)), (ctypes.c_ssize_t * (u.nin + 1))(*strides, 8), found[1])
        with np.errstate(all="ignore"):
            ref = u(*[a if s else a[:1] for a, s in zip(args, strides)]) if u.nin == 2 else u(args[0])
        ref = np.broadcast_to(ref, r.shape)
        if not np.array_equal(r.view(np.int64), ref.view(np.int64)):
            return None
    return found


def _library():
    """The C function, or None (no compiler, the cache off, or its compiling failed: looked for
    again after RETRY_S).  Compiled at its first use, waited for (about a second of gcc, once
    per cache folder), not in a background process."""
    if "f" in _function or time.monotonic() - _tried[0] < RETRY_S:
        return _function.get("f")
    _tried[0] = time.monotonic()
    key = compiled.entry_key("program_c", SOURCE, {"block_max": 256, "functions": 2})
    if key is None:
        _tried[0] = np.inf
        return None

    def prepare(folder):
        c_file = folder / f"{key}.src{os.getpid()}.c"
        compiled.write_atomic(c_file, SOURCE.encode())
        return {"kind": "source", "name": NAME, "source": str(c_file), "cleanup": [str(c_file)]}

    path = compiled.library(key, prepare, wait=True)   # (small: about a second of gcc, once; no background process)
    if path is None:
        return None
    try:
        f = getattr(ctypes.CDLL(str(path)), NAME)
    except (OSError, AttributeError):
        compiled.remove(key)
        return None
    try:
        flags = getattr(ctypes.CDLL(str(path)), f"{NAME}_flags")
    except AttributeError:
        compiled.remove(key)
        return None
    f.restype = flags.restype = ctypes.c_int
    f.argtypes = [ctypes.c_long, *[ctypes.c_void_p] * 13, ctypes.c_long, ctypes.c_long, *[ctypes.c_void_p] * 4]
    flags.argtypes = [ctypes.c_long, *[ctypes.c_void_p] * 5, ctypes.c_long, ctypes.c_void_p, ctypes.c_long,
                      *[ctypes.c_void_p] * 3]
    _function["flags"] = flags
    _function["f"] = f
    return f


class ProgramC:
    """A stored program's arrays made ready for the C: per instruction its kind, the C's code,
    operands, result and whether each operand varies with the column (``columns``: which inputs
    are given per column); ``ready`` False when the C cannot give numpy's numbers for it."""

    def __init__(self, rows, constants, work: int, columns):
        """``rows``: the program as :mod:`.programs` stores it (kind, CasADi operation or
        input/output number, b0, b1, c)."""
        self.work = int(work)
        self.constants = np.ascontiguousarray(constants, float)
        self.columns = np.asarray([bool(c) for c in columns], np.int32)
        self.ready = self._prepare(np.asarray(rows, np.int64))

    def _prepare(self, rows):
        if rows.ndim != 2 or rows.shape[1] != 5 or not len(rows):
            return False
        kind, op, b0, b1, c = (rows[:, j] for j in range(5))
        n = len(rows)
        code, loop = np.zeros(n, np.int32), np.zeros(n, np.int32)
        x, y = np.zeros(n, np.int32), np.zeros(n, np.int32)
        computed = (kind == 3) | (kind == 4)
        ufuncs = []
        for o in np.unique(op[computed]).tolist():
            at = computed & (op == o)
            if o in OWN:
                code[at] = OWN[o]
            elif o in LOOPS:
                u = LOOPS[o]
                if u not in ufuncs:
                    ufuncs.append(u)
                code[at], loop[at] = (BINARY_LOOP if u.nin == 2 else UNARY_LOOP), ufuncs.index(u)
            else:
                return False
        found = _loops(ufuncs)
        if any(found[u] is None for u in ufuncs):
            return False
        io, const = (kind == 0) | (kind == 1), kind == 2
        if np.count_nonzero(const) > len(self.constants) or np.any(op[kind == 0] >= len(self.columns)):
            return False
        x[io], y[io] = op[io], b0[io]                       # input/output number, nonzero
        y[const] = np.arange(np.count_nonzero(const))       # the constants in order
        x[computed], y[kind == 3] = b0[computed], b1[kind == 3]
        # in program order: whether each operand varies with the column, and no truth value where numpy changes type
        cls = np.zeros(n, np.uint8)
        for bit, names in ((1, _BOOL_OUT), (2, _BOOL_SAFE), (4, ("OP_MUL", "OP_SQ", "OP_ASSIGN"))):
            cls[computed & np.isin(op, [getattr(ca, k) for k in names if hasattr(ca, k)])] |= bit
        flags, block, truth = np.zeros(n, np.uint8), np.zeros(self.work, np.uint8), np.zeros(self.work, np.uint8)
        kind32, dst = np.ascontiguousarray(kind, np.int32), np.ascontiguousarray(c, np.int32)
        status = _function["flags"](n, kind32.ctypes.data, x.ctypes.data, y.ctypes.data, dst.ctypes.data,
                                     self.columns.ctypes.data, len(self.columns), cls.ctypes.data, self.work,
                                     flags.ctypes.data, block.ctypes.data, truth.ctypes.data)
        if status != 0:
            return False
        self.arrays = [kind32, code, x, y, dst, flags, loop]
        self.io = [(x[kind == j].astype(np.int64), y[kind == j].astype(np.int64)) for j in (0, 1)]   # (number, nonzero)
        self.loops = (ctypes.c_void_p * max(1, len(ufuncs)))(*[found[u][0] for u in ufuncs])
        self.loop_data = (ctypes.c_void_p * max(1, len(ufuncs)))(*[found[u][1] for u in ufuncs])
        return True

    def __call__(self, f, inputs, outs, where) -> bool:
        """Run over the columns: ``inputs`` (per input: its nonzeros x m, C-contiguous, when it
        is given per column, else its nonzeros), ``outs`` (per output: numel x m, C-contiguous,
        written) and ``where`` (per output: the row of each nonzero).  False when the C refused."""
        m = outs[0].shape[1]
        ins = [np.ascontiguousarray(a, float) for a in inputs]
        for (number, nonzero), sizes in zip(self.io, ([len(a) for a in ins], [len(w) for w in where])):
            sizes = np.asarray(sizes, np.int64)   # (every input and output place read or written in range)
            if np.any((number < 0) | (number >= len(sizes))) or np.any((nonzero < 0) | (nonzero >= sizes[number])):
                return False
        in_ptrs = (ctypes.c_void_p * len(ins))(*[a.ctypes.data for a in ins])
        out_ptrs = (ctypes.c_void_p * len(outs))(*[o.ctypes.data for o in outs])
        where_flat = np.ascontiguousarray(np.concatenate([np.asarray(w, np.int64) for w in where] + [np.zeros(1, np.int64)]))
        where_at = np.cumsum([0] + [len(w) for w in where[:-1]]).astype(np.int64)
        block = min(BLOCK, max(1, m))
        ws, wb = np.zeros(self.work), np.zeros(self.work * block)
        k, code, x, y, d, flags, loop = self.arrays
        status = f(len(k), k.ctypes.data, code.ctypes.data, x.ctypes.data, y.ctypes.data, d.ctypes.data,
                   flags.ctypes.data, loop.ctypes.data, self.constants.ctypes.data, ctypes.addressof(in_ptrs),
                   self.columns.ctypes.data, ctypes.addressof(out_ptrs), where_flat.ctypes.data, where_at.ctypes.data,
                   m, block, ws.ctypes.data, wb.ctypes.data, ctypes.addressof(self.loops),
                   ctypes.addressof(self.loop_data))
        return status == 0


def pending() -> bool:
    """Whether the C may still come in this process (being compiled: looked for again later)."""
    return "f" not in _function and _tried[0] != np.inf


def program(rows, constants, work, columns):
    """(:class:`ProgramC` of the stored program, the C function), or None (numpy then runs it)."""
    f = _library()
    if f is None:
        return None
    p = ProgramC(rows, constants, work, columns)
    return (p, f) if p.ready else None
