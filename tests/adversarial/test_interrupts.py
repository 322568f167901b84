"""Interrupts and lost helpers: Ctrl-C stops an integration or an optimisation within a second
(CasADi reports it as a failed call, which must not be taken for one), an interrupted optimise
saves the best design of the starts that finished, workers die with a parent killed by SIGKILL
without tracebacks, a lost Dask scheduler is one line with the command that resumes, and
CasADi's own log lines never reach the terminal."""
from __future__ import annotations

import io
import json
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

import optdesign
from optdesign.errors import OptimisationInterrupted, _WithoutCasadiMessages, casadi_messages_hidden
from processes import still_there  # tests/ is on sys.path under pytest

from .util import JIB_DESIGN, PROBLEMS, ROOT

SIM_BAR = PROBLEMS / "sim_bar.toml"
SLIDER = PROBLEMS / "sim_slider_crank.toml"


def start(*args, cwd):
    """``optdesign ARGS`` in a process of its own, with Ctrl-C handled as in a terminal."""
    return subprocess.Popen([sys.executable, "-m", "optdesign", *map(str, args)], cwd=cwd, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env={**os.environ, "MPLBACKEND": "Agg"},
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))


def wait_for_library(proc, name, timeout=60):
    """Until CasADi's plugin ``name`` ('ipopt', 'cvodes') is loaded in ``proc``: its first solve
    or integration is under way (a fixed sleep is too short on a loaded machine)."""
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout and proc.poll() is None:
        if name in Path(f"/proc/{proc.pid}/maps").read_text():
            return
        time.sleep(0.05)


def cpu_seconds(pid) -> float:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")   # utime + stime


def wait_for_starts(proc, workers, timeout=120):
    """Until the starts are being solved (past the imports, the build and the plan of the starts,
    however loaded the machine): the pool's workers exist (besides the process that draws the
    figures, forked before the build), or this process has spent 9 s of CPU (the start-up, build
    and the plan of 2,000 starts take about 4-6 s of it; the 2,000 starts another ~30 s)."""
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout and proc.poll() is None:
        if workers > 1:
            if len(subprocess.run(["pgrep", "-P", str(proc.pid)], capture_output=True, text=True).stdout.split()) > workers:
                return
        elif cpu_seconds(proc.pid) >= 9.0:
            return
        time.sleep(0.1)


def interrupt(proc, after):
    """SIGINT ``after`` seconds from now; (return code, stdout, stderr, seconds from the signal
    to the exit)."""
    time.sleep(after)
    assert proc.poll() is None, "the run ended before it could be interrupted: " + proc.communicate()[1]
    t0 = time.monotonic()
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=120)
    return proc.returncode, out, err, time.monotonic() - t0


pytestmark = pytest.mark.skipif(not Path("/proc/self/maps").exists(), reason="needs /proc")


# --- Ctrl-C inside an integration -------------------------------------------------------------------
@pytest.mark.parametrize("args, library", [
    ([SIM_BAR, "--integrator", "rk4", "--steps", "200000"], "casadi"),        # 20 million RK4 steps
    ([SLIDER, "--tolerance", "1e-13", "--samples", "100000"], "cvodes"),      # CVODES, about 8 s
])
def test_ctrl_c_inside_an_integration_exits_130_within_a_second(tmp_path, args, library):
    proc = start("simulate", *args, cwd=tmp_path)
    wait_for_library(proc, library)
    code, out, err, took = interrupt(proc, 1.0)
    assert code == 130, err
    assert took < 1.0, f"{took:.2f} s from Ctrl-C to the exit"
    assert "optdesign simulate: interrupted (nothing was written: every results folder is as it was)" in err
    assert "Traceback" not in err and "CasADi" not in err and "rhs failed" not in err and out == ""


def test_ctrl_c_in_simulate_from_python_raises_keyboard_interrupt_and_the_next_run_is_whole():
    scene = optdesign.load(SIM_BAR)
    timer = threading.Timer(1.5, lambda: os.kill(os.getpid(), signal.SIGINT))
    timer.start()
    t0 = time.monotonic()
    with pytest.raises(KeyboardInterrupt):
        optdesign.simulate(scene, integrator="rk4", steps=200000)
    assert time.monotonic() - t0 < 2.5
    timer.join()
    # the interrupt is not left pending: the next run is the undisturbed closed form
    # q = q0 + w0 t + T t^2 / (2 I), I = m L^2/3 + J_rotor (problems/sim_bar.toml)
    r = optdesign.simulate(scene)
    inertia = 3.0 * 1.2**2 / 3 + 0.05
    t = r.t
    exact = 0.3 + 2.0 * t + 2.0 * t**2 / (2 * inertia)
    assert r.stop == "t_end" and t[-1] == 5.0 and max(abs(r.columns["q"] - exact)) < 3e-5   # 27 rad at t_end


