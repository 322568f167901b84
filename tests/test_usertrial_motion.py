"""Round 2 of the new user's trial, motion in time and design studies (tests/data/usertrial/):
a dock leveller's deck raised by a cylinder at constant force (linear drive, efficiency 0.9,
started at rest, stops at the stroke end) and a compressor's slider-crank run up from rest by
a motor curve (rotary, ten turns).  Each motion is checked against scipy's solve_ivp on a numpy
model written here (positions in closed form, derivatives by five-point differences, the
equation of motion from Lagrange with the drive's inertia and the efficiency factor)."""
from __future__ import annotations

import dataclasses
import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import optdesign
from optdesign.dynamics.simulator import simulate

DATA = Path(__file__).parent / "data" / "usertrial"
ROOT = Path(__file__).resolve().parent.parent
G = 9.81


def d1(f, x, h=1e-5):
    return (f(x - 2 * h) - 8 * f(x - h) + 8 * f(x + h) - f(x + 2 * h)) / (12 * h)


# ------------------------------------------------------------------ dock leveller (linear)

DL = dict(L=2.5, m=900.0, b=0.8, dx=0.7, dy=-0.6, F=20000.0, m_rod=8.0, eta=0.9)


def dock_q(th):
    """Cylinder length |DB|, B = b (cos th, sin th), D = (dx, dy)."""
    return np.hypot(DL["b"] * np.cos(th) - DL["dx"], DL["b"] * np.sin(th) - DL["dy"])


def dock_rhs(t, x, c=1 / DL["eta"]):
    """(c M + J k^2) th'' = k F - J k k' th'^2 - c Q, M = m L^2/3 (a bar about its end, constant),
    Q = m g L/2 cos th; c = 1/eta while the cylinder raises the deck (power flows in), eta while
    the deck comes down against it."""
    th, w = x
    k = d1(dock_q, th)
    kp = d1(lambda s: d1(dock_q, s), th, 1e-4)
    M = DL["m"] * DL["L"] ** 2 / 3
    Q = DL["m"] * G * DL["L"] / 2 * np.cos(th)
    J = DL["m_rod"]
    return [w, (k * DL["F"] - J * k * kp * w**2 - c * Q) / (c * M + J * k**2)]


def test_dock_leveller_rises_to_the_stroke_end_as_solve_ivp():
    res = simulate(optdesign.load(DATA / "dock_leveller.toml"), tolerance=1e-10)
    th0, th1 = math.radians(-10), math.radians(12)
    end = lambda t, x: x[0] - th1
    end.terminal = True
    ref = solve_ivp(dock_rhs, (0, 5), [th0, 0.0], method="DOP853", rtol=1e-11, atol=1e-12,
                    events=end, dense_output=True)
    t_ref = ref.t_events[0][0]
    assert res.stop == "stroke end" and res.stop_end == "to"
    assert res.t_stop == pytest.approx(t_ref, rel=1e-7)
    assert np.all(res.efficiency_factor == pytest.approx(1 / 0.9, rel=1e-14))
    inside = res.t < t_ref
    th_ref, w_ref = ref.sol(res.t[inside])
    assert np.max(np.abs(res.s[inside] - th_ref)) < 1e-7
    assert np.max(np.abs(res.sd[inside] - w_ref)) < 1e-6
    # the drive coordinate is the cylinder length, its rate k * theta'
    assert np.max(np.abs(res.q - dock_q(res.s))) < 1e-12
    # energy: the work of F less the losses (1 - eta of the power in) equals KE + PE gained;
    # with c = 1/eta constant: eta * F * (q - q0) = KE + m g L/2 (sin th - sin th0)
    pe = DL["m"] * G * DL["L"] / 2 * (np.sin(res.s) - np.sin(th0))
    # what reaches the mechanism is eta * transmitted power; the rod's KE is the drive's own
    ke_rod = 0.5 * DL["m_rod"] * res.qd**2
    work_f = DL["F"] * (res.q - res.q[0])
    # J qdd is taken before the efficiency: F dq = d(KE_rod) + (1/eta) (d KE_deck + dPE)
    ke_deck = res.kinetic_energy - ke_rod
    assert np.max(np.abs(work_f - ke_rod - (ke_deck + pe) / 0.9)) < 1e-5 * work_f[-1]


