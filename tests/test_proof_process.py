"""A motor catalogue's energy proofs sought in a forked process while the command's process
prepares a motor (design/proof_process.py, design/catalogue.py): the catalogue is the one made
motor by motor in one process (the proofs, every motor's result and start plan); a proof
process that dies leaves its verdicts to this one, an error in it is raised here, and a Ctrl-C
keeps the catalogue so far and leaves no process behind.

The scene: tests/test_cases_optimise.py's crank lifting a payload through a gearbox, the ratio
the one design variable, a catalogue of three motors; there "tiny" cannot carry the load at any
ratio (checked against a numpy model and a dense scan of the ratio) and its energy proof finds
it (tests/test_energy_bound.py checks the proof itself)."""
from __future__ import annotations

import multiprocessing
import os
import signal
import time

import pytest
from test_cases_optimise import CATALOGUE, _only_ratio, scene

from optdesign.design import catalogue
from optdesign.design.catalogue import optimise_catalogue
from optdesign.errors import OptimisationInterrupted


@pytest.fixture(scope="module")
def crank():
    return _only_ratio(scene("rms_time(motor_torque)", extra=CATALOGUE), 2.0, 200.0)


@pytest.fixture(scope="module")
def alone(crank):
    """The catalogue made in this process alone (one worker: no proof process)."""
    return optimise_catalogue(crank, starts=3, workers=1)


def _same(a, b):
    assert a.chosen == b.chosen and a.not_tried == b.not_tried and list(a.results) == list(b.results)
    assert {k: p.to_dict() for k, p in a.proofs.items()} == {k: p.to_dict() for k, p in b.proofs.items()}
    for name in a.results:
        x, y = a.results[name], b.results[name]
        assert (x.success, x.status, x.objective, x.design) == (y.success, y.status, y.objective, y.design), name
        assert [(r.status, r.objective, r.iterations, r.start) for r in x.starts] == [
            (r.status, r.objective, r.iterations, r.start) for r in y.starts], name
        plan_x, plan_y = dict(x.start_plan or {}), dict(y.start_plan or {})
        assert plan_x == plan_y, name


def _spy_prove(monkeypatch, log, replace=None):
    """Prover.prove recording the process that runs it (in ``log``, a file: a forked child's
    memory is its own) and doing ``replace(self, motor)`` there instead when given."""
    original = catalogue.Prover.prove
    parent = os.getpid()

    def prove(self, motor):
        with open(log, "a") as f:
            f.write(f"{os.getpid()} {motor.name}\n")
        if replace is not None and os.getpid() != parent:
            return replace(self, motor)
        return original(self, motor)
    monkeypatch.setattr(catalogue.Prover, "prove", prove)


def _provers(log):
    return [line.split() for line in open(log).read().splitlines()] if os.path.exists(log) else []


def test_proofs_in_another_process_give_the_catalogue_of_one_process(crank, alone, tmp_path, monkeypatch):
    assert "tiny" in alone.proofs and alone.chosen == "small"
    log = tmp_path / "provers"
    _spy_prove(monkeypatch, log)
    shared = optimise_catalogue(crank, starts=3, workers=2)
    _same(alone, shared)
    # proved in processes of their own (tiny, then small: not proved), which are gone
    assert [name for _, name in _provers(log)] == ["tiny", "small"]
    assert all(int(pid) != os.getpid() for pid, _ in _provers(log))
    assert multiprocessing.active_children() == []


def test_a_proof_process_that_dies_leaves_its_verdicts_to_this_one(crank, alone, tmp_path, monkeypatch):
    log = tmp_path / "provers"
    _spy_prove(monkeypatch, log, replace=lambda self, motor: os.kill(os.getpid(), signal.SIGKILL))
    shared = optimise_catalogue(crank, starts=3, workers=2)
    _same(alone, shared)
    # tiny, then small, each tried in a process of its own that died, then found here
    assert [name for _, name in _provers(log)] == ["tiny", "tiny", "small", "small"]
    assert [int(pid) == os.getpid() for pid, _ in _provers(log)] == [False, True, False, True]
    assert multiprocessing.active_children() == []


