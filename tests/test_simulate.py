"""`optdesign simulate`: motion in time under a drive law, against closed forms and an
independent stiff reference (scipy Radau on a slider-crank equation of motion written here)."""
import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

import optdesign
from optdesign.errors import SolverError
from optdesign.dynamics.simulator import simulate

PROBLEMS = Path(__file__).resolve().parent.parent / "problems"


def bar(law=None, **params):
    """problems/sim_bar.toml: a uniform bar turning about its end, I = m L^2/3 + J_rotor."""
    scene = optdesign.load(PROBLEMS / "sim_bar.toml", params)
    if law is not None:
        scene = dataclasses.replace(scene, drive=dataclasses.replace(scene.drive, law=law))
    return scene


def bar_inertia(m=3.0, L=1.2, J=0.05):
    return m * L**2 / 3 + J


@pytest.mark.parametrize("integrator", ["bdf", "adams", "rk4"])
def test_constant_torque_closed_form(integrator):
    """q(t) = q0 + w0 t + T t^2 / (2 I), qd(t) = w0 + T t / I (I constant: the bar)."""
    res = simulate(bar(), integrator=integrator, tolerance=1e-10)
    I, T, q0, w0 = bar_inertia(), 2.0, 0.3, 2.0
    t = res.t
    assert res.stop == "t_end" and t[-1] == pytest.approx(5.0, abs=1e-15)
    # bdf/adams: local error control at 1e-10 of the stroke (125.7 rad) and the reference rate
    # (bdf measured 2.0e-7: 2.6e-9 of the angle turned, 9 integrator calls each starting at first
    # order); rk4 integrates this quadratic motion exactly (to round-off)
    assert np.max(np.abs(res.q - (q0 + w0 * t + T * t**2 / (2 * I)))) < 3e-7
    assert np.max(np.abs(res.qd - (w0 + T * t / I))) < 2e-8
    assert np.max(np.abs(res.qdd - T / I)) < 1e-9
    assert np.max(np.abs(res.drive - T)) == 0.0
    assert np.max(np.abs(res.transmitted - (T - 0.05 * T / I))) < 1e-9   # T - J_rotor qdd


def test_stroke_end_time_is_located_not_rounded_to_the_grid():
    """Running out of the stroke (phi = 40 pi): the stop time solves q0 + w0 t + T t^2/(2 I) = 40 pi."""
    res = simulate(bar(), t_end=30.0, samples=31, tolerance=1e-11)  # grid step 1 s
    I, T, q0, w0 = bar_inertia(), 2.0, 0.3, 2.0
    a = T / (2 * I)
    t_ref = (-w0 + math.sqrt(w0**2 + 4 * a * (40 * math.pi - q0))) / (2 * a)
    assert res.stop == "stroke end" and res.stop_end == "to"
    assert res.t_stop == pytest.approx(t_ref, rel=1e-9)
    assert res.s[-1] == pytest.approx(40 * math.pi, rel=1e-14)
    assert res.qd[-1] == pytest.approx(w0 + T * t_ref / I, rel=1e-8)
    assert np.all(np.diff(res.t) > 0) and len(res.t) < 31


def test_backwards_to_the_from_end():
    """A negative torque turns the bar back to phi = 0: q0 + w0 t - T t^2/(2 I) = 0, the time to
    3e-9 at tolerance 1e-11 (measured 2.1e-9: the run is three integrator calls, each starting
    again at first order, and the tolerance is relative to the stroke, 40 pi)."""
    res = simulate(bar(T=-2.0), t_end=30.0, tolerance=1e-11)
    I, T, q0, w0 = bar_inertia(), 2.0, 0.3, 2.0
    a = T / (2 * I)  # q0 + w0 t - a t^2 = 0
    t_ref = (w0 + math.sqrt(w0**2 + 4 * a * q0)) / (2 * a)
    assert res.stop_end == "from" and res.t_stop == pytest.approx(t_ref, rel=3e-9)


@pytest.mark.parametrize("integrator", ["bdf", "adams", "rk4"])
def test_motor_curve_closed_form(integrator):
    """T = T (1 - qd/omega0) on the constant inertia I: qd = omega0 + (w0 - omega0) exp(-t/tau),
    tau = I omega0 / T, and q = q0 + omega0 t + (w0 - omega0) tau (1 - exp(-t/tau))."""
    omega0 = 10.0
    res = simulate(bar(law=f"T*(1 - qd/{omega0})"), integrator=integrator, tolerance=1e-10,
                   steps=40 if integrator == "rk4" else None)
    I, T, q0, w0 = bar_inertia(), 2.0, 0.3, 2.0
    tau = I * omega0 / T
    t = res.t
    qd_ref = omega0 + (w0 - omega0) * np.exp(-t / tau)
    q_ref = q0 + omega0 * t + (w0 - omega0) * tau * (1 - np.exp(-t / tau))
    assert np.max(np.abs(res.qd - qd_ref)) < 1e-7          # rad/s, at speeds 2 .. 5.4
    assert np.max(np.abs(res.q - q_ref)) < 1e-6            # rad, over 19 rad
    assert np.max(np.abs(res.drive - T * (1 - qd_ref / omega0))) < 1e-7


