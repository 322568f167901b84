"""Extreme case: a crank-driven four-bar close to lock-up (issue 5, part 3).

Ground A-D (d = 2 m), crank A-B (a = 1 m, the drive and the sweep alpha), coupler B-C (c = 1.5 m),
rocker D-C (r = 1.2 m), C built as a dyad (left of B -> D).  Not a Grashof linkage: the crank
cannot turn fully.  At alpha* = acos((a^2 + d^2 - (c + r)^2) / (2 a d)) = 124.92 deg the coupler and
the rocker lie in line (|BD| = c + r): the linkage locks, the rocker's angular velocity per unit
crank rate grows like 1/sqrt(alpha* - alpha) and the reduced inertia I_zS like 1/(alpha* - alpha).

Reference (independent of optdesign): the same linkage by the law of cosines, the angle at D in
triangle B-C-D: C = D + r (cos(phi_DB - delta), sin(phi_DB - delta)), cos delta =
(r^2 + rho^2 - c^2)/(2 r rho), rho = |BD|; bodies (coupler: 3 kg at mid-length, I = m c^2/12;
rocker: 2 kg at mid-length, I = m r^2/12; gravity), differentiated by mpmath.diff in 40-digit
arithmetic:  I_zS = sum m |r'|^2 + I phi'^2 (the crank angle is the sweep, k = 1),
dI_zS/dalpha, T_Su = dV/dalpha and T_S = T_Su + I_zS eps_S + 1/2 omega_S^2 dI_zS/dalpha.

Tolerance from the conditioning: optdesign builds C from the dyad's margin
m = 4 rho^2 c^2 - (rho^2 + c^2 - r^2)^2 (its height is sqrt(m)); in float64 m carries an absolute
round-off of a few eps times its terms (4 rho^2 c^2 ~ 65 m^4), so sqrt(m) and everything
downstream carries a relative error ~ eps 4 rho^2 c^2 / m = eps / kappa, kappa = m / (4 rho^2 c^2)
(the squared sine of the angle at B).  I_zS ~ 1/m and dI_zS/dalpha ~ 1/m^2 amplify it; measured: at most 4 eps / kappa.  We allow
20 eps / kappa per sample (at least 1e-12).  At alpha* - 1e-6 rad kappa is 3.6e-7: 1.2e-8.

The errors: sweeping past the lock-up is an AssemblyError naming the dyad, the located lock-up
(to 1e-8 against alpha*) and a fix.  A stroke ending exactly at the lock-up (the margin rounds to exactly 0.0 at the last
sample) is an AssemblyError too, saying that the dyad is at its lock-up position (optdesign
refuses relative margins below 1e-10, where eps/kappa would exceed 1e-6).
"""
from __future__ import annotations

import math
import re

import mpmath
import numpy as np
import pytest

from optdesign import AssemblyError, OptdesignError
from optdesign.model.analysis import analyse
from optdesign.scene.file import loads

a, d, c, r = 1.0, 2.0, 1.5, 1.2
m_c, m_r, G, OMEGA, EPS_S = 3.0, 2.0, 9.81, 2.0, 1.0
ALPHA_LOCK = math.acos((a * a + d * d - (c + r) ** 2) / (2 * a * d))
EPS = np.finfo(float).eps

SCENE = """
title = "Four-bar near lock-up"
[parameters]
a = {a!r}
d = {d!r}
c = {c!r}
r = {r!r}
[sweep]
name = "alpha"
from = 0.3
to = {stop!r}
samples = {samples}
[points]
A = {{ fixed = [0, 0] }}
D = {{ fixed = ["d", 0] }}
B = {{ polar = ["A", "a", "alpha"] }}
C = {{ dyad = ["B", "c", "D", "r"], side = "left" }}
[[bodies]]
name = "coupler"
frame = ["B", "C"]
mass = {mc!r}
com = ["c/2", 0]
inertia = "{mc!r}*c^2/12"
[[bodies]]
name = "rocker"
frame = ["D", "C"]
mass = {mr!r}
com = ["r/2", 0]
inertia = "{mr!r}*r^2/12"
[gravity]
g = {g!r}
[drive]
type = "rotary"
crank = ["A", "B"]
speed = {w!r}
acceleration = {e!r}
"""


def scene(stop, samples=121):
    return loads(SCENE.format(a=a, d=d, c=c, r=r, stop=stop, samples=samples, mc=m_c, mr=m_r, g=G, w=OMEGA,
                              e=EPS_S), "<four-bar>")


# --- the independent linkage (mpmath) ---------------------------------------------------------------
def linkage(alpha):
    """Centres of mass and angles of coupler and rocker at crank angle alpha (mpmath numbers)."""
    B = (a * mpmath.cos(alpha), a * mpmath.sin(alpha))
    rho = mpmath.sqrt((B[0] - d) ** 2 + B[1] ** 2)
    phi_DB = mpmath.atan2(B[1], B[0] - d)
    delta = mpmath.acos((r**2 + rho**2 - c**2) / (2 * r * rho))
    C = (d + r * mpmath.cos(phi_DB - delta), r * mpmath.sin(phi_DB - delta))
    coupler = ((B[0] + C[0]) / 2, (B[1] + C[1]) / 2, mpmath.atan2(C[1] - B[1], C[0] - B[0]))
    rocker = ((d + C[0]) / 2, C[1] / 2, mpmath.atan2(C[1], C[0] - d))
    return B, C, coupler, rocker