def test_a_proof_process_that_hangs_is_ended_and_its_verdicts_found_here(crank, alone, tmp_path, monkeypatch):
    """A proof process that gives no verdict within proof_process.WAIT (here 1 s; it sleeps for
    a minute) is ended, and its verdict is found in this process: the same catalogue, no hang."""
    from optdesign.design import proof_process

    monkeypatch.setattr(proof_process, "WAIT", 1.0)
    log = tmp_path / "provers"
    _spy_prove(monkeypatch, log, replace=lambda self, motor: time.sleep(60))
    t0 = time.perf_counter()
    shared = optimise_catalogue(crank, starts=3, workers=2)
    assert time.perf_counter() - t0 < 50
    _same(alone, shared)
    assert [name for _, name in _provers(log)] == ["tiny", "tiny", "small", "small"]
    assert [int(pid) == os.getpid() for pid, _ in _provers(log)] == [False, True, False, True]
    for pid, _ in _provers(log)[::2]:   # ended and reaped
        with pytest.raises(ProcessLookupError):
            os.kill(int(pid), 0)
    assert multiprocessing.active_children() == []


def test_an_error_in_the_proof_process_is_raised_here(crank, tmp_path, monkeypatch):
    def fail(self, motor):
        raise ValueError("no proof today")
    _spy_prove(monkeypatch, tmp_path / "provers", replace=fail)
    with pytest.raises(ValueError, match="no proof today"):
        optimise_catalogue(crank, starts=3, workers=2)
    assert multiprocessing.active_children() == []


def test_ctrl_c_while_a_motor_is_proved_in_the_other_process(crank, tmp_path, monkeypatch):
    """Ctrl-C while this process prepares a motor and the other seeks tiny's proof (for a
    minute): the catalogue so far (nothing decided) at once, the proof process ended."""
    log = tmp_path / "provers"
    _spy_prove(monkeypatch, log, replace=lambda self, motor: time.sleep(60))

    def ctrl_c(*args):
        while not os.path.exists(log):   # the child has begun
            time.sleep(0.01)
        os.kill(os.getpid(), signal.SIGINT)
        time.sleep(5)   # (the Ctrl-C is raised here)
    monkeypatch.setattr(catalogue, "prepare_while_proved", ctrl_c)
    t0 = time.perf_counter()
    with pytest.raises(OptimisationInterrupted) as caught:
        optimise_catalogue(crank, starts=3, workers=2)
    assert time.perf_counter() - t0 < 30
    cat = caught.value.catalogue
    assert cat.interrupted == "tiny" and cat.results == {} and cat.best is None and cat.proofs == {}
    assert cat.not_tried == ("small", "large")
    (pid, name), = _provers(log)
    assert name == "tiny" and int(pid) != os.getpid()
    with pytest.raises(ProcessLookupError):   # ended and reaped
        os.kill(int(pid), 0)
    assert multiprocessing.active_children() == []


def test_the_next_motor_prepared_while_a_proof_is_sought_is_used_once(crank, tmp_path, monkeypatch):
    """A motor whose proof looks likely has the next motor prepared while it is sought; guessed
    wrong (tiny not proved here: its starts run) that preparation is the next motor's, made once
    (not again by the thread that would make it during tiny's starts), and the catalogue is the
    one made motor by motor in one process."""
    monkeypatch.setattr(catalogue.Prover, "prove", lambda self, motor: None)
    reference = optimise_catalogue(crank, starts=3, workers=1)
    assert reference.proofs == {} and reference.chosen == "small"
    parent = os.getpid()
    monkeypatch.setattr(catalogue.Prover, "prove", lambda self, motor: time.sleep(1.0 if os.getpid() != parent else 0))
    monkeypatch.setattr(catalogue.Prover, "likely", lambda self, motor: True)
    built, prepare, ahead = [], catalogue.prepare, catalogue.Ahead._run
    monkeypatch.setattr(catalogue, "prepare", lambda sc, *a, **k: built.append(sc.motors[0].name) or prepare(sc, *a, **k))
    monkeypatch.setattr(catalogue.Ahead, "_run", lambda self: built.append(self.scene.motors[0].name) or ahead(self))
    shared = optimise_catalogue(crank, starts=3, workers=2)
    _same(reference, shared)
    assert built == ["small"]
    assert multiprocessing.active_children() == []
