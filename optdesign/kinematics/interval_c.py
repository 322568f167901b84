"""C source of an :class:`~.enclosure.IntervalProgram`: the same interval operations as
:mod:`.intervals`, compiled.

Each operation of :mod:`.intervals` is an inline C function here with the same contract: the
same formulas in the same order of IEEE operations (no fast-math, no fused multiply-adds: the
compile cache's flags), the same outward rounding (2^-50 of the value plus 1e-300 after +, -,
*, /, sqrt; 2^-48 after the C library's elementary functions, as after numpy's: both assumed
accurate to 16 ulp), numpy's NaN rules (``np.minimum`` keeps a NaN, ``np.fmin`` drops it; an
interval outside a function's domain, and a product or quotient with an operand that has a NaN
end, NaN at both ends), and the same jump tracking (comparisons, if_else, sign, floor, atan2's
branch cut: per interval, where the outcome is not decided; an output's flag is the OR over the
jumps it depends on).  A product or quotient by a nonzero point is taken by the general
four-product formula (numpy takes two products): the same numbers.

The program runs as loops over blocks of ``BLOCK`` intervals, one loop per instruction (the
compiler vectorises the loops without library calls; the last block's loops over its intervals
only, to a multiple of 8: a call of a few intervals costs a few), the parameters' own work
redone per block (so that each interval may carry its own parameter vector).  The C function::

    int NAME(long n, const double *lo, const double *hi, const double *p, long p_stride,
             const unsigned char *need, double *out_lo, double *out_hi, unsigned char *out_jump,
             const long *col, double *sh_lo, double *sh_hi, unsigned char *sh_jump, const long *src,
             long n_sh)

evaluates the intervals [lo[i], hi[i]], i < n, with parameters p + i * p_stride (p_stride 0:
one vector for all), running only the varying instructions j with need[j] (the program cut to
the rows asked for); it writes each output's rows, stacked (row r of output j at
``offsets[j] + r``), as out_*[row * n + i].  Returns 0, or 1 when it could not allocate its
work arrays.  :func:`c_source` gives the source and the stacked row of each output.

The same function runs a program in two phases, so that work which does not depend on the
parameters that differ between cases is done once per distinct interval
(:meth:`~optdesign.model.intervals_compiled.CompiledProgram.__call__`): need[j] = 2 also
exports instruction j's value (and its jump flags) to column col[j] of ``sh_*`` (column-major
over the n intervals of this call: sh_*[col[j] * n + i]); need[j] = 3 imports it instead of
computing it, for interval i from sh_*[col[j] * n_sh + src[i]].  Each instruction does the
same operations on the same operands in either phase: the values are the same bits.
"""
from __future__ import annotations

import math

import casadi as ca

from .intervals import ROUND, ROUND_LIB, TINY, TWO_PI

BLOCK = 256  # intervals per loop of one operation (the same numbers; truck-crane batches 0.89-0.91x the time of 64, measured)

