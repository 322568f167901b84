"""A rest at a stroke's end is a rest, not a dead centre; messages give the sweep in the units the
scene wrote it (issue 28).

* The ventilator's motion written with the normalised time tau as the sweep (the rocker placed
  by the cycloidal law psi0 + h (tau - sin(2 pi tau)/(2 pi))): at tau = 0 the crank's
  dq/dtau = 0 because the whole mechanism rests, not because the drive passes a dead centre.
  The old code called it a dead centre "at tau = 0 (0 deg)" with "infinite" loads; it is now
  named a rest, with the remedy (the output as the sweep, the law as a profile), and tau
  printed as the plain number the scene wrote.
* A linear drive whose length is extremal at the stroke's end while the crank still turns is a
  dead centre (the numpy model: |PB| is least where P, A, B line up), and a crank angle swept
  in plain radians is still shown in degrees too.
"""
import math
import pathlib

import numpy as np
import pytest

import optdesign
from optdesign.errors import DeadCentreError

ROOT = pathlib.Path(__file__).resolve().parents[1]


def tau_scene() -> str:
    text = (ROOT / "problems" / "ventilator_squeeze.toml").read_text()
    text = text.replace('name = "psi"            # the rocker\'s direction D->C: the output\nfrom = "100 deg"\nto = "130 deg"',
                        'name = "tau"\nfrom = 0\nto = 1')
    text = text.replace('psi0 = "100 deg"', 'psi0 = "100 deg"\nh = "30 deg"')
    text = text.replace('C = { polar = ["D", "c", "psi"] }', 'C = { polar = ["D", "c", "psi0 + h*(tau - sin(2*pi*tau)/(2*pi))"] }')
    text = text.replace('expr = "psi - psi0"', 'expr = "angle(D, C) - psi0"')
    # the motion in time is the sweep itself here: no profiles, cases, duty or phases
    text = text[:text.index("[profiles.squeeze]")] + text[text.index("[[constraints]]"):text.index("# The breath in time")]
    text = text.replace('minimise = "rms_time(motor_torque)"', 'minimise = "rms(drive)"')
    assert 'name = "tau"' in text and "tau - sin" in text
    return text


def test_a_rest_at_the_stroke_end_is_named_a_rest_in_the_sweeps_units():
    scene = optdesign.loads(tau_scene(), "tau.toml")
    with pytest.raises(DeadCentreError) as info:
        optdesign.analyse(scene)
    message = str(info.value)
    assert "[sweep] tau = 0: the mechanism rests at this end of the stroke" in message
    assert "not a dead centre" in message and "[profiles]" in message
    assert "deg)" not in message and "infinite" not in message
    assert info.value.s == 0.0


def test_a_drive_dead_centre_at_the_stroke_end_is_still_a_dead_centre():
    """Crank A->B (r) swept by phi in plain radians from 0; the drive a cylinder from P = (d, 0)
    to B, whose length |PB| = sqrt(r^2 + d^2 - 2 r d cos phi) is least at phi = 0 (numpy below)
    while B moves at r per radian: a dead centre of the drive, shown in degrees too."""
    r, d = 0.1, 0.5
    text = f"""title = "crank with a cylinder at its dead centre"
[parameters]
r = {r}
d = {d}
[sweep]
name = "phi"
from = 0
to = 1.5
samples = 31
[points]
A = {{ fixed = [0, 0] }}
P = {{ fixed = ["d", 0] }}
B = {{ polar = ["A", "r", "phi"] }}
[[bodies]]
name = "crank"
frame = ["A", "B"]
mass = 2.0
com = ["r/2", 0]
[gravity]
g = 9.81
[drive]
type = "linear"
between = ["P", "B"]
speed = 0.1
acceleration = 0.0
"""
    phi = np.linspace(0, 1.5, 31)
    q = np.sqrt(r**2 + d**2 - 2 * r * d * np.cos(phi))
    assert np.argmin(q) == 0 and np.gradient(q, phi)[0] == pytest.approx(0, abs=0.01)
    with pytest.raises(DeadCentreError) as info:
        optdesign.analyse(optdesign.loads(text, "cylinder.toml"))
    message = str(info.value)
    assert "[drive] dead centre at phi = 0 (0 deg)" in message and "rests" not in message


def test_the_located_position_is_printed_in_degrees_for_an_angle_only():
    from optdesign.kinematics.assembly import fmt_s

    tau = optdesign.loads(tau_scene(), "tau.toml")
    vent = optdesign.load(ROOT / "problems" / "ventilator_squeeze.toml")
    assert fmt_s(0.5, tau) == "0.5"
    assert fmt_s(math.radians(100), vent) == f"{math.radians(100):.10g} (100 deg)"
