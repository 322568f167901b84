"""examples/seed1_figures.py run headless: the files it claims, and its numbers checked against
independent derivations written here (closed forms of the two worked examples of seed 1, power
balance), never against the code under test.

Closed forms used (derived here, see the comments; the seed's prints carry slips):
slider-crank, piston on the line through S, alpha from the bottom dead centre, L = l/r:
    y_C = -r cos(alpha) + sqrt(l^2 - r^2 sin^2(alpha))
    R_z = dy_C/dalpha = r [sin a - 1/2 sin 2a / sqrt(L^2 - sin^2 a)]            (eq. 18, with
          l^2/r^2 under the root where the print has r^2/l^2)
    dR_z/dalpha = r [cos a - cos 2a / sqrt(X) - 1/4 sin^2 2a / X^(3/2)], X = L^2 - sin^2 a
          (the second bracket of eq. 21; eq. 19 as printed carries an extra factor 1/2)
jib, triangle A (pivot), D (cylinder base, |AD| = e), B (rod eye, |AB| = b), x = |DB|:
    cos(delta) = (x^2 + e^2 - b^2)/(2 e x) at D; i_v = v_S/v_C = (e/l) sin(delta)   (eq. 39)
    gamma = angle DAB = acos((e^2 + b^2 - x^2)/(2 e b)), jib angle theta = psi + gamma,
    dtheta/dx = x/(e b sin gamma)                                                  (law of cosines)
"""
from __future__ import annotations

import csv
import os
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest

import optdesign

ROOT = Path(__file__).resolve().parents[1]
SCRIPT = ROOT / "examples" / "seed1_figures.py"
SLIDER_CRANK = ROOT / "problems" / "seed1_slider_crank.toml"
JIB = ROOT / "problems" / "seed1_jib.toml"

EXPECTED_COLUMNS = {
    "fig06_R_z": ["alpha [deg]", "R_z [m]", "|R_z| [m]", "dR_z/dalpha [m/rad]", "d|R_z|/dalpha [m/rad]"],
    "fig07_I_zS": ["alpha [deg]", "I_zS [kg m^2]", "dI_zS/dalpha [kg m^2/rad]"],
    "fig08_piston_acceleration": ["alpha [deg]", "a_C0 [m/s^2]", "delta_a_C [m/s^2]", "a_C [m/s^2]"],
    "fig09_torque_T_S": ["alpha [deg]", "T_Su [N m]", "I_zS*eps_S [N m]", "dT_S [N m]", "T_S [N m]"],
    "fig13_i_v": ["x [m]", "i_v [-]", "di_v/dx [1/m]"],
    "fig14_m_zS": ["x [m]", "m_zS [kg]", "dm_zS/dx [kg/m]"],
    "fig15_tip_acceleration": ["x [m]", "a_C0 [m/s^2]", "delta_a_C [m/s^2]", "a_C [m/s^2]"],
    "fig16_force_F_S": ["x [m]", "F_Su [N]", "m_zS*a_S [N]", "dF_S [N]", "F_S [N]"],
}