_PRELUDE = r"""
#include <math.h>
#include <float.h>
#include <stdlib.h>
#include <string.h>
#pragma GCC push_options
#pragma GCC optimize ("O3")
#define B %(block)d
#define TWO_PI %(two_pi)s
typedef double slot[2][B];
/* as intervals.py's _down/_up: a lower bound that overflowed to +inf stands for a finite value
   above DBL_MAX, so DBL_MAX is its bound (inf - inf would give NaN); an upper -inf likewise */
static inline double capd(double x) { return x > DBL_MAX ? DBL_MAX : x; }
static inline double capu(double x) { return x < -DBL_MAX ? -DBL_MAX : x; }
static inline double dn(double x) { x = capd(x); return x - (fabs(x) * %(round)s + %(tiny)s); }
static inline double up(double x) { x = capu(x); return x + (fabs(x) * %(round)s + %(tiny)s); }
static inline double dnl(double x) { x = capd(x); return x - (fabs(x) * %(round_lib)s + %(tiny)s); }
static inline double upl(double x) { x = capu(x); return x + (fabs(x) * %(round_lib)s + %(tiny)s); }
/* numpy's minimum/maximum (a NaN wins) and fmin/fmax (a NaN loses); written as two flat selects
   (the compiler vectorises these, not the nested form) */
static inline double nmin(double x, double y) { double m = x < y ? x : y; return x != x ? x : m; }
static inline double nmax(double x, double y) { double m = x > y ? x : y; return x != x ? x : m; }
static inline double fmn(double x, double y) { double m = x < y ? x : y; return y != y ? x : m; }
static inline double fmx(double x, double y) { double m = x > y ? x : y; return y != y ? x : m; }
static inline double sgn(double x) { return x > 0 ? 1.0 : (x < 0 ? -1.0 : (x == 0 ? 0.0 : x)); }
static inline int contains(double a, double b, double centre) {
  double slack = 1e-9 * (1.0 + fabs(a) + fabs(b));
  return floor((b - centre) / TWO_PI + slack) >= ceil((a - centre) / TWO_PI - slack);
}
#define ARGS2 double a, double b, double c, double d, double *l, double *h
#define ARGS1 double a, double b, double *l, double *h
static inline void iv_add(ARGS2) { *l = dn(a + c); *h = up(b + d); }
static inline void iv_sub(ARGS2) { *l = dn(a - d); *h = up(b - c); }
/* intervals.py's _undefined: an operand with a NaN end (no enclosure) gives NaN at both ends */
#define UNDEFINED(a, b, c, d) (((a) != (a)) | ((b) != (b)) | ((c) != (c)) | ((d) != (d)))
static inline void iv_mul(ARGS2) {
  double p1 = a * c, p2 = a * d, p3 = b * c, p4 = b * d;
  double lo = dn(fmn(fmn(p1, p2), fmn(p3, p4))), hi = up(fmx(fmx(p1, p2), fmx(p3, p4)));
  int bad = UNDEFINED(a, b, c, d);
  *l = bad ? NAN : lo; *h = bad ? NAN : hi;
}
static inline void iv_div(ARGS2) {
  double q1 = a / c, q2 = a / d, q3 = b / c, q4 = b / d;
  double lo = dn(fmn(fmn(q1, q2), fmn(q3, q4))), hi = up(fmx(fmx(q1, q2), fmx(q3, q4)));
  int zero = (c <= 0) & (d >= 0), bad = UNDEFINED(a, b, c, d);
  lo = zero ? -INFINITY : lo; hi = zero ? INFINITY : hi;
  *l = bad ? NAN : lo; *h = bad ? NAN : hi;
}
static inline void iv_sq(ARGS1) {
  double a2 = a * a, b2 = b * b;
  double lo = ((a <= 0) & (b >= 0)) ? 0.0 : nmin(a2, b2);
  *l = nmax(dn(lo), 0.0); *h = up(nmax(a2, b2));
}
static inline void iv_powr(ARGS2) {   /* exp(y log x), x >= 0 */
  double la = dnl(log(nmax(a, 0.0))), lb = upl(log(nmax(b, 0.0))), ml, mh;
  iv_mul(la, lb, c, d, &ml, &mh);
  *l = a < 0 ? NAN : dnl(exp(ml)); *h = a < 0 ? NAN : upl(exp(mh));
}
static inline void iv_powi(double a, double b, int n, double *l, double *h) {   /* repeated products */
  if (n == 0) { *l = 1.0; *h = 1.0; return; }
  double lo = a * 0 + 1.0, hi = b * 0 + 1.0;
  for (int k = 0; k < (n < 0 ? -n : n); k++) iv_mul(lo, hi, a, b, &lo, &hi);
  if (n %% 2 == 0) {
    lo = nmax(lo, 0.0);
    lo = ((a <= 0) & (b >= 0)) ? 0.0 : lo;
    hi = nmin(hi, upl(pow(nmax(fabs(a), fabs(b)), (double)(n < 0 ? -n : n))));   /* x^|n| before 1/x */
  }
  if (n < 0) iv_div(1.0, 1.0, lo, hi, l, h); else { *l = lo; *h = hi; }
}
static inline void iv_pow(ARGS2) {   /* an exponent that does not vary: an integer point exactly */
  if (c == d && c == floor(c) && fabs(c) <= 64) iv_powi(a, b, (int)c, l, h); else iv_powr(a, b, c, d, l, h);
}
static inline void iv_hypot(ARGS2) {
  double l1, h1, l2, h2; iv_sq(a, b, &l1, &h1); iv_sq(c, d, &l2, &h2);
  *l = dnl(sqrt(dn(l1 + l2))); *h = upl(sqrt(up(h1 + h2)));
}
static inline void iv_fmin(ARGS2) { *l = nmin(a, c); *h = nmin(b, d); }
static inline void iv_fmax(ARGS2) { *l = nmax(a, c); *h = nmax(b, d); }
static inline unsigned char iv_bool(int t, int f, double *l, double *h) {
  *l = t ? 1.0 : 0.0; *h = f ? 0.0 : 1.0; return !(t | f);
}
static inline unsigned char iv_lt(ARGS2) { return iv_bool(b < c, a >= d, l, h); }
static inline unsigned char iv_le(ARGS2) { return iv_bool(b <= c, a > d, l, h); }
static inline unsigned char iv_eq(ARGS2) { return iv_bool((a == b) & (b == c) & (c == d), (b < c) | (d < a), l, h); }
static inline unsigned char iv_ne(ARGS2) { return iv_bool((b < c) | (d < a), (a == b) & (b == c) & (c == d), l, h); }
#define TRUE_(a, b) (((a) > 0) | ((b) < 0))
#define FALSE_(a, b) (((a) == 0) & ((b) == 0))
static inline unsigned char iv_and(ARGS2) { return iv_bool(TRUE_(a, b) & TRUE_(c, d), FALSE_(a, b) | FALSE_(c, d), l, h); }
static inline unsigned char iv_or(ARGS2) { return iv_bool(TRUE_(a, b) | TRUE_(c, d), FALSE_(a, b) & FALSE_(c, d), l, h); }
static inline unsigned char iv_not(ARGS1) { return iv_bool(FALSE_(a, b), TRUE_(a, b), l, h); }
static inline unsigned char iv_if_else_zero(ARGS2) {
  int t = TRUE_(a, b), f = FALSE_(a, b);
  double lo = nmin(c, 0.0), hi = nmax(d, 0.0);
  lo = f ? 0.0 : lo; hi = f ? 0.0 : hi;
  *l = t ? c : lo; *h = t ? d : hi;
  return !(t | f);
}
static inline unsigned char iv_atan2(double ya, double yb, double xa, double xb, int periodic, double *l, double *h) {
  double c1 = atan2(ya, xa), c2 = atan2(ya, xb), c3 = atan2(yb, xa), c4 = atan2(yb, xb);
  double lo = dnl(nmin(nmin(nmin(c1, c2), c3), c4)), hi = upl(nmax(nmax(nmax(c1, c2), c3), c4));
  int cut = (xa < 0) & (ya < 0) & (yb > 0);
  int origin = (xa <= 0) & (xb >= 0) & (ya <= 0) & (yb >= 0);
  if (periodic) {
    double w1 = c1 < 0 ? c1 + TWO_PI : c1, w2 = c2 < 0 ? c2 + TWO_PI : c2;
    double w3 = c3 < 0 ? c3 + TWO_PI : c3, w4 = c4 < 0 ? c4 + TWO_PI : c4;
    if (cut) { lo = dnl(nmin(nmin(nmin(w1, w2), w3), w4)); hi = upl(nmax(nmax(nmax(w1, w2), w3), w4)); }
    cut = origin;
  }
  *l = (origin | cut) ? %(pi_lo)s : lo; *h = (origin | cut) ? %(pi_hi)s : hi;
  return cut | origin;
}
static inline unsigned char iv_atan2_all(ARGS2) { return iv_atan2(a, b, c, d, 0, l, h); }
static inline unsigned char iv_atan2_periodic(ARGS2) { return iv_atan2(a, b, c, d, 1, l, h); }
static inline void iv_neg(ARGS1) { *l = -b; *h = -a; }
static inline void iv_assign(ARGS1) { *l = a; *h = b; }
static inline void iv_twice(ARGS1) { *l = 2.0 * a; *h = 2.0 * b; }
/* a function over an interval outside its domain: NaN at both ends (intervals.py's _outside) */
static inline void iv_sqrt(ARGS1) {
  double lo = dn(sqrt(nmax(a, 0.0))), hi = up(sqrt(b));
  *l = b < 0 ? NAN : nmax(lo, 0.0); *h = b < 0 ? NAN : hi;
}
static inline void iv_inv(ARGS1) { iv_div(1.0, 1.0, a, b, l, h); }
static inline void iv_fabs(ARGS1) {
  *l = ((a <= 0) & (b >= 0)) ? 0.0 : nmin(fabs(a), fabs(b)); *h = nmax(fabs(a), fabs(b));
}
static inline unsigned char iv_sign(ARGS1) { *l = sgn(a); *h = sgn(b); return *l != *h; }
static inline void iv_sin_(double a, double b, int cosine, double top, double bottom, double *l, double *h) {
  double fa = cosine ? cos(a) : sin(a), fb = cosine ? cos(b) : sin(b);
  double lo = dnl(nmin(fa, fb)), hi = upl(nmax(fa, fb));
  hi = contains(a, b, top) ? 1.0 : nmin(hi, 1.0);
  lo = contains(a, b, bottom) ? -1.0 : nmax(lo, -1.0);
  int wide = (b - a) >= TWO_PI;
  *l = wide ? -1.0 : lo; *h = wide ? 1.0 : hi;
}
static inline void iv_sin(ARGS1) { iv_sin_(a, b, 0, %(sin_top)s, %(sin_bottom)s, l, h); }
static inline void iv_cos(ARGS1) { iv_sin_(a, b, 1, %(cos_top)s, %(cos_bottom)s, l, h); }
#define MONOTONE(name, f) static inline void name(ARGS1) { *l = dnl(f(a)); *h = upl(f(b)); }
MONOTONE(iv_exp, exp) MONOTONE(iv_atan, atan) MONOTONE(iv_tanh, tanh) MONOTONE(iv_sinh, sinh)
MONOTONE(iv_expm1, expm1) MONOTONE(iv_erf, erf)
static inline void iv_log(ARGS1) { *l = b < 0 ? NAN : dnl(log(nmax(a, 0.0))); *h = b < 0 ? NAN : upl(log(b)); }
static inline void iv_log1p(ARGS1) {
  *l = b < -1 ? NAN : dnl(log1p(nmax(a, -1.0))); *h = b < -1 ? NAN : upl(log1p(b));
}
static inline double clip1(double x) { return nmin(nmax(x, -1.0), 1.0); }
static inline void iv_asin(ARGS1) {
  int out = (a > 1) | (b < -1);
  *l = out ? NAN : dnl(asin(clip1(a))); *h = out ? NAN : upl(asin(clip1(b)));
}
static inline void iv_acos(ARGS1) {
  int out = (a > 1) | (b < -1);
  *l = out ? NAN : dnl(acos(clip1(b))); *h = out ? NAN : upl(acos(clip1(a)));
}
static inline void iv_tan(ARGS1) {
  int pole = contains(a, b, %(half_pi)s) | contains(a, b, %(minus_half_pi)s) | ((b - a) >= %(pi)s);
  *l = pole ? -INFINITY : dnl(tan(a)); *h = pole ? INFINITY : upl(tan(b));
}
static inline void iv_cosh(ARGS1) {
  double lo = dnl(cosh(nmin(fabs(a), fabs(b)))), hi = upl(cosh(nmax(fabs(a), fabs(b))));
  *l = ((a <= 0) & (b >= 0)) ? 1.0 : lo; *h = hi;
}
static inline unsigned char iv_floor(ARGS1) { *l = floor(a); *h = floor(b); return *l != *h; }
static inline unsigned char iv_ceil(ARGS1) { *l = ceil(a); *h = ceil(b); return *l != *h; }
/* each operation over a block of intervals: a loop the compiler vectorises (its operands never
   share memory with its results: the generator gives every result a slot of its own) */
#define R_ double *restrict
#define C_ const double *restrict
#define BLK2(f) static void __attribute__((noinline)) b_##f(int nb, C_ a, C_ b, C_ c, C_ d, R_ l, R_ h) \
  { for (int i = 0; i < nb; i++) iv_##f(a[i], b[i], c[i], d[i], l + i, h + i); }
#define BLK1(f) static void __attribute__((noinline)) b_##f(int nb, C_ a, C_ b, R_ l, R_ h) \
  { for (int i = 0; i < nb; i++) iv_##f(a[i], b[i], l + i, h + i); }
#define BLK2J(f) static void __attribute__((noinline)) b_##f(int nb, C_ a, C_ b, C_ c, C_ d, R_ l, R_ h, \
  unsigned char *restrict u) { for (int i = 0; i < nb; i++) u[i] = iv_##f(a[i], b[i], c[i], d[i], l + i, h + i); }
#define BLK1J(f) static void __attribute__((noinline)) b_##f(int nb, C_ a, C_ b, R_ l, R_ h, unsigned char *restrict u) \
  { for (int i = 0; i < nb; i++) u[i] = iv_##f(a[i], b[i], l + i, h + i); }
BLK2(add) BLK2(sub) BLK2(mul) BLK2(div) BLK2(powr) BLK2(pow) BLK2(hypot) BLK2(fmin) BLK2(fmax)
BLK2J(lt) BLK2J(le) BLK2J(eq) BLK2J(ne) BLK2J(and) BLK2J(or) BLK2J(if_else_zero) BLK2J(atan2_all)
BLK2J(atan2_periodic) BLK1(neg) BLK1(assign) BLK1(twice) BLK1(sq) BLK1(sqrt) BLK1(inv) BLK1(fabs) BLK1J(sign)
BLK1J(not) BLK1(sin) BLK1(cos) BLK1(exp) BLK1(log) BLK1(asin) BLK1(acos) BLK1(atan) BLK1(tan) BLK1(tanh)
BLK1(sinh) BLK1(cosh) BLK1(log1p) BLK1(expm1) BLK1J(floor) BLK1J(ceil) BLK1(erf)
/* an if_else: the sum of its two if_else_zero, or where undecided (u) the hull of their branches */
static void __attribute__((noinline)) b_select(int nb, C_ a, C_ b, C_ c, C_ d, C_ xl, C_ xh, C_ yl, C_ yh,
                                               const unsigned char *restrict u, R_ l, R_ h) {
  for (int i = 0; i < nb; i++) {
    double l_, h_; iv_add(a[i], b[i], c[i], d[i], &l_, &h_);
    l[i] = u[i] ? nmin(xl[i], yl[i]) : l_; h[i] = u[i] ? nmax(xh[i], yh[i]) : h_;
  }
}
static void __attribute__((noinline)) b_jor(int nb, unsigned char *restrict j, const unsigned char *restrict x)
  { for (int i = 0; i < nb; i++) j[i] |= x[i]; }
/* the copies in and out of a block (the last block's missing intervals repeat its last one) */
static void __attribute__((noinline)) g_in(C_ x, C_ y, long stride, long i0, long m, R_ l, R_ h)
  { for (int i = 0; i < B; i++) { long q = (i0 + (i < m ? i : m - 1)) * stride; l[i] = x[q]; h[i] = y[q]; } }
static void __attribute__((noinline)) g_const(double v, R_ l, R_ h) { for (int i = 0; i < B; i++) { l[i] = v; h[i] = v; } }
static void __attribute__((noinline)) g_out(C_ l, C_ h, R_ x, R_ y, long m)
  { for (long i = 0; i < m; i++) { x[i] = l[i]; y[i] = h[i]; } }
static void __attribute__((noinline)) g_outj(const unsigned char *restrict j, unsigned char *restrict x, long m) { memcpy(x, j, m); }
static void __attribute__((noinline)) g_import(C_ x, C_ y, const long *restrict src, long m, R_ l, R_ h)
  { for (int i = 0; i < B; i++) { long q = src[i < m ? i : m - 1]; l[i] = x[q]; h[i] = y[q]; } }
static void __attribute__((noinline)) g_importj(const unsigned char *restrict x, const long *restrict src, long m,
                                                unsigned char *restrict j)
  { for (int i = 0; i < B; i++) j[i] = x[src[i < m ? i : m - 1]]; }
#pragma GCC pop_options
#define L(s) w[s][0]
#define H(s) w[s][1]
#define A(s) w[s][0], w[s][1]
#define IN_S(o) g_in(lo, hi, 1, i0, m, L(o), H(o))
#define IN_P(o, k) g_in(p + (k), p + (k), p_stride, i0, m, L(o), H(o))
#define CONST(o, v) g_const(v, L(o), H(o))
#define COPY(o, x) memcpy(w[o], w[x], sizeof(slot))
#define COPYJ(o, x) memcpy(J[o], J[x], B)
#define OUT(r, x) g_out(L(x), H(x), out_lo + (r) * n + i0, out_hi + (r) * n + i0, m)
#define OUTJ(r, x) g_outj(J[x], out_jump + (r) * n + i0, m)
#define EXPORT(x, e) g_out(L(x), H(x), sh_lo + (e) * n + i0, sh_hi + (e) * n + i0, m)
#define EXPORTJ(x, e) g_outj(J[x], sh_jump + (e) * n + i0, m)
#define IMPORT(o, e) g_import(sh_lo + (e) * n_sh, sh_hi + (e) * n_sh, src + i0, m, L(o), H(o))
#define IMPORTJ(o, e) g_importj(sh_jump + (e) * n_sh, src + i0, m, J[o])
"""