# --- Ctrl-C in optimise ------------------------------------------------------------------------------
@pytest.mark.parametrize("workers", [1, 2])
def test_ctrl_c_in_optimise_saves_the_best_design_of_the_finished_starts(tmp_path, workers):
    out = tmp_path / "out"
    proc = start("optimise", JIB_DESIGN, "--starts", "2000", "--workers", workers, "--out", out, cwd=tmp_path)
    wait_for_starts(proc, workers)
    code, stdout, err, took = interrupt(proc, 2.0)
    assert code == 130, err
    assert took < 15, f"{took:.2f} s to stop and save"
    assert "Traceback" not in err and "CasADi" not in err and "BrokenPipe" not in err
    line = err.strip().splitlines()[-1]
    assert line.startswith("optdesign optimise: interrupted (after "), line
    finished = int(line.split("after ")[1].split(" of ")[0])
    assert f"of 2000 starts; the best design of those {finished} starts was written to {out}" in line
    result = json.loads((out / "result.json").read_text())
    assert result["interrupted"] is True and result["starts_total"] == finished and result["success"] is True
    assert result["message"].startswith(f"INTERRUPTED by Ctrl-C after {finished} of 2000 starts")
    summary = (out / "summary.txt").read_text()
    assert f"INTERRUPTED (the best of the {finished} starts that finished before Ctrl-C" in summary
    assert not (out / "animation.gif").exists()
    # the saved design is the scene's: its certified objective is the peak drive force of an
    # independent analysis of that design (on a fine grid; the certified peak is at least it)
    scene = optdesign.load(JIB_DESIGN, result["design"])
    sampled = optdesign.analyse(scene, 4001).peaks["drive"]
    assert sampled <= result["objective"] * (1 + 1e-9) and result["objective"] - sampled < 1e-4 * sampled


def test_ctrl_c_in_optimise_from_python_carries_the_best_result():
    scene = optdesign.load(JIB_DESIGN)
    done = []

    def progress(i, n):
        done.append(i)
        if i == 3:
            os.kill(os.getpid(), signal.SIGINT)

    with pytest.raises(OptimisationInterrupted) as caught:
        optdesign.optimise(scene, starts=400, workers=1, progress=progress)
    stop = caught.value
    assert isinstance(stop, KeyboardInterrupt) and stop.total == 400 and stop.finished == 3
    assert done == [0, 1, 2, 3]   # progress(0, N) once the starts are planned, then one per start
    result = stop.result
    assert result.interrupted and result.starts_total == 3 and result.success
    assert result.message.startswith("INTERRUPTED by Ctrl-C after 3 of 400 starts")
    # its objective is the peak drive force of an independent analysis of its design
    sampled = optdesign.analyse(optdesign.load(JIB_DESIGN, result.design), 4001).peaks["drive"]
    assert sampled <= result.objective * (1 + 1e-9) and result.objective - sampled < 1e-4 * sampled
    assert not optdesign.optimise(scene, starts=1, workers=1).interrupted   # nothing left pending


def test_workers_die_with_a_parent_killed_by_sigkill(tmp_path):
    err_path = tmp_path / "stderr.txt"
    with open(err_path, "w") as err:
        proc = subprocess.Popen([sys.executable, "-m", "optdesign", "optimise", str(JIB_DESIGN), "--starts", "2000",
                                 "--workers", "2", "--out", str(tmp_path / "out")], cwd=tmp_path,
                                stdout=subprocess.DEVNULL, stderr=err, start_new_session=True,
                                env={**os.environ, "MPLBACKEND": "Agg"})
        # the children are read the moment the pool's workers are seen, never after a fixed sleep:
        # on a fast machine the 2,000 starts may be over and the pool gone a few seconds later
        wait_for_starts(proc, 2)
        children = subprocess.run(["pgrep", "-P", str(proc.pid)], capture_output=True, text=True).stdout.split()
        assert proc.poll() is None, "the run ended before it could be killed: " + err_path.read_text()
        assert len(children) == 3, children   # the 2 workers and the process ready to draw the figures
        proc.kill()
        proc.wait()
    assert still_there(children, 5) == [], "a worker or the figure process outlived its parent"
    time.sleep(0.5)
    assert err_path.read_text() == ""   # no BrokenPipeError from a worker
    assert not (tmp_path / "out").exists()


# --- a lost Dask scheduler ------------------------------------------------------------------------------
class _LostAfter:
    """An executor whose cluster is lost after ``n`` cases (the Dask executor's interface)."""

    def __init__(self, n):
        from optdesign.study.execute import _Inline

        self.inner, self.n, self.finished = _Inline(), n, 0

    def batch_size(self, remaining):
        return 1

    def submit(self, cases, tasks):
        self.inner.submit(cases, tasks)

    def room(self):
        return self.inner.room()

    def ready(self):
        return False

    def results(self):
        from optdesign.study.results import ClusterLost

        from optdesign.study.blocks import as_outputs

        i = 0
        for cases, outs in self.inner.results():
            for case, out in zip(cases, as_outputs(cases, outs)):   # case by case
                if i == self.n:
                    raise ClusterLost("the Dask scheduler at tcp://127.0.0.1:8786 was lost (FuturesCancelledError)")
                i += 1
                yield [case], [out]

    def stop(self, journal):
        return self.finished

    def close(self):
        pass

    def describe(self):
        return "Dask cluster at tcp://127.0.0.1:8786 (lost)"


