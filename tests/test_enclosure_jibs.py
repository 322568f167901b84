"""A generated family of luffing jibs on a cylinder with a torque bump narrower than the sample
spacing (issue 27): analyse's certified peak cylinder force against an independent model
written here.

Each jib (Sobol points over the cylinder's base B, its pin A's place on the jib, the bump's
place between two samples, its width and height) turns about O through theta = 0 .. 60 deg on 31
samples (2 deg apart), its cylinder B-A extending at a constant 0.05 m/s; the jib (3 m, 400 kg,
a uniform bar) has gravity and a torque -T0 exp(-((theta - theta_c)/w)^2) on it, w 0.05 .. 0.3
deg.  The reference: the cylinder's length x(theta) = |A - B| in numpy, x' by a complex step and
x'' by 4th-order central differences of it, and virtual work at the constant extension rate v,

    F x' = I_O theta'' + m g (L/2) cos(theta) - tau,  theta' = v / x',  theta'' = -x'' theta'^2 / x',

on 20,001 samples with the largest |F| refined by scipy's bounded minimiser.  The certified
peak may not be below the reference, nor above it by more than the certificate's tolerance.
Run once (35 jibs: the fast 3 and the slow 32): every certified peak within 6e-13 of the
reference, the samples' own 6 % to 22 % of it.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import minimize_scalar
from scipy.stats import qmc

import optdesign

DEG = math.pi / 180
L, M, G, V = 3.0, 400.0, 9.81, 0.05

SCENE = """
title = "luffing jib on a cylinder with a narrow torque bump"
[parameters]
L = {L!r}
m = {m!r}
la = {la!r}
xB = {xB!r}
yB = {yB!r}
T0 = {T0!r}
tc = {tc!r}
w = {w!r}
[sweep]
name = "theta"
from = "0 deg"
to = "60 deg"
samples = 31
[points]
O = {{ fixed = [0, 0] }}
B = {{ fixed = ["xB", "yB"] }}
A = {{ polar = ["O", "la", "theta"] }}
T = {{ polar = ["O", "L", "theta"] }}
[[bodies]]
name = "jib"
frame = ["O", "T"]
mass = "m"
com = ["L/2", 0]
inertia = "m*L^2/12"
torque = "-T0*exp(-((theta - tc)/w)^2)"
[gravity]
g = {g!r}
[drive]
type = "linear"
between = ["B", "A"]
speed = {v!r}
acceleration = 0.0
"""


def force(theta, la, xB, yB, T0, tc, w):
    """The cylinder's force at the jib angles ``theta`` (numpy), by virtual work."""
    def length(t):
        return np.sqrt((la * np.cos(t) - xB) ** 2 + (la * np.sin(t) - yB) ** 2)

    def rate(t):
        h = 1e-30
        return np.imag(length(t + 1j * h)) / h

    theta = np.asarray(theta, float)
    x1 = rate(theta)
    k = 1e-4
    x2 = (-rate(theta + 2 * k) + 8 * rate(theta + k) - 8 * rate(theta - k) + rate(theta - 2 * k)) / (12 * k)
    td = V / x1
    tdd = -x2 * td**2 / x1
    tau = -T0 * np.exp(-((theta - tc) / w) ** 2)
    return (M * L**2 / 3 * tdd + M * G * L / 2 * np.cos(theta) - tau) / x1


def reference_peak(params):
    t = np.linspace(0.0, 60 * DEG, 20001)
    f = np.abs(force(t, **params))
    i = int(np.argmax(f))
    step = t[1] - t[0]
    res = minimize_scalar(lambda s: -abs(float(force(np.array([s]), **params)[0])),
                          bounds=(max(t[0], t[i] - step), min(t[-1], t[i] + step)), method="bounded",
                          options={"xatol": 1e-13})
    return max(-res.fun, f[i])


def designs(n, seed):
    out = []
    for u in qmc.Sobol(6, seed=seed).random(n):
        k = 3 + int(u[3] * 24)                       # between samples k and k + 1 (2 deg apart)
        out.append({"la": 0.8 + 0.6 * u[0], "xB": 0.2 + 0.6 * u[1], "yB": -0.7 + 0.4 * u[2],
                    "tc": (2 * k + 2 * (0.2 + 0.6 * u[4])) * DEG, "w": (0.05 + 0.25 * u[5]) * DEG,
                    "T0": 2e4 + 6e4 * ((u[0] * 5.7) % 1.0)})
    return out


def check(params):
    text = SCENE.format(L=L, m=M, g=G, v=V, **{k: float(v) for k, v in params.items()})
    result = optdesign.analyse(optdesign.loads(text, "jib " + " ".join(f"{k}={v:.4g}" for k, v in params.items())))
    return result.peaks["drive"], reference_peak(params), result.certificates["peak |drive|"], result.peaks_sampled["drive"]


def check_family(points):
    wrong, missed = [], 0
    for params in points:
        peak, ref, cert, sampled = check(params)
        missed += sampled < 0.9 * ref
        if not (ref * (1 - 1e-9) <= peak <= ref * (1 + 2e-9) and cert["note"] == "" and peak <= cert["bound"]):
            wrong.append(f"{params}: certified {peak:.10g} (bound {cert['bound']}, {cert['note']!r}) against "
                         f"{ref:.10g}, sampled {sampled:.10g}")
    assert not wrong, f"{len(wrong)} of {len(points)} jibs wrong:\n" + "\n".join(wrong)
    assert missed >= len(points) // 2   # the family exercises the certificate


def test_a_few_jibs_with_a_narrow_torque_bump():
    """The fast sibling: 3 generated jibs."""
    check_family(designs(4, seed=5)[:3])


@pytest.mark.slow
def test_a_family_of_jibs_with_a_narrow_torque_bump():
    check_family(designs(32, seed=55))
