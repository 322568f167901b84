"""[quantities] in a scene with [[cases]] (issue 28): a case's columns, their RMS over the duty
cycle's time, a profile law's speed, and the cases objective (peak(NAME), rms_time(NAME)).
The ventilator (problems/ventilator_squeeze.toml) against closed forms and the numpy model of
test_motion_output: its quantity squeeze = psi - psi0 over the breath is L f(t) on the cycloidal
squeeze, L (1 - g(t/0.8)) on the modified-sine return and 0 on the rest (quad in time); a law
speed V = 0.2 + squeeze takes ln((0.2 + L)/0.2) s over the stroke."""
import math
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import quad

import optdesign
from optdesign.design.cases import parse_objective
from optdesign.errors import SceneError
from test_motion_output import BOX, PSI_HI, PSI_LO, angles, cycloidal, modified_sine, slack

SCENE = Path(__file__).parents[1] / "problems" / "ventilator_squeeze.toml"
L = PSI_HI - PSI_LO


def test_quantities_are_case_columns_with_their_rms_over_the_cycle():
    result = optdesign.analyse(optdesign.load(SCENE))
    squeeze = result.cases.cases["squeeze"].columns
    assert np.max(np.abs(squeeze["squeeze"] - (squeeze["s"] - PSI_LO))) < 1e-15
    mu = result.cases.cases["return"].columns["mu"]
    assert np.max(np.abs(mu - angles(result.cases.cases["return"].columns["s"], 0.025, 0.10, 0.08)[0])) < 1e-12
    on_squeeze = quad(lambda t: (L * cycloidal(t)[0]) ** 2, 0, 1, epsabs=0, epsrel=1e-13)[0]
    on_return = sum(quad(lambda t: (L * (1 - modified_sine(t / 0.8)[0])) ** 2, a, b, epsabs=0, epsrel=1e-13)[0]
                    for a, b in ((0, 0.1), (0.1, 0.7), (0.7, 0.8)))
    want = math.sqrt((on_squeeze + on_return + 0.0 * 1.2) / 3.0)
    assert result.cases.duty["rms_time"]["squeeze"] == pytest.approx(want, rel=1e-9)
    # the hold at 100 deg counts mu there for its 1.2 s
    mu_rest = angles(np.array([PSI_LO]), 0.025, 0.10, 0.08)[0][0]
    mu_sq = result.cases.duty["rms_time"]["mu"] ** 2 * 3.0
    moving = sum(result.cases.cases[c].integrals["squared:mu"] for c in ("squeeze", "return"))
    assert mu_sq == pytest.approx(moving + mu_rest**2 * 1.2, rel=1e-12)


def law_text(speed):
    return SCENE.read_text().replace('[profiles.return]\nkind = "modified-sine"\ntime = 0.8',
                                     f'[profiles.return]\nkind = "law"\nspeed = "{speed}"')


def test_a_law_speed_may_use_a_quantity_of_the_sweep():
    result = optdesign.analyse(optdesign.loads(law_text("0.2 + squeeze"), "law.toml"))
    assert result.cases.cases["return"].duration == pytest.approx(math.log((0.2 + L) / 0.2), rel=1e-9)
    with pytest.raises(SceneError) as info:
        optdesign.loads(law_text("0.2+mu"), "law.toml")
    assert ("[profiles] return, speed: '0.2+mu' uses the mechanism's points (through [quantities] mu): a law's "
            "speed is an expression of the sweep and the parameters") in str(info.value)


def test_the_cases_objective_takes_quantities():
    terms = parse_objective("peak(toggle) + 2*rms_time(mu)", ["squeeze", "return"], "x.toml", ["mu", "toggle"])
    assert terms == [(1.0, "peak", "toggle", None), (2.0, "rms_time", "mu", None)]
    with pytest.raises(SceneError) as info:
        parse_objective("rms_time(nu)", ["squeeze"], "x.toml", ["mu"])
    assert "'nu' is not a column of a load case; expected one of drive, power" in str(info.value)
    assert "rod_buckling, mu" in str(info.value)


def rms_mu(x):
    """The RMS over the breath of the transmission angle of the numpy four-bar at design x."""
    def sq(psi):
        return angles(np.atleast_1d(psi), *x)[0][0] ** 2
    on_squeeze = quad(lambda t: sq(PSI_LO + L * cycloidal(t)[0]), 0, 1, epsabs=0, epsrel=1e-12)[0]
    on_return = sum(quad(lambda t: sq(PSI_HI - L * modified_sine(t / 0.8)[0]), a, b, epsabs=0, epsrel=1e-12)[0]
                    for a, b in ((0, 0.1), (0.1, 0.7), (0.7, 0.8)))
    return math.sqrt((on_squeeze + on_return + sq(PSI_LO) * 1.2) / 3.0)


@pytest.mark.slow
def test_optimise_rms_time_of_a_quantity_against_the_numpy_optimum():
    """minimise rms_time(mu) (the transmission angle's RMS over the breath: a motion in time that
    is the same for every design) from one start; the reference: a 7^3 grid of the numpy model,
    then SLSQP from its best feasible points (the constraints at 601 rocker angles, ends included)."""
    from scipy.optimize import minimize

    scene = optdesign.loads(SCENE.read_text().replace('minimise = "rms_time(motor_torque)"',
                                                      'minimise = "rms_time(mu)"'), "mu.toml")
    result = optdesign.optimise(scene, starts=1)
    assert result.success
    x = np.array([result.design[k] for k in "abc"])
    assert result.objective == pytest.approx(rms_mu(x), rel=1e-9)
    scale = BOX[:, 1] - BOX[:, 0]
    grid = [np.array(p) for p in np.stack(np.meshgrid(*[np.linspace(lo, hi, 7) for lo, hi in BOX]), -1).reshape(-1, 3)]
    feasible = sorted((rms_mu(p), tuple(p)) for p in grid if np.min(slack(p)) >= 0)
    best = math.inf
    for _, p0 in feasible[:3]:
        res = minimize(lambda z: rms_mu(BOX[:, 0] + z * scale), (np.array(p0) - BOX[:, 0]) / scale, method="SLSQP",
                       bounds=[(0, 1)] * 3, constraints=[{"type": "ineq", "fun": lambda z: slack(BOX[:, 0] + z * scale)}],
                       options={"ftol": 1e-14, "maxiter": 300})
        z = BOX[:, 0] + res.x * scale
        if np.min(slack(z)) >= -1e-10:
            best = min(best, rms_mu(z))
    assert result.objective <= best * (1 + 1e-7)