def test_a_lost_scheduler_is_one_line_with_the_command_that_resumes(tmp_path, capsys, monkeypatch):
    from optdesign.cli.main import main
    from optdesign.study import execute

    monkeypatch.setattr(execute, "_executor", lambda workers, scheduler, n: _LostAfter(4))
    out = tmp_path / "s"
    argv = ["study", str(PROBLEMS / "seed1_jib.toml"), "--mode", "analyse", "--values", "mC=100,200,300,400,500,600",
            "--scheduler", "tcp://127.0.0.1:8786", "--out", str(out), "--restart"]
    assert main(argv) == 2
    err = capsys.readouterr().err
    progress = [line for line in err.splitlines(keepends=True) if line.startswith("cases ")]   # the progress log
    err = err[sum(map(len, progress)):]
    assert err.count("\n") == 1 and "Traceback" not in err, err
    assert err == (f"optdesign study: error: the Dask scheduler at tcp://127.0.0.1:8786 was lost "
                   f"(FuturesCancelledError): 4 of 6 cases are finished and kept in {out / 'journal.jsonl'}; "
                   f"resume with: optdesign study {PROBLEMS / 'seed1_jib.toml'} --mode analyse --values "
                   f"mC=100,200,300,400,500,600 --scheduler tcp://127.0.0.1:8786 --out {out}\n")
    assert len((out / "journal.jsonl").read_text().splitlines()) == 4
    assert len((out / "cases.csv").read_text().splitlines()) == 1 + 4
    # the command it gives resumes: the two missing cases computed, the four kept
    monkeypatch.setattr(execute, "_executor", lambda workers, scheduler, n: _LostAfter(99))
    assert main(argv[:-1]) == 0
    assert "this run: 2 computed, 4 taken from the journal" in (out / "summary.txt").read_text()


# --- CasADi's own messages ------------------------------------------------------------------------------
@pytest.mark.parametrize("pieces, shown", [
    (["CasADi - ", "2026", "-11-24", " WARNING(\"", "Failed to calculate multipliers", "\") [", "x.cpp:95", "]\n"], ""),
    (["before\n", "CasADi - 2026 WARNING(\"KeyboardInterruptException\") [f.cpp:1]\n", "after\n"], "before\nafter\n"),
    (["CasADi - 2026 WARNING(\"x\") [f.cpp:1]\nnext line\n"], "next line\n"),
    (["a table row\n", "CasADi is a tool\n"], "a table row\nCasADi is a tool\n"),
    (["", "row 1\nrow 2\n"], "row 1\nrow 2\n"),
    (["rhs failed: ", "KeyboardInterrupt", "\n", "x\n"], "x\n"),
    (["the rhs failed: twice\n"], "the rhs failed: twice\n"),
])
def test_casadi_log_lines_are_dropped_and_nothing_else(pieces, shown):
    sink = io.StringIO()
    stream = _WithoutCasadiMessages(sink)
    for p in pieces:
        assert stream.write(p) == len(p)
    assert sink.getvalue() == shown


def test_a_warning_from_ipopt_does_not_reach_the_terminal(capsys):
    import casadi as ca

    x = ca.SX.sym("x")
    # an infeasible problem whose multipliers CasADi cannot compute: it warns on standard error
    solver = ca.nlpsol("s", "ipopt", {"x": x, "f": x**2, "g": ca.vertcat(x, x)},
                       {"ipopt.print_level": 0, "print_time": False, "ipopt.sb": "yes", "error_on_fail": False})
    with casadi_messages_hidden():
        solver(x0=0, lbg=[1, -ca.inf], ubg=[ca.inf, -1])
        print("ours")
    captured = capsys.readouterr()
    assert captured.out == "ours\n" and "CasADi" not in captured.err


@pytest.mark.parametrize("then", [None, SystemError])
def test_a_ctrl_c_swallowed_inside_the_work_is_raised_when_it_ends(then):
    """CasADi's SWIG conversions can swallow the handler's KeyboardInterrupt (taken for 'not
    convertible') or turn it into SystemError ('returned a result with an exception set'): the
    front door's interruptible() raises the Ctrl-C when its work ends instead of losing it."""
    from optdesign.errors import interrupt_pending, interruptible

    with pytest.raises(KeyboardInterrupt):
        with interruptible():
            try:
                os.kill(os.getpid(), signal.SIGINT)   # the handler raises here...
                time.sleep(1.0)
            except KeyboardInterrupt:
                pass                                  # ...and a conversion swallows it
            assert interrupt_pending()
            if then is not None:
                raise then("<built-in function DM_elements> returned a result with an exception set")
    assert not interrupt_pending()
    with interruptible():   # the next run is undisturbed
        pass