# Enclosure.bounds's forms (kinematics/enclosure.py), element by element: the same IEEE
# operations in the same order as its numpy (np.maximum: nmax, np.where: ?:), so the same bits
_FORMS = r"""
#pragma GCC push_options
#pragma GCC optimize ("O3")
static inline double corr_g(double a, double r, double b) {   /* enclosure._upper_correction's g */
  double end = nmax(a * r + b * r * r, 0.0);
  double inner = ((b < 0) & (a > 0) & (a < -2.0 * b * r)) ? a * a / (-4.0 * b) : end;
  return b >= 0 ? end : inner;
}
static inline double correction(double d1_lo, double d1_hi, double d2_hi, double r, double r_below) {
  double b = 0.5 * d2_hi;
  double c = nmax(corr_g(d1_hi, r, b), corr_g(-d1_lo, r_below, b));
  return c + fabs(c) * 1e-12;
}
/* (restrict: the outputs are arrays of their own, the inputs only read) */
void %(name)s_forms(long n_rows, const long *restrict rows, long n, long n_ends, C_ v_lo, C_ v_hi,
    const unsigned char *restrict v_jump, C_ d_lo, C_ d_hi, const unsigned char *restrict d_jump,
    C_ e_lo, C_ e_hi, C_ vm_lo, C_ vm_hi, C_ dm_lo, C_ dm_hi, C_ at_lo, C_ at_hi, const long *restrict end_a,
    const long *restrict end_b, C_ r_above, C_ r_below, R_ out_lo, R_ out_hi) {
  for (long k = 0; k < n_rows; k++) {
    long o = rows[k] * n, oe = rows[k] * n_ends;
    for (long i = 0; i < n; i++) {
      long x = o + i;
      int smooth0 = !v_jump[x], smooth1 = smooth0 & !d_jump[x];
      double ra = r_above[i], rb = r_below[i];
      double mv = nmax(nmax(ra * d_hi[x], -rb * d_lo[x]), 0.0), mv_low = nmax(nmax(-ra * d_lo[x], rb * d_hi[x]), 0.0);
      mv = mv + fabs(mv) * 1e-12; mv_low = mv_low + fabs(mv_low) * 1e-12;
      double U_mv = up(vm_hi[x] + mv), L_mv = dn(vm_lo[x] - mv_low);
      double U_t = up(vm_hi[x] + correction(dm_lo[x], dm_hi[x], e_hi[x], ra, rb));
      double L_t = dn(vm_lo[x] - correction(-dm_hi[x], -dm_lo[x], -e_lo[x], ra, rb));
      double de = nmax(ra, rb) * nmax(e_hi[x], -e_lo[x]); de = de + fabs(de) * 1e-12;
      double lo_d = dn(dm_lo[x] - de), hi_d = up(dm_hi[x] + de);
      double dv_lo = (smooth1 & (lo_d > d_lo[x])) ? lo_d : d_lo[x];
      double dv_hi = (smooth1 & (hi_d < d_hi[x])) ? hi_d : d_hi[x];
      int rising = smooth0 & (dv_lo >= 0), falling = smooth0 & (dv_hi <= 0);
      /* both ends read whatever the form (no load under a condition: the loop vectorises) */
      double a_lo = at_lo[oe + end_a[i]], a_hi = at_hi[oe + end_a[i]], b_lo = at_lo[oe + end_b[i]], b_hi = at_hi[oe + end_b[i]];
      double U_m = rising ? b_hi : (falling ? a_hi : INFINITY);
      double L_m = rising ? a_lo : (falling ? b_lo : -INFINITY);
      double U = v_hi[x], L = v_lo[x];
      U = (smooth0 & (U_mv < U)) ? U_mv : U; L = (smooth0 & (L_mv > L)) ? L_mv : L;
      U = (smooth1 & (U_t < U)) ? U_t : U; L = (smooth1 & (L_t > L)) ? L_t : L;
      out_hi[x] = U_m < U ? U_m : U;
      out_lo[x] = L_m > L ? L_m : L;
    }
  }
}
#pragma GCC pop_options
"""