def test_dock_leveller_thrown_down_against_the_cylinder_as_solve_ivp():
    """Started downwards at 0.5 m/s (the deck falls against the pushing cylinder: power flows
    back, c = eta), it reaches the lower end of the stroke before it stops."""
    scene = optdesign.load(DATA / "dock_leveller.toml")
    scene = dataclasses.replace(scene, simulation=dataclasses.replace(scene.simulation, speed=-0.5))
    res = simulate(scene, tolerance=1e-10)
    th0, lo = math.radians(-10), math.radians(-12)
    w0 = -0.5 / d1(dock_q, th0)
    end = lambda t, x: x[0] - lo
    end.terminal = True
    ref = solve_ivp(lambda t, x: dock_rhs(t, x, DL["eta"]), (0, 1), [th0, w0], method="DOP853",
                    rtol=1e-11, atol=1e-12, events=end, dense_output=True)
    assert res.stop == "stroke end" and res.stop_end == "from"
    assert res.t_stop == pytest.approx(ref.t_events[0][0], rel=1e-7)
    assert np.all(res.efficiency_factor == pytest.approx(0.9, rel=1e-14))
    inside = res.t < ref.t_events[0][0]
    assert np.max(np.abs(res.sd[inside] - ref.sol(res.t[inside])[1])) < 1e-6


def test_dock_leveller_held_by_a_weak_cylinder_stalls_at_once():
    """F between eta F_Su and F_Su / eta at the start: neither direction moves off (forwards
    the cylinder is too weak, backwards the self-locking efficiency holds the weight)."""
    th0 = math.radians(-10)
    k = d1(dock_q, th0)
    F_su = DL["m"] * G * DL["L"] / 2 * math.cos(th0) / k
    res = simulate(optdesign.load(DATA / "dock_leveller.toml", {"F": F_su}))
    assert res.stop == "stalled"
    assert res.t_stop == 0.0
    assert res.s[-1] == pytest.approx(th0, abs=1e-14)


# ------------------------------------------------------------------ compressor (rotary)

CP = dict(r=0.05, l=0.2, mp=2.5, mr=1.2, J_fly=0.15, T0=40.0, w0=157.0, J=0.01, F=300.0)


def comp_ratios(a):
    """Closed-form velocity ratios per unit crank rate: the rod angle beta (sin beta = -r sin a / l,
    C on the x axis ahead of O), the piston's dcx/da, the rod middle's velocity."""
    r, l = CP["r"], CP["l"]
    cb = np.sqrt(1 - (r * np.sin(a) / l) ** 2)
    db = -r * np.cos(a) / (l * cb)
    dcx = -r * np.sin(a) - r**2 * np.sin(a) * np.cos(a) / (l * cb)
    dmid = np.array([(-r * np.sin(a) + dcx) / 2, r * np.cos(a) / 2])
    return db, dcx, dmid


def comp_M(a):
    """M(alpha) = J_fly + m_rod |v_mid|^2 + I_rod beta'^2 + m_p cx'^2 (per unit crank rate)."""
    db, dcx, dmid = comp_ratios(a)
    return CP["J_fly"] + CP["mr"] * (dmid[0] ** 2 + dmid[1] ** 2) + CP["mr"] * CP["l"] ** 2 / 12 * db**2 + CP["mp"] * dcx**2


def comp_rhs(t, x):
    """(M + J) a'' = T0 (1 - a'/w0) - 1/2 M' a'^2 - Q, Q = F_gas dcx/da (the gas force -F_gas x)."""
    a, w = x
    Mp = d1(comp_M, a, 1e-4)
    Q = CP["F"] * comp_ratios(a)[1]
    T = CP["T0"] * (1 - w / CP["w0"])
    return [w, (T - 0.5 * Mp * w**2 - Q) / (comp_M(a) + CP["J"])]


def test_compressor_run_up_as_solve_ivp():
    res = simulate(optdesign.load(DATA / "compressor_spinup.toml"), tolerance=1e-10)
    end = lambda t, x: x[0] - 20 * math.pi
    end.terminal = True
    ref = solve_ivp(comp_rhs, (0, 1.5), [0.1, 0.0], method="DOP853", rtol=1e-11, atol=1e-11,
                    events=end, dense_output=True)
    t_ref = ref.t_events[0][0]
    assert res.stop == "stroke end" and res.stop_end == "to"
    assert res.t_stop == pytest.approx(t_ref, rel=1e-7)
    inside = res.t < t_ref
    a_ref, w_ref = ref.sol(res.t[inside])
    assert np.max(np.abs(res.s[inside] - a_ref)) < 1e-6
    assert np.max(np.abs(res.sd[inside] - w_ref)) < 1e-5
    assert np.max(np.abs(res.q - res.s)) < 1e-12   # the crank O->A is the sweep itself


# ------------------------------------------------------------------ user mistakes

def cli(*args):
    return subprocess.run([sys.executable, "-m", "optdesign.cli.main", *map(str, args)], capture_output=True,
                          text=True, cwd=ROOT, timeout=120)


