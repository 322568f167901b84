"""Ctrl-C in a motor catalogue keeps what finished: the motors decided, the interrupted motor's
best design of its finished starts (a feasible design proves that motor fits), the motors not
tried; the command line writes it to the results folder as a whole, marked interrupted, or
nothing when nothing was decided.

The scene: a crank (the sweep) lifting a payload on a Scotch yoke, driven through a gearbox of
ratio i (the one design variable) by the motors of a catalogue of three, the RMS motor torque
over two load cases minimised.  "tiny" cannot carry the load at any ratio, "small" can
(tests/test_cases_optimise.py checks both against a numpy model of this mechanism and a dense
scan of the ratio); each start takes about 0.2 s."""
from __future__ import annotations

import dataclasses
import json
import os
import re
import signal
import subprocess
import time

import pytest

import optdesign
from optdesign.errors import OptimisationInterrupted


SCENE = '''title = "crank lifting a payload through a gearbox, sized for a motor of a catalogue"
[parameters]
r = 0.2
rc = 0.2
m = 30.0
mc = 10.0
i = { value = 20.0, min = 2.0, max = 200.0 }
[sweep]
name = "theta"
from = 0.2
to = 2.6
samples = 61
[points]
O = { fixed = [0, 0] }
P = { polar = ["O", "r", "theta"] }
B = { polar = ["O", "rc", "theta + pi"] }
C = { fixed = [0, "r*sin(theta)"] }
D = { fixed = [1, "r*sin(theta)"] }
[[bodies]]
name = "payload"
frame = ["C", "D"]
mass = "m"
com = [0, 0]
[[bodies]]
name = "counterweight"
frame = ["O", "B"]
mass = "mc"
com = ["rc", 0]
[gravity]
g = 9.81
[drive]
type = "rotary"
crank = ["O", "P"]
speed = 1.0
acceleration = 0.0
[profiles.trap]
kind = "trapezoidal"
speed = 0.8
acceleration = 0.5
deceleration = 0.3
[[cases]]
name = "loaded up"
direction = "forward"
profile = "trap"
[[cases]]
name = "empty down"
direction = "reverse"
set = { m = 0 }
profile = "trap"
[gearbox]
ratio = "i"
[[motors]]
name = "tiny"
inertia = 1e-4
rated_torque = 0.05
peak_torque = 0.15
max_speed = 500
[[motors]]
name = "small"
inertia = 4e-4
rated_torque = 0.6
peak_torque = 2.0
max_speed = 500
[[motors]]
name = "large"
inertia = 2e-3
rated_torque = 3.0
peak_torque = 9.0
max_speed = 500
[objective]
minimise = "rms_time(motor_torque)"
'''


@pytest.fixture(autouse=True)
def no_energy_proof(monkeypatch):
    """These tests interrupt a motor's starts: the energy proof (design/energy_bound.py), which
    decides the tiny motor before its starts in this process, is left out here
    (tests/test_energy_bound.py has it)."""
    from optdesign.design import catalogue

    monkeypatch.setattr(catalogue.Prover, "prove", lambda self, motor: None)


@pytest.fixture
def scene_path(tmp_path):
    path = tmp_path / "catalogue.toml"
    path.write_text(SCENE)
    return path


def only(scene, name):
    """The scene with one motor of its catalogue: optimised on its own."""
    return dataclasses.replace(scene, motors=tuple(m for m in scene.motors if m.name == name))


def ctrl_c_at(motor, done):
    """A progress callback (label, done, total) that sends Ctrl-C when ``motor``'s starts reach
    ``done`` (0: once its starts are planned)."""
    def progress(label, n, total):
        if label.startswith(f"{motor}, ") and n == done:
            os.kill(os.getpid(), signal.SIGINT)
    return progress


def test_ctrl_c_in_a_catalogue_from_python_carries_the_catalogue_so_far(scene_path):
    from optdesign.design.catalogue import optimise_catalogue

    scene = optdesign.load(scene_path)
    with pytest.raises(OptimisationInterrupted) as caught:
        optimise_catalogue(scene, starts=3, workers=1, progress=ctrl_c_at("small", 1))
    stop = caught.value
    assert isinstance(stop, KeyboardInterrupt) and (stop.finished, stop.total) == (1, 3)
    cat = stop.catalogue
    assert cat.interrupted == "small" and cat.interrupted_starts == (1, 3)
    assert list(cat.results) == ["tiny", "small"] and cat.not_tried == ("large",)
    assert not cat.results["tiny"].success and cat.results["tiny"].status == "infeasible"
    # the best design of small's one finished start: feasible, so small fits (tiny does not)
    result = stop.result
    assert cat.results["small"] is result and cat.best is result and cat.chosen == "small"
    assert result.interrupted and result.success and result.starts_total == 1
    assert result.message.startswith("INTERRUPTED by Ctrl-C after 1 of 3 starts")
    # it is what that start finds when small is optimised from it alone, uninterrupted
    alone = optdesign.optimise(only(scene, "small"), x_starts=[[result.starts[0].start["i"]]], workers=1)
    assert alone.success and not alone.interrupted
    assert result.design["i"] == pytest.approx(alone.design["i"], rel=1e-9)
    assert result.objective == pytest.approx(alone.objective, rel=1e-9)
    # nothing left pending: the next catalogue runs to its end
    assert optimise_catalogue(scene, starts=1, workers=1).interrupted is None