_BINARY = {"OP_ADD": "iv_add", "OP_SUB": "iv_sub", "OP_MUL": "iv_mul", "OP_DIV": "iv_div", "OP_FMIN": "iv_fmin",
           "OP_FMAX": "iv_fmax", "OP_HYPOT": "iv_hypot", "OP_LT": "iv_lt", "OP_LE": "iv_le", "OP_EQ": "iv_eq",
           "OP_NE": "iv_ne", "OP_AND": "iv_and", "OP_OR": "iv_or", "OP_IF_ELSE_ZERO": "iv_if_else_zero"}
_UNARY = {"OP_NEG": "iv_neg", "OP_ASSIGN": "iv_assign", "OP_TWICE": "iv_twice", "OP_SQ": "iv_sq",
          "OP_SQRT": "iv_sqrt", "OP_INV": "iv_inv", "OP_FABS": "iv_fabs", "OP_SIGN": "iv_sign", "OP_NOT": "iv_not",
          "OP_SIN": "iv_sin", "OP_COS": "iv_cos", "OP_EXP": "iv_exp", "OP_LOG": "iv_log", "OP_ASIN": "iv_asin",
          "OP_ACOS": "iv_acos", "OP_ATAN": "iv_atan", "OP_TAN": "iv_tan", "OP_TANH": "iv_tanh", "OP_SINH": "iv_sinh",
          "OP_COSH": "iv_cosh", "OP_LOG1P": "iv_log1p", "OP_EXPM1": "iv_expm1", "OP_FLOOR": "iv_floor",
          "OP_CEIL": "iv_ceil", "OP_ERF": "iv_erf"}