def test_tolerance_above_a_tenth_is_refused_as_in_the_scene():
    """[simulation] tolerance must lie in (0, 0.1]; --tolerance 0.5 (and simulate(tolerance=0.5))
    ran a 50 %-tolerance motion without a word (stop time 0.651958 s against 0.652007 s)."""
    out = cli("simulate", DATA / "dock_leveller.toml", "--tolerance", "0.5")
    assert out.returncode == 2 and "Traceback" not in out.stderr
    assert "argument --tolerance: expected a finite number > 0 and <= 0.1, found '0.5'" in out.stderr
    with pytest.raises(optdesign.OptdesignError, match=r"tolerance: expected a finite number > 0 and <= 0.1"):
        simulate(optdesign.load(DATA / "dock_leveller.toml"), tolerance=0.5)
    assert simulate(optdesign.load(DATA / "dock_leveller.toml"), tolerance=0.1).stop == "stroke end"


def test_study_axis_over_a_design_variable_is_refused(tmp_path):
    """`study --grid b=0.6:1.0:3` with b a design variable gave three identical optima
    (11930.50 N, b = 1.2 each: the axis only moved the start) without a word."""
    out = cli("study", DATA / "dock_leveller.toml", "--grid", "b=0.6:1.0:3", "--no-figures", "--out", tmp_path / "s")
    assert out.returncode == 2 and "Traceback" not in out.stderr
    assert "'b' is a design variable" in out.stderr and "--mode analyse" in out.stderr
    assert not (tmp_path / "s" / "cases.csv").exists()


def test_pareto_study_writes_its_front_without_figures_and_the_front_holds_up(tmp_path):
    """--no-figures dropped pareto.csv (a table, not a figure).  The front's objective is checked
    against the numpy model at each optimum: peak over the stroke of (1/eta) (Q_s/k + 1/2 v^2 dm_z/dq)
    at v_S = 0.05 m/s, a = 0, by Lagrange in q with finite differences."""
    out = cli("study", DATA / "dock_leveller.toml", "--pareto", "cylinder length ratio=1.5:1.9:3",
              "--no-figures", "--workers", "1", "--out", tmp_path / "p")
    assert out.returncode == 0, out.stderr
    front = (tmp_path / "p" / "pareto.csv").read_text().splitlines()
    assert len(front) == 4
    import csv
    rows = list(csv.DictReader((tmp_path / "p" / "cases.csv").open()))
    th = np.linspace(math.radians(-12), math.radians(12), 4001)
    for row in rows:
        b, dx = float(row["design:b"]), float(row["design:dx"])
        q = lambda s: np.hypot(b * np.cos(s) - dx, b * np.sin(s) - DL["dy"])
        k = d1(q, th, 1e-6)
        mz = lambda s: DL["m"] * DL["L"] ** 2 / 3 / d1(q, s, 1e-6) ** 2   # reduced mass M_s / k^2
        # Lagrange in q at q' = v, q'' = 0: F = F_Su + 1/2 v^2 dm_z/dq; power flows in: / eta
        drive = (DL["m"] * G * DL["L"] / 2 * np.cos(th) / k + 0.5 * 0.05**2 * d1(mz, th, 1e-4) / k) / 0.9
        ratio = q(th).max() / q(th).min()
        assert ratio == pytest.approx(float(row["bound:cylinder length ratio:max"]), abs=1e-6)
        assert float(row["objective"]) == pytest.approx(np.abs(drive).max(), rel=2e-6)
    objectives = [float(r["objective"]) for r in rows]
    assert objectives[0] > objectives[1] > objectives[2]   # a looser ratio, a smaller force


def test_compressor_peak_torque_at_constant_speed_by_lagrange():
    """analyse at the [drive] speed 150 rad/s, eps = 0: T = 1/2 M'(alpha) w^2 + Q(alpha); the
    flywheel's J does not enter (an analyse-mode study over J_fly gave one peak: right)."""
    out = cli("analyse", DATA / "compressor_spinup.toml", "--json")
    assert out.returncode == 0, out.stderr
    peak = json.loads(out.stdout)["peaks"]["drive"]
    a = np.linspace(0, 2 * np.pi, 20001)
    T = 0.5 * d1(comp_M, a, 1e-4) * 150.0**2 + CP["F"] * comp_ratios(a)[1]
    assert peak == pytest.approx(np.abs(T).max(), rel=1e-7)


def test_animation_caption_shows_round_off_at_a_dead_centre_as_zero():
    """animate --frame 0.3 of the compressor printed 'drive torque -1.942e-13 N m' (a zero of the
    torque at a dead centre, against a 104.6 N m peak)."""
    from optdesign.report.animate import caption_value
    assert f"{caption_value(-1.942e-13, 104.6):.4g}" == "0"
    assert f"{caption_value(-0.01046, 104.6):.4g}" == "-0.01046"   # a small real value stays