def test_ctrl_c_while_the_last_motors_starts_are_summarised_keeps_them(scene_path, monkeypatch):
    """Ctrl-C after small's last start, while its starts are summarised (the best one polished):
    the best design of all of them, marked interrupted, and small chosen."""
    from optdesign.design import multistart
    from optdesign.design.catalogue import optimise_catalogue

    summarise, calls = multistart.summarise, []

    def interrupted_once(*args, **kw):
        calls.append(len(args[2]))
        if len(calls) == 2:   # tiny's summary, then small's: Ctrl-C inside it
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(1.0)
        return summarise(*args, **kw)
    monkeypatch.setattr(multistart, "summarise", interrupted_once)
    scene = optdesign.load(scene_path)
    with pytest.raises(KeyboardInterrupt) as caught:
        optimise_catalogue(scene, starts=3, workers=1)
    stop = caught.value
    assert isinstance(stop, OptimisationInterrupted), "the Ctrl-C while summarising lost the finished starts"
    assert calls == [3, 3, 3] and (stop.finished, stop.total) == (3, 3)
    assert stop.catalogue.chosen == "small" and stop.catalogue.interrupted_starts == (3, 3)
    assert stop.result.interrupted and stop.result.starts_total == 3
    assert stop.result.message.startswith("INTERRUPTED by Ctrl-C after 3 of 3 starts, once all had finished")
    monkeypatch.setattr(multistart, "summarise", summarise)
    alone = optdesign.optimise(only(scene, "small"), starts=3, workers=1)   # the same starts, uninterrupted
    assert stop.result.design["i"] == pytest.approx(alone.design["i"], rel=1e-9)
    assert stop.result.objective == pytest.approx(alone.objective, rel=1e-9)


@pytest.mark.parametrize("motor, done", [("small", 1), ("small", 0), ("tiny", 0)])
def test_ctrl_c_in_a_catalogue_on_the_command_line(scene_path, tmp_path, monkeypatch, capsys, motor, done):
    """Interrupted after small's first start: small is chosen, its design saved with the figures
    (no animation); before any of small's starts: tiny's outcome saved, no motor chosen, no
    figures; before any of tiny's starts: nothing written."""
    import optdesign.cli.optimise as command
    from optdesign.cli import main as cli

    send = ctrl_c_at(motor, done)
    monkeypatch.setattr(command, "progress_bar", lambda what: lambda n, total: send(what[len("starts, "):], n, total))
    caught = []
    save = command.save_interrupted
    monkeypatch.setattr(command, "save_interrupted", lambda stop, *a: caught.append(stop) or save(stop, *a))
    out = tmp_path / "out"
    assert cli.main(["optimise", str(scene_path), "--starts", "3", "--workers", "1", "--out", str(out)]) == 130
    err = capsys.readouterr().err
    assert "Traceback" not in err
    line = err.strip().splitlines()[-1]
    stop, = caught
    place = "2 of 3" if motor == "small" else "1 of 3"
    assert line.startswith(f"optdesign optimise: interrupted (motor catalogue: interrupted while optimising motor "
                           f"'{motor}' ({place}) after {done} of 3 of its starts"), line
    if motor == "tiny":
        assert stop.catalogue.best is None and stop.result is None
        assert line.endswith("none with a feasible design and no motor decided; nothing was written: "
                             "every results folder is as it was)"), line
        assert not out.exists()
        return
    doc = json.loads((out / "result.json").read_text())
    summary = (out / "summary.txt").read_text()
    assert doc["interrupted"] is True and doc["not_tried"] == ["large"]
    assert doc["motors"] == {"tiny": "does not fit", "small": "interrupted", "large": "not tried"}
    assert doc["catalogue"]["tiny"]["success"] is False and doc["catalogue"]["tiny"]["status"] == "infeasible"
    assert summary.startswith("motor catalogue INTERRUPTED by Ctrl-C")
    assert not (out / "animation.gif").exists()
    if done == 1:
        # the saved design is the one small's finished start found: the exception's result
        assert doc["interrupted_motor"] == {"name": "small", "starts_finished": 1, "starts_total": 3, "fits": True}
        assert doc["chosen_motor"] == "small" and doc["success"] is True and doc["starts_total"] == 1
        assert doc["design"] == stop.result.design and doc["objective"] == stop.result.objective
        assert doc["catalogue"]["small"]["design"] == stop.result.design
        assert doc["message"].startswith("INTERRUPTED by Ctrl-C after 1 of 3 starts")
        assert "small: INTERRUPTED by Ctrl-C after 1 of 3 starts: fits" in summary
        assert "smallest motor that fits: small\nbelow: the optimisation with motor 'small' (the smallest that fits)" \
            in summary
        assert (out / "mechanism.png").exists() and (out / "drive_and_constraints.png").exists()
        assert line.endswith(f"tiny does not fit; 'small' fits, the smallest that does: the best design of its 1 "
                             f"finished start, with the catalogue's outcome, was written to {out}, replaced as a "
                             "whole and marked interrupted in result.json and summary.txt)"), line
    else:
        assert stop.result is None
        assert doc["interrupted_motor"] == {"name": "small", "starts_finished": 0, "starts_total": 3, "fits": False}
        assert doc["chosen_motor"] is None and doc["success"] is False and list(doc["catalogue"]) == ["tiny"]
        assert ("smallest motor that fits: none found (the catalogue was interrupted before a motor was found to fit)\n"
                "below: the optimisation with motor 'tiny' (the last motor decided; it does not fit)") in summary
        assert sorted(p.name for p in out.iterdir()) == ["result.json", "summary.txt"]   # no design to draw
        assert line.endswith(f"tiny does not fit; no motor was found to fit: the catalogue's outcome so far was "
                             f"written to {out}, replaced as a whole and marked interrupted in result.json and "
                             "summary.txt)"), line