BINARY = {getattr(ca, k): f for k, f in _BINARY.items() if hasattr(ca, k)}
UNARY = {getattr(ca, k): f for k, f in _UNARY.items() if hasattr(ca, k)}
POW = {getattr(ca, k) for k in ("OP_POW", "OP_CONSTPOW") if hasattr(ca, k)}
# the operations that say where their outcome is undecided (a jump): their functions return it
JUMPING = {getattr(ca, k) for k in ("OP_LT", "OP_LE", "OP_EQ", "OP_NE", "OP_AND", "OP_OR", "OP_IF_ELSE_ZERO",
                                    "OP_NOT", "OP_SIGN", "OP_FLOOR", "OP_CEIL", "OP_ATAN2") if hasattr(ca, k)}


def _literal(x: float) -> str:
    """An exact C literal of a double."""
    if math.isinf(x):
        return "INFINITY" if x > 0 else "(-INFINITY)"
    if math.isnan(x):
        return "NAN"
    return f"({float(x).hex()})"


def _prelude() -> str:
    half = math.pi / 2
    return _PRELUDE % {
        "block": BLOCK, "two_pi": _literal(TWO_PI), "round": _literal(ROUND), "round_lib": _literal(ROUND_LIB),
        "tiny": _literal(TINY), "pi_lo": _literal(-math.pi - 1e-15), "pi_hi": _literal(math.pi + 1e-15),
        "sin_top": _literal(half), "sin_bottom": _literal(half + math.pi),
        "cos_top": _literal(half - half), "cos_bottom": _literal((half - half) + math.pi),
        "half_pi": _literal(half), "minus_half_pi": _literal(-half), "pi": _literal(math.pi)}