# --- running the example once --------------------------------------------------------------------
@pytest.fixture(scope="module")
def out(tmp_path_factory):
    """Run the script as a user would (own process, Agg backend, another working directory)."""
    folder = tmp_path_factory.mktemp("seed1")
    env = dict(os.environ, MPLBACKEND="Agg")
    run = subprocess.run([sys.executable, str(SCRIPT), "--out", str(folder)], cwd=folder.parent, env=env,
                         capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr
    assert len(run.stdout.splitlines()) == 16, run.stdout
    return folder


def read(out, stem):
    """{column header: array} of one CSV, in file order."""
    path = out / f"{stem}.csv"
    with open(path, newline="") as fh:
        rows = list(csv.reader(fh))
    header, body = rows[0], np.array(rows[1:], dtype=float)
    return {h: body[:, i] for i, h in enumerate(header)}


def assert_close(got, want, rel):
    """|got - want| <= rel * max|want| at every sample."""
    got, want = np.asarray(got), np.asarray(want)
    scale = np.max(np.abs(want))
    err = np.max(np.abs(got - want))
    assert err <= rel * scale, f"max error {err:.3g} > {rel:g} x {scale:.3g}"


def max_rel(values):
    return np.max(np.abs(values))


@pytest.fixture(scope="module")
def slider():
    """The slider-crank's data (inputs, read from the scene file)."""
    p = optdesign.load(SLIDER_CRANK).parameter_values()
    drive = tomllib.loads(SLIDER_CRANK.read_text())["drive"]
    return {"r": p["r"], "l": p["l"], "m": p["mC"], "F": p["FC"], "omega": drive["speed"], "eps": drive["acceleration"]}


@pytest.fixture(scope="module")
def jib():
    p = optdesign.load(JIB).parameter_values()
    data = tomllib.loads(JIB.read_text())
    return {"l": p["l"], "e": p["e"], "b": p["b"], "psi": p["psi"], "m": p["mC"], "g": data["gravity"]["g"],
            "v": data["drive"]["speed"], "a": data["drive"]["acceleration"]}


def slider_closed_form(alpha, r, l):
    """(R_z, dR_z/dalpha) of the slider-crank, signed (module docstring)."""
    X = (l / r) ** 2 - np.sin(alpha) ** 2
    R = r * (np.sin(alpha) - 0.5 * np.sin(2 * alpha) / np.sqrt(X))
    dR = r * (np.cos(alpha) - np.cos(2 * alpha) / np.sqrt(X) - 0.25 * np.sin(2 * alpha) ** 2 / X**1.5)
    return R, dR


def jib_closed_form(x, d):
    """i_v, di_v/dx, m_zS, dm_zS/dx by the seed's eqs. (39)-(42) (checked in the module
    docstring and by test_closed_forms_agree_with_plain_differences), and theta, dtheta/dx,
    d2theta/dx2 from the triangle A-D-B."""
    e, b, l, m = d["e"], d["b"], d["l"], d["m"]
    c = (x**2 + e**2 - b**2) / (2 * e * x)
    i_v = e / l * np.sqrt(1 - c**2)
    di_v = -(e**2 / l**2) * (x**4 - (e**2 - b**2) ** 2) / (4 * e**2 * x**3 * (e / l) * np.sqrt(1 - c**2))
    m_zS = m * l**2 * 4 * x**2 / (4 * e**2 * x**2 - (x**2 + e**2 - b**2) ** 2)
    dm_zS = 0.5 * m * l**2 / e**4 * (x**4 - (e**2 - b**2) ** 2) / (x**3 * (1 - c**2) ** 2)
    gamma = np.arccos((e**2 + b**2 - x**2) / (2 * e * b))
    dtheta = x / (e * b * np.sin(gamma))
    d2theta = 1 / (e * b * np.sin(gamma)) - x * np.cos(gamma) * dtheta / (e * b * np.sin(gamma) ** 2)
    return {"i_v": i_v, "di_v": di_v, "m_zS": m_zS, "dm_zS": dm_zS, "theta": d["psi"] + gamma,
            "dtheta": dtheta, "d2theta": d2theta}


# --- the files -----------------------------------------------------------------------------------
def test_all_figures_written_as_png_and_csv(out):
    names = sorted(p.name for p in out.iterdir())
    assert names == sorted(f"{s}.{ext}" for s in EXPECTED_COLUMNS for ext in ("png", "csv"))  # no temp files left
    for stem in EXPECTED_COLUMNS:
        png = (out / f"{stem}.png").read_bytes()
        assert png[:8] == b"\x89PNG\r\n\x1a\n"
        width, height = int.from_bytes(png[16:20], "big"), int.from_bytes(png[20:24], "big")
        assert width >= 800 and height >= 600, (stem, width, height)


@pytest.mark.parametrize("stem", sorted(EXPECTED_COLUMNS))
def test_csv_columns_are_the_figure_quantities(out, stem):
    cols = read(out, stem)
    assert list(cols) == EXPECTED_COLUMNS[stem]
    n = {"fig0": 721, "fig1": 201}[stem[:4]]  # the scenes' sample counts
    assert all(len(v) == n for v in cols.values())


# --- slider-crank, Figs. 6-9 ---------------------------------------------------------------------
def test_fig06_R_z_is_the_closed_form_and_the_tool_gives_its_magnitude(out, slider):
    c = read(out, "fig06_R_z")
    alpha = np.radians(c["alpha [deg]"])
    assert_close(c["alpha [deg]"], np.linspace(0, 360, 721), 1e-14)
    R, dR = slider_closed_form(alpha, slider["r"], slider["l"])
    assert_close(c["R_z [m]"], R, 1e-10)
    assert_close(c["dR_z/dalpha [m/rad]"], dR, 1e-10)
    assert_close(c["|R_z| [m]"], np.abs(c["R_z [m]"]), 1e-12)
    # the tool's d|R_z|/dalpha: sign(v_C) dR_z/dalpha where the piston moves; undefined only where
    # it stands still (|v_C| has a corner there)
    tool = c["d|R_z|/dalpha [m/rad]"]
    moving = np.abs(R) > 1e-6 * max_rel(R)
    assert_close(tool[moving], np.sign(R[moving]) * dR[moving], 1e-9)
    assert np.all(np.abs(R[~np.isfinite(tool)]) <= 1e-12 * max_rel(R))
    # at the dead centres (sin alpha = 0) the closed form gives dR_z/dalpha = r (cos a - cos 2a r/l):
    # r (1 - r/l) at the bottom (0, 360 deg) and -r (1 + r/l) at the top (180 deg)
    r, l = slider["r"], slider["l"]
    assert c["dR_z/dalpha [m/rad]"][[0, 360, 720]] == pytest.approx([r * (1 - r / l), -r * (1 + r / l), r * (1 - r / l)], rel=1e-12)


def test_fig07_I_zS_is_m_R_z_squared_and_vanishes_at_the_dead_centres(out, slider):
    c6, c7 = read(out, "fig06_R_z"), read(out, "fig07_I_zS")
    R, dR = c6["R_z [m]"], c6["dR_z/dalpha [m/rad]"]
    I, dI = c7["I_zS [kg m^2]"], c7["dI_zS/dalpha [kg m^2/rad]"]
    assert_close(I, slider["m"] * R**2, 1e-12)          # eq. (20) with eta = 1
    assert_close(dI, 2 * slider["m"] * R * dR, 1e-10)   # d/dalpha of m R_z^2
    assert np.all(np.abs(I[[0, 360, 720]]) <= 1e-12 * max_rel(I))  # alpha = 0, 180, 360 deg
    assert np.all(I >= 0)


def test_fig08_piston_acceleration_is_the_second_derivative_of_its_position(out, slider):
    c = read(out, "fig08_piston_acceleration")
    alpha = np.radians(c["alpha [deg]"])
    omega, eps, r, l = slider["omega"], slider["eps"], slider["r"], slider["l"]
    R, dR = slider_closed_form(alpha, r, l)
    assert_close(c["a_C0 [m/s^2]"], R * eps, 1e-10)
    assert_close(c["delta_a_C [m/s^2]"], dR * omega**2, 1e-10)
    assert_close(c["a_C [m/s^2]"], c["a_C0 [m/s^2]"] + c["delta_a_C [m/s^2]"], 1e-12)
    assert_close(c["a_C [m/s^2]"], R * eps + dR * omega**2, 1e-10)  # d2y_C/dt2 at constant eps
    # textbook values at the dead centres: r omega^2 (1 -+ r/l) towards the top dead centre
    assert c["a_C [m/s^2]"][[0, 360]] == pytest.approx([r * omega**2 * (1 - r / l), -r * omega**2 * (1 + r / l)], rel=1e-12)


def test_fig09_torque_balances_the_power_of_the_piston(out, slider):
    c = read(out, "fig09_torque_T_S")
    c7 = read(out, "fig07_I_zS")
    alpha = np.radians(c["alpha [deg]"])
    T_Su, Ieps, dT, T_S = (c[k] for k in ("T_Su [N m]", "I_zS*eps_S [N m]", "dT_S [N m]", "T_S [N m]"))
    assert_close(T_S, T_Su + Ieps - dT, 1e-12)                                          # eq. (16)
    assert_close(dT, -0.5 * slider["omega"] ** 2 * c7["dI_zS/dalpha [kg m^2/rad]"], 1e-12)  # eq. (15)
    assert_close(Ieps, c7["I_zS [kg m^2]"] * slider["eps"], 1e-12)
    # virtual work: the gas force F_C pushes the piston down, so lifting it at R_z omega takes F_C R_z
    R, dR = slider_closed_form(alpha, slider["r"], slider["l"])
    assert_close(T_Su, slider["F"] * R, 1e-10)
    # power balance: T_S omega = m a_C v_C + F_C v_C with v_C = R_z omega (eta = 1)
    a_C = R * slider["eps"] + dR * slider["omega"] ** 2
    assert_close(T_S, slider["m"] * R * a_C + slider["F"] * R, 1e-10)


# --- jib, Figs. 13-16 ----------------------------------------------------------------------------
def test_closed_forms_agree_with_plain_differences(jib):
    """The test's own eqs. (39)-(42) against central differences of eq. (39) (h = 1e-5 m,
    truncation ~1e-10 relative) and against theta(x): i_v = 1/(l dtheta/dx)."""
    x, h = np.linspace(2.2, 3.2, 11), 1e-5
    f = jib_closed_form(x, jib)
    fp, fm = jib_closed_form(x + h, jib), jib_closed_form(x - h, jib)
    assert_close(f["di_v"], (fp["i_v"] - fm["i_v"]) / (2 * h), 1e-8)
    assert_close(f["dm_zS"], (fp["m_zS"] - fm["m_zS"]) / (2 * h), 1e-8)
    assert_close(f["m_zS"], jib["m"] / f["i_v"] ** 2, 1e-13)
    assert_close(f["i_v"], 1 / (jib["l"] * f["dtheta"]), 1e-13)
    assert_close(f["d2theta"], (fp["dtheta"] - fm["dtheta"]) / (2 * h), 1e-8)


def test_fig13_i_v_is_eq_39_and_falls_over_the_stroke(out, jib):
    c = read(out, "fig13_i_v")
    x = c["x [m]"]
    assert (x[0], x[-1]) == pytest.approx((2.2, 3.2), abs=1e-9)
    f = jib_closed_form(x, jib)
    assert_close(c["i_v [-]"], f["i_v"], 1e-10)
    assert_close(c["di_v/dx [1/m]"], f["di_v"], 1e-10)
    assert np.all(np.diff(c["i_v [-]"]) < 0)


def test_fig14_m_zS_is_m_over_i_v_squared_and_its_derivative_is_a_difference_limit(out, jib):
    c13, c14 = read(out, "fig13_i_v"), read(out, "fig14_m_zS")
    x, m_zS, dm_zS = c14["x [m]"], c14["m_zS [kg]"], c14["dm_zS/dx [kg/m]"]
    assert_close(m_zS, jib["m"] / c13["i_v [-]"] ** 2, 1e-12)   # eq. (41) in terms of eq. (39)
    f = jib_closed_form(x, jib)
    assert_close(m_zS, f["m_zS"], 1e-10)
    assert_close(dm_zS, f["dm_zS"], 1e-10)
    # second-order differences of the m_zS column (h ~ 5 mm): error O(h^2), ~6e-5 of max|dm_zS/dx|;
    # doubling h must multiply it by ~4 (the column is the derivative, not something near it)
    errors = []
    for step in (1, 2):
        fd = np.gradient(m_zS[::step], x[::step], edge_order=2)
        errors.append(np.max(np.abs(fd - dm_zS[::step])) / max_rel(dm_zS))
    assert errors[0] < 2e-4
    assert 3.5 < errors[1] / errors[0] < 4.5
    assert np.all(np.diff(m_zS) > 0)  # grows as the transmission worsens (i_v falls)


def test_fig15_tip_acceleration_is_l_times_the_jib_angular_acceleration(out, jib):
    c, c13 = read(out, "fig15_tip_acceleration"), read(out, "fig13_i_v")
    x = c["x [m]"]
    i_v, di_v = c13["i_v [-]"], c13["di_v/dx [1/m]"]
    assert_close(c["a_C0 [m/s^2]"], jib["a"] / i_v, 1e-12)                       # eq. (24)
    assert_close(c["delta_a_C [m/s^2]"], -jib["v"] ** 2 * di_v / i_v**2, 1e-10)  # eq. (24), di_v/dx
    assert_close(c["a_C [m/s^2]"], c["a_C0 [m/s^2]"] + c["delta_a_C [m/s^2]"], 1e-12)
    f = jib_closed_form(x, jib)  # tip on a circle of radius l: a_C = l theta'' in time
    assert_close(c["a_C [m/s^2]"], jib["l"] * (jib["a"] * f["dtheta"] + jib["v"] ** 2 * f["d2theta"]), 1e-10)


def test_fig16_force_balances_the_power_of_the_load(out, jib):
    c, c14 = read(out, "fig16_force_F_S"), read(out, "fig14_m_zS")
    x = c["x [m]"]
    F_Su, ma, dF, F_S = (c[k] for k in ("F_Su [N]", "m_zS*a_S [N]", "dF_S [N]", "F_S [N]"))
    assert_close(F_S, F_Su + ma - dF, 1e-12)                                          # eq. (37)
    assert_close(dF, -0.5 * jib["v"] ** 2 * c14["dm_zS/dx [kg/m]"], 1e-12)             # eq. (36)
    assert_close(ma, c14["m_zS [kg]"] * jib["a"], 1e-12)
    f = jib_closed_form(x, jib)
    # virtual work of the weight: F_Su dx = m g d(l sin theta)
    weight = jib["m"] * jib["g"] * jib["l"] * np.cos(f["theta"]) * f["dtheta"]
    assert_close(F_Su, weight, 1e-10)
    # power balance: F_S v_S = m a_C v_C + m g v_Cy, v_C = l theta' v_S
    a_C = jib["l"] * (jib["a"] * f["dtheta"] + jib["v"] ** 2 * f["d2theta"])
    assert_close(F_S, jib["m"] * a_C * jib["l"] * f["dtheta"] + weight, 1e-10)