def test_rk4_with_too_few_steps_fails_with_its_error_estimate():
    with pytest.raises(SolverError, match=r"rk4 integrator with 2 steps per output sample is not accurate enough.*steps per sample"):
        simulate(bar(law="T*(1 - qd/0.5)"), integrator="rk4", steps=2, tolerance=1e-10)


# --- the stiff slider-crank: motor curve, rotor 1e-6 of the piston's peak reduced inertia ---
R, L, M_C, T0, OMEGA0 = 0.1, 0.35, 12.0, 2000.0, 105.0


def piston_ratio(a):
    """y_C(alpha) = -r cos a + sqrt(l^2 - r^2 sin^2 a) (crank pin straight down at a = 0):
    dy/da and d2y/da2 by hand."""
    sa, ca = np.sin(a), np.cos(a)
    w = np.sqrt(L**2 - R**2 * sa**2)
    dy = R * sa - R**2 * sa * ca / w
    d2y = R * ca - R**2 * (np.cos(2 * a) / w + R**2 * sa**2 * ca**2 / w**3)
    return dy, d2y


def peak_reduced_inertia():
    a = np.linspace(0, math.pi, 200001)
    return float(np.max(M_C * piston_ratio(a)[0] ** 2))


def radau_reference(J, t_eval):
    """(M(a) + J) a'' = T0 (1 - a'/omega0) - 1/2 M'(a) a'^2, M = m_C (dy/da)^2, by scipy's Radau
    with its own Jacobian, stopped at the stroke end a = 9 pi/2; tolerances 1e-10 (1e-12 moved
    the result by < 3e-9 rad/s)."""
    from scipy.integrate import solve_ivp

    def f(t, x):
        a, om = x
        dy, d2y = piston_ratio(a)
        return [om, (T0 * (1 - om / OMEGA0) - M_C * dy * d2y * om**2) / (M_C * dy**2 + J)]

    def jac(t, x):
        e = 1e-7
        a, om = x
        da = (np.array(f(t, [a + e, om])) - np.array(f(t, [a - e, om]))) / (2 * e)
        dw = (np.array(f(t, [a, om + e * om])) - np.array(f(t, [a, om - e * om]))) / (2 * e * om)
        return np.column_stack([da, dw])

    end = lambda t, x: x[0] - 4.5 * math.pi
    end.terminal = True
    sol = solve_ivp(f, (0, 0.15), [0.5, 100.0], method="Radau", rtol=1e-10, atol=1e-10, jac=jac,
                    events=end, t_eval=t_eval)
    assert sol.status == 1
    return sol.t_events[0][0], sol.y


@pytest.fixture(scope="module")
def stiff_scene():
    scene = optdesign.load(PROBLEMS / "sim_slider_crank.toml")
    J = scene.parameter_values()["J_rotor"]
    assert J == pytest.approx(1e-6 * peak_reduced_inertia(), rel=1e-9)
    return scene


def test_stiff_slider_crank_implicit_meets_stated_accuracy(stiff_scene):
    """Stated accuracy: bdf at tolerance 1e-9 gives the stop time (alpha = 9 pi/2, after four
    dead centres) to 2e-9 s, the crank angle to 1e-6 rad and the crank speed to
    5e-4 rad/s (speeds 80 .. 156 rad/s) at every output sample."""
    res = simulate(stiff_scene, integrator="bdf", tolerance=1e-9)
    assert res.stop == "stroke end" and res.stop_end == "to"
    t_ref, (a_ref, w_ref) = radau_reference(stiff_scene.parameter_values()["J_rotor"], res.t[:-1])
    assert abs(res.t_stop - t_ref) < 2e-9
    assert np.max(np.abs(res.s[:-1] - a_ref)) < 1e-6
    assert np.max(np.abs(res.qd[:-1] - w_ref)) < 5e-4
    assert res.stats["steps"] < 5000


def test_stiff_slider_crank_explicit_fails_clearly(stiff_scene):
    """RK4 at 200 steps per output sample (40,000 steps, 20x the implicit one's ~2,000) is beyond
    its stability limit at the first dead centre (h = 3.8e-6 s > 2.8 J/(T0/omega0) = 1.9e-8 s):
    a clear error, not a table of NaN."""
    with pytest.raises(SolverError, match=r"rk4 integrator failed between t = 0.02\d* s.*alpha = 3\.\d+.*implicit"):
        simulate(stiff_scene, integrator="rk4", steps=200)


def test_stiff_slider_crank_adams_costs_many_more_steps(stiff_scene):
    """CVODES Adams with functional iteration (no Jacobian, explicit-like stability) gets through
    the dead centres only by cutting its step: measured 19x the BDF's steps at 1e-8.  Both stop
    times within 3e-8 s of each other (against Radau at 1e-12: bdf 1.9e-8 s early, adams 1e-10;
    which of 1e-8 .. 2e-8 bdf lands on depends on where CasADi stops CVODES for output)."""
    bdf = simulate(stiff_scene, integrator="bdf", tolerance=1e-8)
    adams = simulate(stiff_scene, integrator="adams", tolerance=1e-8)
    assert adams.stats["steps"] > 10 * bdf.stats["steps"]
    assert adams.t_stop == pytest.approx(bdf.t_stop, abs=3e-8)