def stacked_rows(program):
    """(the stacked row offset of each output, the number of stacked rows) of ``program``."""
    offsets, total = [], 0
    for m in program.shapes:
        offsets.append(total)
        total += m
    return offsets, total


def values(program):
    """The values of ``program``'s entries (its fixed, then its varying instructions): (entries,
    the number of fixed ones, per entry the values it reads and the values it writes).  Every
    value written gets a number; an if_else_zero whose branch an if_else's sum reads writes two
    (its result, and its branch kept in a slot of its own)."""
    entries = list(program.fixed) + list(program.varying)
    n_fixed = len(program.fixed)
    varying_k = {extra[1] for *_, extra in program.varying}
    # the if_else_zero instructions whose branch an if_else's sum reads (kept in slots of their own)
    selected = {k for op, i, out, ins, bit, const, _ in program.varying
                if op == ca.OP_ADD and const is not None and all(c in varying_k for c in const) for k in const}
    # every value written gets a number (the program's store index -> its current value)
    current, reads, writes, branch, count = {}, [], [], {}, 0
    for j, (op, i, out, ins, bit, const, (periodic, k)) in enumerate(entries):
        r = [current[x] for x in ins] if op not in (ca.OP_INPUT, ca.OP_CONST) else []
        if op == ca.OP_ADD and j >= n_fixed and const is not None and all(c in varying_k for c in const):
            r += [branch[const[0]], branch[const[1]]]
        w = []
        if op != ca.OP_OUTPUT:
            w, count = [count], count + 1
            current[out] = w[0]
            if j >= n_fixed and op == ca.OP_IF_ELSE_ZERO and k in selected:
                w, count = [w[0], count], count + 1
                branch[k] = w[1]
        reads.append(r)
        writes.append(w)
    return entries, n_fixed, reads, writes


