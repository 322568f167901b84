"""Profiles of segments (kind = "segments": laws in time between intermediate positions, with
dwells) against an independent model written here: the ventilator four-bar of
problems/ventilator_squeeze.toml (its numpy inverse kinematics and virtual work in
test_motion_output), its rocker squeezing in two stages (cycloidal to 115 deg, a 0.3 s dwell
holding the bag, modified sine to 130 deg) and returning in two (harmonic to 110 deg, a 0.2 s
dwell, 3-4-5 polynomial to 100 deg), then resting 1.2 s.  The laws from their textbook
formulas; the time at each sample by brentq on them; the RMS motor torque over the cycle by
scipy.integrate.quad in time on each smooth piece, dwells holding the static torque; each
segment's peak speed and acceleration against the laws' closed forms (C_v h/T, C_a h/T^2)."""
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.optimize import brentq

import optdesign
from optdesign.errors import SceneError
from test_motion_output import I_RATIO, J_ROTOR, PSI_HI, PSI_LO, cycloidal, drive_torque, modified_sine

PI = np.pi
SCENE = Path(__file__).parents[1] / "problems" / "ventilator_squeeze.toml"
DEG = PI / 180
SQUEEZE = '''[profiles.squeeze]
kind = "segments"
segments = [
  { law = "cycloidal", to = "115 deg", time = 0.5 },
  { dwell = 0.3 },
  { law = "modified-sine", to = "130 deg", time = 0.4 },
]'''
RETURN = '''[profiles.return]
kind = "segments"
segments = [{ law = "harmonic", to = "110 deg", time = 0.6 }, { dwell = 0.2 }, { law = "polynomial-345", to = "100 deg", time = 0.3 }]'''


def harmonic(tau):
    return (1 - np.cos(PI * tau)) / 2, PI / 2 * np.sin(PI * tau), PI**2 / 2 * np.cos(PI * tau)


def poly345(tau):
    return (10 * tau**3 - 15 * tau**4 + 6 * tau**5, 30 * tau**2 - 60 * tau**3 + 30 * tau**4,
            60 * tau - 180 * tau**2 + 120 * tau**3)


# per case: (T0, kbag) and its segments: (law, from, to, seconds, smooth pieces in tau) or (None, at, at, seconds)
CASES = {"squeeze": ((0.6, 6.0), [(cycloidal, 100, 115, 0.5, [0, 1]), (None, 115, 115, 0.3, None),
                                  (modified_sine, 115, 130, 0.4, [0, 1 / 8, 7 / 8, 1])]),
         "return": ((0.0, 0.0), [(harmonic, 130, 110, 0.6, [0, 1]), (None, 110, 110, 0.2, None),
                                 (poly345, 110, 100, 0.3, [0, 1])])}
DESIGN = (0.025, 0.10, 0.08)


def scene_text():
    text = SCENE.read_text()
    text = text.replace('[profiles.squeeze]\nkind = "cycloidal"\ntime = 1.0', SQUEEZE)
    text = text.replace('[profiles.return]\nkind = "modified-sine"\ntime = 0.8', RETURN)
    assert SQUEEZE in text and RETURN in text
    return text


def motor(psi, psi_d, psi_dd, loads):
    _, _, q_dd, torque = drive_torque(np.atleast_1d(psi), psi_d, psi_dd, *DESIGN, *loads)
    return torque, torque / I_RATIO + J_ROTOR * I_RATIO * q_dd


def state(segment, tau):
    """(psi, psi', psi'') of a segment at the fraction tau of its time (a dwell: at rest)."""
    law, a, b, T, _ = segment
    if law is None:
        return a * DEG + 0 * tau, 0 * tau, 0 * tau
    f, v, acc = law(np.asarray(tau, float))
    h = (b - a) * DEG
    return a * DEG + h * f, h / T * v, h / T**2 * acc


