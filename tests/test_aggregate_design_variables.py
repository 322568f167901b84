"""Issue 27: a design variable inside a per-stroke max()/min() is symbolic everywhere (the NLP,
its variable bounds, the certification and the reported value), never read at its start value.

The crank-rocker of the largest least transmission angle (tests/data/issue27/crank_rocker_mu.toml:
ground 120 mm, rocker swing 80 deg, time ratio 10/9, crank a in [0.02, 0.075]) maximises mu under
min(angle(A, B, B0) - mu) >= 0 and max(angle(A, B, B0) + mu) <= pi.  Before the fix the
aggregate's NLP variable kept the sign it had at the start design, bounded by 1e-3 of its start
value: mu* came out 3.6e-4 low from mu = 0.3, and every start failed (Infeasible_Problem_Detected)
from mu = 0.65 or 0.9, where min(angle - mu) starts below 0.

The reference is independent of optdesign and of the scene's closed-form synthesis: for each
crank a, the coupler b and rocker c are solved (scipy fsolve) from the four-bar's two extreme
positions (crank and coupler in line: |A0 B| = b -+ a) so that the rocker swings 80 deg while
the crank turns 180 deg + theta, theta = 180 deg (K - 1)/(K + 1); the transmission angle gamma
from the law of cosines over 20,001 crank angles; mu(a) = min(gamma, pi - gamma) maximised over
a by a grid and a bounded scalar search.  The published optimum (a 46.7, b 116, c 73.9 mm,
mu 37.7 deg) is checked against it."""
from __future__ import annotations

import functools
import warnings
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import fsolve, minimize_scalar

import optdesign

SCENE = Path(__file__).parent / "data" / "issue27" / "crank_rocker_mu.toml"
D, PSI, K = 0.12, np.radians(80.0), 10 / 9
THETA = np.pi * (K - 1) / (K + 1)
PHI = np.linspace(-np.pi, np.pi, 20001)


def links(a, guess=(0.116, 0.074)):
    """(b, c) of the crank-rocker with crank a: the rocker's swing PSI between the positions
    where crank and coupler are in line, the crank's angle between them pi + THETA (Newton
    from ``guess``)."""
    def equations(v):
        b, c = v
        r1, r2 = b - a, b + a                              # |A0 B| folded and extended
        beta = [np.arccos((D**2 + c**2 - r**2) / (2 * D * c)) for r in (r1, r2)]   # at B0
        alpha = [np.arccos((D**2 + r**2 - c**2) / (2 * D * r)) for r in (r1, r2)]  # at A0
        return [beta[1] - beta[0] - PSI, alpha[0] - alpha[1] - THETA]

    with warnings.catch_warnings(), np.errstate(invalid="ignore"):   # trial points beyond assembly
        warnings.simplefilter("ignore", RuntimeWarning)
        b, c = fsolve(equations, guess, xtol=1e-14)
    assert np.allclose(equations([b, c]), 0, atol=1e-12)
    return b, c


def least_margin(a, guess=(0.116, 0.074)):
    """min over the turn of min(gamma, pi - gamma), gamma the transmission angle (coupler to
    rocker) with the crank at each of 20,001 angles."""
    b, c = links(a, guess)
    diagonal2 = a**2 + D**2 - 2 * a * D * np.cos(PHI)        # |A B0|^2
    gamma = np.arccos((b**2 + c**2 - diagonal2) / (2 * b * c))
    return float(np.min(np.minimum(gamma, np.pi - gamma)))


@functools.cache
def reference():
    """(a*, mu*): a grid over a in [0.02, 0.075], then a bounded scalar search around its best."""
    grid = np.linspace(0.02, 0.075, 111)
    values, guess = {}, (0.116, 0.074)
    middle = int(np.argmin(np.abs(grid - 0.0467)))
    for order in (range(middle, 111), range(middle, -1, -1)):   # continuation from the middle
        guess = links(grid[middle])
        for i in order:
            values[i] = least_margin(grid[i], guess)
            guess = links(grid[i], guess)
    values = [values[i] for i in range(111)]
    i = int(np.argmax(values))
    best = minimize_scalar(lambda a: -least_margin(a), bounds=(grid[max(i - 1, 0)], grid[min(i + 1, 110)]),
                           method="bounded", options={"xatol": 1e-12})
    return float(best.x), -float(best.fun)


def test_reference_matches_the_published_optimum():
    a, mu = reference()
    b, c = links(a)
    assert (round(a * 1e3, 1), round(b * 1e3), round(c * 1e3, 1)) == (46.7, 116, 73.9)
    assert round(np.degrees(mu), 1) == 37.7
    assert abs(mu - 0.6585637) < 5e-8          # the value


def outer_form() -> str:
    """The same problem with mu outside the aggregates: min(angle) - mu >= 0 and max(angle) +
    mu <= pi (the old code reported this stroke constraint's value at the start mu: -0.241 from
    mu = 0.9, where analyse --design gives -2.3e-10)."""
    text = SCENE.read_text()
    for old, new in (("min(angle(A, B, B0) - mu)", "min(angle(A, B, B0)) - mu"),
                     ("max(angle(A, B, B0) + mu)", "max(angle(A, B, B0)) + mu")):
        assert old in text
        text = text.replace(old, new)
    return text


@pytest.mark.parametrize("form, mu0", [("inside", 0.3), ("inside", 0.5), ("inside", 0.65), ("inside", 0.9),
                                       ("outside", 0.9)])
def test_mu_inside_min_max_reaches_the_optimum_from_every_start_value(form, mu0):
    scene = optdesign.load(SCENE) if form == "inside" else optdesign.loads(outer_form(), path="crank_rocker_outer.toml")
    scene = scene.with_parameters(mu=mu0)
    result = optdesign.optimise(scene, starts=3, seed=0)
    a_ref, mu_ref = reference()
    assert result.success, result.message
    assert result.starts_at_best == 3, [s.status for s in result.starts]
    assert abs(result.design["mu"] - mu_ref) < 1e-7
    assert abs(-result.objective - mu_ref) < 1e-7
    assert abs(result.design["a"] - a_ref) < 1e-5
    # the reported values of the stroke constraints: those of analyse at the design reported
    analysed = optdesign.analyse(scene.with_parameters(**result.design))
    for name in ("transmission angle above mu", "transmission angle below pi - mu"):
        assert abs(result.constraints[name]["value"] - analysed.constraints[name]) < 1e-9, name
    active = result.constraints["transmission angle above mu"]
    assert active["active"] == "lower" and abs(active["value"]) < 1e-8