def reference(alphas):
    """I_zS, dI_zS/dalpha, T_Su, T_S and kappa at the given crank angles (40 digits)."""
    out = {k: [] for k in ("reduced_inertia", "reduced_inertia_dq", "static_load", "drive", "kappa")}
    bodies = ((2, m_c, m_c * c**2 / 12), (3, m_r, m_r * r**2 / 12))
    with mpmath.workdps(40):
        for alpha in alphas:
            al = mpmath.mpf(float(alpha))
            I, dI, dV = 0, 0, 0
            for idx, m, J in bodies:
                d1 = [mpmath.diff(lambda t, j=j: linkage(t)[idx][j], al, 1) for j in range(3)]
                d2 = [mpmath.diff(lambda t, j=j: linkage(t)[idx][j], al, 2) for j in range(3)]
                I += m * (d1[0] ** 2 + d1[1] ** 2) + J * d1[2] ** 2
                dI += 2 * m * (d1[0] * d2[0] + d1[1] * d2[1]) + 2 * J * d1[2] * d2[2]
                dV += m * G * d1[1]
            B, C, _, _ = linkage(al)
            rho2 = (B[0] - d) ** 2 + B[1] ** 2
            margin = 4 * rho2 * c**2 - (rho2 + c**2 - r**2) ** 2
            out["reduced_inertia"].append(float(I))
            out["reduced_inertia_dq"].append(float(dI))
            out["static_load"].append(float(dV))
            out["drive"].append(float(dV + I * EPS_S + dI * OMEGA**2 / 2))
            out["kappa"].append(float(margin / (4 * rho2 * c**2)))
    return {k: np.array(v) for k, v in out.items()}


def test_the_reference_is_the_scenes_linkage():
    """Cross-check of the two constructions at a healthy angle: same point C, left of B -> D."""
    res = analyse(scene(1.5, samples=3))
    with mpmath.workdps(40):
        B, C, _, _ = linkage(mpmath.mpf(1.5))
        cross = (d - B[0]) * (C[1] - B[1]) - (0 - B[1]) * (C[0] - B[0])
    assert cross > 0  # left of B -> D, as the scene's dyad side
    assert float(res.columns["reduced_inertia"][-1]) == pytest.approx(float(reference([1.5])["reduced_inertia"][0]), rel=1e-12)


@pytest.mark.parametrize("gap", [1e-2, 1e-4, 1e-6])
def test_reduced_model_close_to_lock_up_is_accurate(gap):
    res = analyse(scene(ALPHA_LOCK - gap))
    s = res.columns["s"]
    idx = np.unique(np.r_[np.arange(0, len(s), 12), len(s) - 3, len(s) - 2, len(s) - 1])  # keep mpmath quick
    ref = reference(s[idx])
    rtol = np.maximum(20 * EPS / ref["kappa"], 1e-12)
    for name in ("reduced_inertia", "reduced_inertia_dq", "static_load", "drive"):
        got, want = res.columns[name][idx], ref[name]
        # T_Su = dV/dalpha passes through zero: measured against the gravity scale sum m g |r'|
        scale = np.abs(want) if name != "static_load" else np.maximum(np.abs(want), (m_c + m_r) * G * 1e-3)
        err = np.abs(got - want) / scale
        i = int(np.argmax(err))
        assert np.all(err <= rtol), f"{name}: relative error {err[i]:.3g} > {rtol[i]:.3g} at alpha = {s[idx][i]!r}"
    # close to the lock-up the reduced inertia grows like 1/(alpha* - alpha): it is large, and finite
    assert np.all(np.isfinite(res.columns["drive"]))
    if gap <= 1e-4:
        assert res.columns["reduced_inertia"][-1] > 100 * np.median(res.columns["reduced_inertia"])


def test_sweeping_past_lock_up_is_an_assembly_error():
    with pytest.raises(AssemblyError) as info:
        analyse(scene(ALPHA_LOCK + 0.05, samples=101))
    msg = str(info.value)
    assert "[points] C (dyad) cannot assemble" in msg
    assert "Change its lengths or narrow the sweep" in msg
    alpha = float(re.search(r"alpha = (-?[0-9.eE+-]+) \(", msg).group(1))
    # the lock-up itself, located between the samples (issue 21), not the first sample past it
    assert alpha == pytest.approx(ALPHA_LOCK, abs=1e-8)
    assert info.value.construction == "C" and info.value.s == pytest.approx(ALPHA_LOCK, abs=1e-12)
    s = np.linspace(0.3, ALPHA_LOCK + 0.05, 101)
    first_bad = s[np.argmax(s > ALPHA_LOCK)]
    assert f"alpha = {first_bad:.10g}" in msg  # and the first sample that fails, beside it


def _margin_zero_angle():
    """A float crank angle next to alpha* at which the dyad's margin, computed as optdesign
    writes it, rounds to exactly 0.0 (found by stepping ulps)."""
    x = ALPHA_LOCK
    for _ in range(40):
        B = (a * math.cos(x), a * math.sin(x))
        dx, dy = d - B[0], -B[1]
        d2 = dx * dx + dy * dy
        along = d2 + c**2 - r**2
        if 4 * d2 * c**2 - along**2 == 0.0:
            return x
        x = float(np.nextafter(x, -10.0))
    pytest.fail("no float angle with a margin of exactly 0.0 near the lock-up")


def test_stroke_ending_exactly_at_lock_up_is_a_clear_error():
    alpha_end = _margin_zero_angle()
    try:
        res = analyse(scene(alpha_end, samples=41))
    except OptdesignError as exc:  # what it should do: a clear error naming the dyad
        assert isinstance(exc, AssemblyError)
        assert "[points] C" in str(exc)
        assert "lock-up" in str(exc) and "Narrow the sweep" in str(exc)
        return
    bad = [k for k, v in res.columns.items() if not np.all(np.isfinite(v))]
    assert not bad, f"columns {bad} hold NaN/inf at the lock-up, and no error was raised"