def test_ctrl_c_in_a_catalogue_through_the_command_line(scene_path, tmp_path):
    """A real Ctrl-C to `optdesign optimise` once the second motor's first start has finished:
    its standard error is a terminal (a pseudo-terminal here), so the command draws a progress
    bar per motor, which says when."""
    import pty
    import select
    import sys

    out = tmp_path / "out"
    master, slave = pty.openpty()
    proc = subprocess.Popen([sys.executable, "-m", "optdesign", "optimise", str(scene_path), "--starts", "16",
                             "--workers", "1", "--out", str(out)], cwd=tmp_path, stdout=subprocess.PIPE,
                            stderr=slave, text=True, env={**os.environ, "MPLBACKEND": "Agg"},
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    os.close(slave)
    err, sent, t0 = "", None, time.monotonic()
    # read until the command closes its terminal (it has ended); the limit only catches a hang
    # (a window of 120 s from the start closed the terminal at load ~14 before the command had
    # saved after its Ctrl-C: exit status 1 instead of 130)
    while time.monotonic() - t0 < 900:
        if select.select([master], [], [], 0.5)[0]:
            try:
                chunk = os.read(master, 65536).decode()
            except OSError:   # the command has ended: the terminal is closed
                break
            if not chunk:
                break
            err += chunk
        shown = [int(n) for n in re.findall(r"starts, small, motor 2 of 3 +(\d+)/", err)]
        if sent is None and shown and max(shown) >= 1:
            proc.send_signal(signal.SIGINT)
            sent, seen = time.monotonic(), max(shown)
    os.close(master)
    if proc.poll() is None and time.monotonic() - t0 >= 900:
        proc.kill()
    proc.communicate(timeout=60)
    assert sent is not None, "the second motor's first start was not seen: " + err
    assert proc.returncode == 130, err
    assert "Traceback" not in err and "CasADi" not in err
    line = err.strip().splitlines()[-1]
    head = "optdesign optimise: interrupted (motor catalogue: interrupted while optimising motor 'small' (2 of 3) after "
    assert line.startswith(head), line
    finished = int(line[len(head):].split(" of ")[0])
    # every start the progress bar had shown finished before the Ctrl-C is counted, and the
    # Ctrl-C stopped the motor before all its starts had run
    assert seen <= finished < 16, (seen, line)
    doc = json.loads((out / "result.json").read_text())
    assert doc["interrupted"] is True and doc["chosen_motor"] == "small" and doc["not_tried"] == ["large"]
    assert doc["motors"] == {"tiny": "does not fit", "small": "interrupted", "large": "not tried"}
    assert doc["interrupted_motor"] == {"name": "small", "starts_finished": finished, "starts_total": 16, "fits": True}
    assert doc["success"] is True and doc["starts_total"] == finished and len(doc["starts"]) == finished
    assert doc["design"] == doc["catalogue"]["small"]["design"]
    assert doc["message"].startswith(f"INTERRUPTED by Ctrl-C after {finished} of 16 starts")
    assert (f"the best design of its {finished} finished start{'s' if finished > 1 else ''}, with the catalogue's "
            f"outcome, was written to {out}") in line
    # (no limit on the seconds it took to stop and save: the results folder's figures after the
    # Ctrl-C took 21-24 s at load 6 against 10 s quiet; a command that went on with the motor's
    # starts is caught by finished < 16 above, one that hangs by communicate's timeout)