def reference_rms():
    total = 0.0
    for loads, segments in CASES.values():
        for seg in segments:
            T = seg[3]
            if seg[0] is None:
                total += motor(seg[1] * DEG, 0.0, 0.0, loads)[1][0] ** 2 * T
                continue
            pieces = seg[4]
            for lo, hi in zip(pieces[:-1], pieces[1:]):
                value, err = quad(lambda tau: motor(*state(seg, tau), loads)[1][0] ** 2 * T, lo, hi,
                                  epsabs=0, epsrel=1e-13, limit=200)
                total += value
    total += motor(PSI_LO, 0.0, 0.0, CASES["return"][0])[1][0] ** 2 * 1.2   # the rest, holding the return's loads
    return np.sqrt(total / (1.2 + 1.1 + 1.2))


def reference_at(name, psi):
    """(t, drive, motor torque) of a case at rocker angles ``psi``: the segment that reaches each
    one (at a stop: its arrival, at rest), tau by brentq."""
    loads, segments = CASES[name]
    out = []
    for p in psi:
        t0 = 0.0
        for seg in segments:
            law, a, b, T, _ = seg
            if law is not None and min(a, b) * DEG - 1e-15 <= p <= max(a, b) * DEG + 1e-15:
                u = np.clip((p - a * DEG) / ((b - a) * DEG), 0.0, 1.0)
                u = 1.0 if abs(p - b * DEG) <= 1e-14 else 0.0 if abs(p - a * DEG) <= 1e-14 else u   # a stop (to round-off)
                tau = 0.0 if u <= 0 else 1.0 if u >= 1 else brentq(lambda t: law(t)[0] - u, 0, 1, xtol=1e-16, rtol=8.9e-16)
                x, v, acc = state(seg, tau)
                if u >= 1:   # at a stop: at rest
                    v, acc = 0.0, 0.0
                drive, mot = motor(p, v, acc, loads)
                out.append((t0 + T * tau, drive[0], mot[0]))
                break
            t0 += T
    return np.array(out).T


@pytest.fixture(scope="module")
def analysed():
    return optdesign.analyse(optdesign.loads(scene_text(), "segments.toml"))


def test_cases_against_the_numpy_model(analysed):
    for name in CASES:
        cols = analysed.cases.cases[name].columns
        t, drive, mot = reference_at(name, cols["s"])
        assert len(t) == len(cols["s"])
        # (the time is ill-conditioned next to a rest, where f grows like the cube of the time from it:
        # 1.5e-11 s at the samples 1.5e-8 deg either side of the stops)
        assert np.max(np.abs(cols["t"] - t)) < 1e-10
        assert np.max(np.abs(cols["drive"] - drive)) < 1e-9 * np.max(np.abs(drive))
        assert np.max(np.abs(cols["motor_torque"] - mot)) < 1e-9 * np.max(np.abs(mot))
    assert analysed.cases.cases["squeeze"].duration == pytest.approx(1.2, rel=1e-15)
    assert analysed.cases.cases["return"].duration == pytest.approx(1.1, rel=1e-15)


def test_rms_over_the_cycle_against_quad(analysed):
    """Dwells carry their load: the 0.3 s at 115 deg holds the bag's torque T0 + kbag 15 deg."""
    duty = analysed.cases.duty
    assert duty["cycle_time"] == pytest.approx(3.5, rel=1e-15)
    assert duty["rms_time"]["motor_torque"] == pytest.approx(reference_rms(), rel=1e-9)


