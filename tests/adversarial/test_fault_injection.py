"""Fault injection: `optdesign optimise` and `optdesign study` killed (SIGKILL, no chance to clean
up) or interrupted (SIGINT, Ctrl-C) at random moments, several times over one folder.  After every
kill the folder is the old whole folder or a new whole one, never a mix; a study's journal never
loses a finished case; finished, the study's cases.csv is byte-equal to an uninterrupted run's.

The moments are drawn (seeded) over the length of a reference run measured in the same test, so
they fall in the imports, the solves, the writing and the swap alike on a fast or a loaded
machine.  A few kills each keep the test near 20 s."""
from __future__ import annotations

import json
import os
import random
import signal
import subprocess
import sys
import time
from optdesign.report.design import FILES   # every file of an optimise folder

from .util import JIB_DESIGN, ROOT, snapshot

DERIVED = ("cases.csv", "cases.parquet", "study.json", "summary.txt")
KILLS = 3


def start(args, cwd):
    env = {**os.environ, "MPLBACKEND": "Agg", "PYTHONPATH": str(ROOT)}
    return subprocess.Popen([sys.executable, "-m", "optdesign", *map(str, args)], cwd=cwd, env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, start_new_session=True)


def timed(args, cwd):
    t0 = time.monotonic()
    proc = start(args, cwd)
    _, err = proc.communicate(timeout=300)
    assert proc.returncode == 0, err
    return time.monotonic() - t0


def python_start():
    """Seconds for the interpreter alone to start: a SIGINT before that lands in Python's own
    start-up (its site module), where no program can catch it; the kills come later."""
    t0 = time.monotonic()
    subprocess.run([sys.executable, "-c", "pass"], check=True)
    return time.monotonic() - t0


def kill_at(proc, delay, sig):
    time.sleep(delay)
    if proc.poll() is None:
        os.killpg(proc.pid, sig)
    _, err = proc.communicate(timeout=120)
    assert "Traceback" not in err, err
    return proc.returncode


def siblings(folder):
    return [p.name for p in folder.parent.iterdir() if p.name.startswith(f".{folder.name}.")]


# --- optimise ---------------------------------------------------------------------------------------
def optimise_args(out, mC):
    return ["optimise", JIB_DESIGN, "--starts", "2", "--workers", "1", "--set", f"mC={mC}", "--out", out]


def is_new_whole(folder, design):
    """Every file of a complete optimise folder, and they belong together (the same optimum)."""
    names = {p.name for p in folder.iterdir()}
    # FILES lists every file an optimise folder can hold; a scene without load cases, a motor
    # or a cylinder has no cases.png, torque_speed.png or cylinder.png
    if not names <= set(FILES) or not names >= set(FILES) - {"cases.png", "torque_speed.png", "cylinder.png"}:
        return False
    result = json.loads((folder / "result.json").read_text())
    summary = (folder / "summary.txt").read_text()
    return result["design"] == design and all(f"{k} = {v:.9g}" in summary for k, v in design.items())


def test_optimise_killed_at_random_moments_leaves_the_old_or_the_new_whole_folder(tmp_path):
    rng = random.Random(1515)
    out, ref = tmp_path / "out", tmp_path / "ref"
    timed(optimise_args(out, 400), tmp_path)
    duration = timed(optimise_args(ref, 600), tmp_path)
    design = json.loads((ref / "result.json").read_text())["design"]
    old = snapshot(out)
    outcomes, least = [], 3 * python_start()
    for k in range(KILLS):
        sig = (signal.SIGKILL, signal.SIGINT)[k % 2]
        delay = max(least, rng.uniform(0.3, 1.05) * duration)
        code = kill_at(start(optimise_args(out, 600), tmp_path), delay, sig)
        now = snapshot(out)
        if now == old:
            outcomes.append("old")
        else:
            assert is_new_whole(out, design), (sig, code, sorted(now))
            outcomes.append("new")
            old = now
        if sig == signal.SIGINT and outcomes[-1] == "old":
            assert code == 130
    # whatever was left beside it by a kill is cleaned by the next run
    timed(optimise_args(out, 600), tmp_path)
    assert is_new_whole(out, design) and siblings(out) == []
    print("optimise outcomes:", outcomes)


# --- study ------------------------------------------------------------------------------------------
def study_args(out):
    return ["study", JIB_DESIGN, "--grid", "mC=300:750:8", "--starts", "1", "--chain", "4", "--workers", "1",
            "--no-figures", "--out", out]


def journal_ids(folder):
    """The ids of the journal's records; every line but a torn last one must be a record."""
    path = folder / "journal.jsonl"
    if not path.exists():
        return set()
    data = path.read_bytes()
    lines = data.split(b"\n")
    ids = [json.loads(line)["id"] for line in lines[:-1]]
    assert len(ids) == len(set(ids)), "a finished case was journalled twice"
    return set(ids)


def derived(folder):
    return {n: (folder / n).read_bytes() for n in DERIVED if (folder / n).exists()}


def test_study_killed_at_random_moments_never_loses_a_finished_case(tmp_path):
    rng = random.Random(1516)
    out, ref = tmp_path / "out", tmp_path / "ref"
    duration = timed(study_args(ref), tmp_path)
    finished, before, least = set(), {}, 3 * python_start()
    for k in range(KILLS):
        sig = (signal.SIGKILL, signal.SIGINT, signal.SIGKILL)[k % 3]
        delay = max(least, rng.uniform(0.3, 1.0) * duration)
        code = kill_at(start(study_args(out), tmp_path), delay, sig)
        ids = journal_ids(out)
        assert finished <= ids, f"finished cases lost: {finished - ids}"
        finished = ids
        now = derived(out)
        if now != before:                                  # a new whole set: all three, consistent
            assert sorted(now) == sorted(DERIVED), (sig, code, sorted(now))
            rows = now["cases.csv"].decode().splitlines()[1:]
            assert {r.split(",")[1] for r in rows} <= ids
            assert f"{len(rows)} finished" in now["summary.txt"].decode()
            before = now
    done = start(study_args(out), tmp_path)
    _, err = done.communicate(timeout=300)
    assert done.returncode == 0, err
    assert journal_ids(out) >= finished and len(journal_ids(out)) == 8
    assert (out / "cases.csv").read_bytes() == (ref / "cases.csv").read_bytes()
    assert siblings(out) == []