def test_flywheel_written_with_mass_zero_says_to_leave_mass_out(tmp_path):
    """A flywheel given by its inertia about the pivot, written `mass = 0` and no com, was told
    'a body with mass needs its centre of mass' (it has none) without saying what to write."""
    text = (DATA / "compressor_spinup.toml").read_text().replace(
        'frame = ["O", "A"]\ninertia', 'frame = ["O", "A"]\nmass = 0\ninertia')
    assert "mass = 0" in text
    (tmp_path / "c.toml").write_text(text)
    out = cli("simulate", tmp_path / "c.toml")
    assert out.returncode == 2 and "Traceback" not in out.stderr and len(out.stderr.strip().splitlines()) == 1
    assert "[[bodies]] 'flywheel', com" in out.stderr and "leave out 'mass', not mass = 0" in out.stderr


@pytest.mark.parametrize("integrator", ["bdf", "adams", "rk4"])
def test_compressor_run_up_each_integrator_at_the_default_tolerance(integrator):
    """At tolerance 1e-8 (local, relative to the stroke of 62.8 rad) the global error measured
    against solve_ivp: bdf 3.0e-5 rad (t_stop -2.6e-7 s), adams 3.8e-6 rad, rk4 1.1e-9 rad;
    bounded here by 1e-6 of the stroke."""
    res = simulate(optdesign.load(DATA / "compressor_spinup.toml"), integrator=integrator, tolerance=1e-8)
    end = lambda t, x: x[0] - 20 * math.pi
    end.terminal = True
    ref = solve_ivp(comp_rhs, (0, 1.5), [0.1, 0.0], method="DOP853", rtol=1e-11, atol=1e-11,
                    events=end, dense_output=True)
    t_ref = ref.t_events[0][0]
    assert res.stop == "stroke end" and res.t_stop == pytest.approx(t_ref, rel=1e-6)
    inside = res.t < t_ref
    assert np.max(np.abs(res.s[inside] - ref.sol(res.t[inside])[0])) < 1e-6 * 20 * math.pi


@pytest.mark.parametrize("given, says", [
    ("summary.txt", "not a result file, it does not read as JSON"),
    ("", "a folder, not a file; give the result.json that `optdesign optimise` wrote in it (--design "),
])
def test_design_option_names_what_to_give_instead(tmp_path, given, says):
    """`simulate --design optdesign-results/dock_leveller/summary.txt` (or the folder itself)
    said only 'not a result file (Expecting value: line 1 column 1 (char 0))'."""
    folder = tmp_path / "dock_leveller"
    folder.mkdir()
    (folder / "summary.txt").write_text("Dock leveller ... optimum\n")
    (folder / "result.json").write_text("{}")
    out = cli("simulate", DATA / "dock_leveller.toml", "--design", folder / given if given else folder)
    assert out.returncode == 2 and "Traceback" not in out.stderr
    assert says in out.stderr and "optimise" in out.stderr


def test_compressor_run_up_through_a_lossy_drive_as_solve_ivp(tmp_path):
    """[drive] efficiency = 0.8, T0 = 12 N m: the motor always delivers power here (the torque
    passed on, T - J qdd, stays positive), so c = 1/eta throughout:
    (c M + J) a'' = T - c (1/2 M' a'^2 + Q)."""
    text = (DATA / "compressor_spinup.toml").read_text().replace(
        "acceleration = 0.0\n", "acceleration = 0.0\nefficiency = 0.8\n")
    assert "efficiency = 0.8" in text
    (tmp_path / "c.toml").write_text(text)
    scene = optdesign.load(tmp_path / "c.toml", {"T0": 12.0})
    res = simulate(scene, tolerance=1e-10)
    c = 1 / 0.8

    def rhs(t, x):
        a, w = x
        Q = CP["F"] * comp_ratios(a)[1]
        T = 12.0 * (1 - w / CP["w0"])
        return [w, (T - c * (0.5 * d1(comp_M, a, 1e-4) * w**2 + Q)) / (c * comp_M(a) + CP["J"])]

    end = lambda t, x: x[0] - 20 * math.pi
    end.terminal = True
    ref = solve_ivp(rhs, (0, 1.5), [0.1, 0.0], method="DOP853", rtol=1e-11, atol=1e-11, events=end,
                    dense_output=True)
    t_ref = ref.t_events[0][0]
    assert res.stop == "stroke end" and res.t_stop == pytest.approx(t_ref, rel=1e-7)
    assert np.all(res.efficiency_factor == pytest.approx(c, rel=1e-14))
    inside = res.t < t_ref
    assert np.max(np.abs(res.sd[inside] - ref.sol(res.t[inside])[1])) < 1e-5