def test_segment_peaks_against_the_closed_forms(analysed):
    """Each segment's peak sweep speed C_v h/T (cycloidal 2, modified sine 4 pi/(4 + pi),
    harmonic pi/2, 3-4-5 15/8) at its middle, a node of the law in time; and the accelerations
    where their peaks are nodes: cycloidal 2 pi h/T^2 at tau = 1/4, harmonic pi^2/2 h/T^2 at the
    ends, modified sine 4 pi^2/(4 + pi) h/T^2 at tau = 1/8."""
    h15, h20, h10 = 15 * DEG, 20 * DEG, 10 * DEG
    speed = {"squeeze": [(100, 115, 2 * h15 / 0.5, 2 * PI * h15 / 0.25),
                         (115, 130, 4 * PI / (4 + PI) * h15 / 0.4, 4 * PI**2 / (4 + PI) * h15 / 0.16)],
             "return": [(110, 130, PI / 2 * h20 / 0.6, PI**2 / 2 * h20 / 0.36), (100, 110, 15 / 8 * h10 / 0.3, None)]}
    for name, segments in speed.items():
        cols = analysed.cases.cases[name].columns
        for lo, hi, v, a in segments:
            inside = (cols["s"] >= lo * DEG - 1e-12) & (cols["s"] <= hi * DEG + 1e-12)   # (next to a stop: the other segment at rest)
            assert np.max(np.abs(cols["sd"][inside])) == pytest.approx(v, rel=1e-12)
            if a is not None:
                assert np.max(np.abs(cols["sdd"][inside])) == pytest.approx(a, rel=1e-9)


def test_segments_that_do_not_run_one_way_are_refused():
    for old, new, message in (('to = "115 deg", time = 0.5', 'to = "130 deg", time = 0.5', "segments[2].to: 2.268928028 does "
                               "not lie beyond 2.268928028 towards 2.268928028"),
                              ('to = "130 deg", time = 0.4', 'to = "112 deg", time = 0.4', "segments[2].to: the last "
                               "segment ends at 1.954768762, inside the stroke"),
                              ('to = "115 deg", time = 0.5', 'to = "135 deg", time = 0.5', "segments[0].to: 2.35619449 lies "
                               "beyond the end of the motion")):
        with pytest.raises(SceneError) as info:
            optdesign.loads(scene_text().replace(old, new), "back.toml")
        assert message in str(info.value)
    text = scene_text().replace('{ dwell = 0.2 }', '{ dwell = 0.2, time = 1 }')
    with pytest.raises(SceneError) as info:
        optdesign.loads(text, "dwell.toml")
    assert "a dwell takes only its time" in str(info.value)


CYCLE = '''[profiles.breath]
kind = "cycle"
segments = [
  { law = "cycloidal", to = "115 deg", time = 0.5 },
  { dwell = 0.3 },
  { law = "modified-sine", to = "130 deg", time = 0.4 },
  { law = "harmonic", to = "110 deg", time = 0.6, set = { T0 = 0, kbag = 0 } },
  { dwell = 0.2 },
  { law = "polynomial-345", to = "100 deg", time = 0.3, set = { T0 = 0, kbag = 0 } },
  { dwell = 1.2 },
]

[[cases]]
name = "breath"
profile = "breath"

'''


def cycle_text():
    text = SCENE.read_text()
    return text[:text.index("[profiles.squeeze]")] + CYCLE + text[text.index("[[constraints]]"):text.index("# The breath in time")]


def test_one_cycle_profile_for_the_whole_breath():
    """The same breath as one profile of kind "cycle": cut where it turns back into a way each
    (cases 'breath 1' and 'breath 2', the return's set from its segments), the end's dwell a
    hold carrying the return's static load; the same numbers as the numpy model's."""
    result = optdesign.analyse(optdesign.loads(cycle_text(), "cycle.toml"))
    cases = result.cases.cases
    assert list(cases) == ["breath 1", "breath 2"]
    assert (cases["breath 1"].direction, cases["breath 2"].direction) == ("forward", "reverse")
    assert cases["breath 2"].overrides == {"T0": 0.0, "kbag": 0.0}
    for name, ref in (("breath 1", "squeeze"), ("breath 2", "return")):
        cols = cases[name].columns
        t, drive, mot = reference_at(ref, cols["s"])
        assert np.max(np.abs(cols["t"] - t)) < 1e-10
        assert np.max(np.abs(cols["motor_torque"] - mot)) < 1e-9 * np.max(np.abs(mot))
    steps = result.cases.duty["steps"]
    assert [(s["kind"], s.get("case"), s.get("at")) for s in steps] == [("case", "breath 1", None), ("case", "breath 2", None),
                                                                          ("hold", "breath 2", "end")]
    hold = motor(PSI_LO, 0.0, 0.0, (0.0, 0.0))[0][0]
    assert steps[2]["load"] == pytest.approx(hold, rel=1e-12)
    assert result.cases.duty["rms_time"]["motor_torque"] == pytest.approx(reference_rms(), rel=1e-9)