def dependencies(program):
    """Per varying entry of ``program``: the varying entries whose values it reads, and the
    parameters it depends on (a bit mask, bit k: parameter k), directly or through what it
    reads; and the varying entries that are an if_else (which read the branches their two
    if_else_zero keep)."""
    entries, n_fixed, reads, writes = values(program)
    producer, params = {}, []
    for j, (op, i, *_) in enumerate(entries):
        mask = (1 << int(i[1])) if op == ca.OP_INPUT and i[0] == 1 else 0
        for v in reads[j]:
            mask |= params[producer[v]]
        params.append(mask)
        for v in writes[j]:
            producer[v] = j
    read = [sorted({producer[v] - n_fixed for v in reads[j] if producer[v] >= n_fixed})
            for j in range(n_fixed, len(entries))]
    selects = [j - n_fixed for j in range(n_fixed, len(entries)) if len(reads[j]) == 4]
    return read, params[n_fixed:], selects


def c_source(program, name: str):
    """(C source, stacked row offset of each output, number of stacked rows) of ``program`` (an
    IntervalProgram) as the function ``name`` described in the module's docstring."""
    offsets, total = stacked_rows(program)
    entries, n_fixed, reads, writes = values(program)
    # C slots by a linear scan over the values' lives, a result never in an operand's slot
    last = {}
    for j, r in enumerate(reads):
        for v in r:
            last[v] = j
    slot_of, free, n_slots = {}, [], 0
    for j in range(len(entries)):
        for v in writes[j]:
            if free:
                slot_of[v] = free.pop()
            else:
                slot_of[v], n_slots = n_slots, n_slots + 1
        for v in set(reads[j]) | set(writes[j]):
            if last.get(v, j) == j:   # its last use (or never read)
                free.append(slot_of[v])
    body, live = [], set()   # values whose jump flag is live (they depend on a varying jump)
    for j, (op, i, out, ins, bit, const, (periodic, k)) in enumerate(entries):
        varying = j >= n_fixed
        guard = f"if(need[{j - n_fixed}])" if varying else ""
        xs = [slot_of[v] for v in reads[j]]
        if op == ca.OP_OUTPUT:
            row = offsets[i[0]] + program.rows[i[0]][i[1]]
            line = f"OUT({row}, {xs[0]});" + (f" OUTJ({row}, {xs[0]});" if reads[j][0] in live else "")
            body.append(guard + "{" + line + "}")
            continue
        o = slot_of[writes[j][0]]
        flags = [slot_of[v] for v in reads[j][:2] if v in live] if varying else []
        jump = varying and bit is not None
        operands = "".join(f"A({x})," for x in xs[:2])
        args = operands + f"A({o})"
        if op == ca.OP_INPUT:
            code = f"IN_S({o});" if i[0] == 0 else f"IN_P({o}, {i[1]});"
        elif op == ca.OP_CONST:
            code = f"CONST({o}, {_literal(const)});"
        elif len(xs) == 4:   # an if_else: its two if_else_zero's sum and their branches
            code = f"b_select(nb,{operands}A({xs[2]}),A({xs[3]}),J[{xs[2]}],A({o}));"
        else:
            f = _function(program, op, ins, periodic)
            code = f"b_{f}(nb,{args}{f',J[{o}]' if op in JUMPING else ''});"
            if len(writes[j]) == 2:   # an if_else_zero an if_else reads: its branch and flag kept
                bx = slot_of[writes[j][1]]
                code += f"COPY({bx},{xs[1]});COPYJ({bx},{o});"
        if flags:
            code += "".join(f"b_jor(nb,J[{o}],J[{x}]);" for x in flags) if jump else \
                f"COPYJ({o},{flags[0]});" + "".join(f"b_jor(nb,J[{o}],J[{x}]);" for x in flags[1:])
        if jump or flags:
            live.add(writes[j][0])
        if varying:   # (the two phases: exported with need 2, imported with need 3)
            x, carry = j - n_fixed, writes[j][0] in live
            code = (f"if(need[{x}]==3){{IMPORT({o},col[{x}]);" + (f"IMPORTJ({o},col[{x}]);" if carry else "")
                    + f"}}else{{{code}if(need[{x}]==2){{EXPORT({o},col[{x}]);"
                    + (f"EXPORTJ({o},col[{x}]);" if carry else "") + "}}")
        body.append(guard + "{" + code + "}")
    n_slots = max(n_slots, 1)
    source = [_prelude(), _FORMS % {"name": name},
              "#pragma GCC optimize (\"O0\")   /* a list of calls: compiled in seconds, runs as fast */",
              f"int {name}(long n, const double *lo, const double *hi, const double *p, long p_stride,",
              "    const unsigned char *need, double *out_lo, double *out_hi, unsigned char *out_jump,",
              "    const long *col, double *sh_lo, double *sh_hi, unsigned char *sh_jump, const long *src, long n_sh) {",
              f"  slot *w = malloc(sizeof(slot) * {n_slots});",
              f"  unsigned char (*J)[B] = calloc({n_slots}, B);",
              "  if (!w || !J) { free(w); free(J); return 1; }",
              "  for (long i0 = 0; i0 < n; i0 += B) {",
              "    long m = n - i0 < B ? n - i0 : B;",
              "    int nb = (int)((m + 7) & ~7L);   /* the operations' loops: the block's intervals, to a multiple of 8 */",
              *("    " + line for line in body),
              "  }",
              "  free(w); free(J);",
              "  return 0;",
              "}", ""]
    return "\n".join(source), offsets, total


def _function(program, op, ins, periodic):
    """The block function (``b_NAME``) of one arithmetic instruction."""
    if op in POW:   # a varying exponent is never an integer point (numpy: exp(y log x) for it)
        return "powr" if ins[1] < program.n_work else "pow"
    if op == ca.OP_ATAN2:
        return "atan2_periodic" if periodic else "atan2_all"
    f = BINARY.get(op) or UNARY.get(op)
    if f is None:
        raise NotImplementedError(f"operation {op} has no C interval enclosure")
    return f[3:]