def test_a_cycle_that_turns_back_inside_the_stroke_is_refused():
    for old, new, message in (
            ('{ law = "modified-sine", to = "130 deg", time = 0.4 },', '{ law = "modified-sine", to = "125 deg", time = 0.4 },\n'
             '  { law = "cycloidal", to = "130 deg", time = 0.3 },\n  { law = "cycloidal", to = "120 deg", time = 0.3 },\n'
             '  { law = "cycloidal", to = "130 deg", time = 0.3 },', "segments[5].to: the cycle turns back at 2.094395102, "
             "inside the stroke"),
            ('to = "100 deg", time = 0.3', 'to = "105 deg", time = 0.3', "segments[5].to: the cycle starts where its "
             "last motion ends, 1.832595715, inside the stroke"),
            ('profile = "breath"', 'profile = "breath"\ndirection = "forward"', "[[cases]] 'breath', direction: the case "
             "runs the cycle 'breath', which goes both ways"),
            ('{ law = "harmonic", to = "110 deg", time = 0.6, set = { T0 = 0, kbag = 0 } }',
             '{ law = "harmonic", to = "110 deg", time = 0.6 }', "segments[5].set: the segments of one way of the "
             "cycle carry one load")):
        with pytest.raises(SceneError) as info:
            optdesign.loads(cycle_text().replace(old, new), "cycle.toml")
        assert message in str(info.value), str(info.value)


def reference_psi(name, t):
    """The rocker angle of a case's segments at times t from its start (numpy laws)."""
    out = np.full(len(t), np.nan)
    t0 = 0.0
    for seg in CASES[name][1]:
        inside = (t >= t0) & (t <= t0 + seg[3])
        out[inside] = state(seg, (t[inside] - t0) / seg[3])[0]
        t0 += seg[3]
    return out


def test_simulate_tracks_the_segments():
    """simulate's phases (the scene's speed controller with a position loop tracking each case's
    profile, then the motor holding the rest) follow the segments, stops and dwells included,
    to the controller's tracking error (the stroke is 0.52 rad)."""
    result = optdesign.simulate(optdesign.loads(scene_text().replace("t_end = 3.0", "t_end = 3.5"), "sim.toml"))
    assert [p["name"] for p in result.phases] == ["squeeze", "return", "rest"]
    t, psi = result.t, result.columns["s"]
    want = np.where(t <= 1.2, reference_psi("squeeze", np.clip(t, 0, 1.2)),
                    np.where(t <= 2.3, reference_psi("return", np.clip(t - 1.2, 0, 1.1)), PSI_LO))
    assert np.max(np.abs(psi - want)) < 1e-3


def test_the_motion_figure_draws_each_dwell_as_a_rest(analysed, tmp_path):
    from optdesign.report.cases import cases_figures
    from optdesign.report.output_motion import _with_dwells

    case = analysed.cases.cases["squeeze"]
    assert case.rests == ((0.5, pytest.approx(0.8, abs=1e-15), pytest.approx(115 * DEG, abs=1e-15)),)
    t, cols = _with_dwells(case)
    i = int(np.flatnonzero(np.isclose(t, 0.8, rtol=0, atol=1e-12))[0])
    assert t[i - 1] == 0.5 and cols["s"][i] == cols["s"][i - 1] and cols["sd"][i] == 0 and cols["sdd"][i] == 0
    assert np.all(np.diff(t) >= 0)
    assert tmp_path / "motion.png" in cases_figures(analysed, tmp_path)
