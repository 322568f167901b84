"""Interrupting a study: `optdesign study` run as a subprocess is killed (SIGKILL, no chance to
clean up) or interrupted (SIGINT, as Ctrl-C in a terminal sends it to the whole process group)
after some cases are journalled; run again, it finishes without redoing them, and its
cases.csv is byte-equal to that of an uninterrupted run (rows in case order, floats in repr)."""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

import optdesign
from optdesign.study import Study, grid

ROOT = Path(__file__).resolve().parents[1]
SCENE = ROOT / "problems" / "seed1_jib_design.toml"
N = 10
ARGS = ["--grid", f"mC=300:750:{N}", "--starts", "2", "--chain", "4", "--no-figures"]


def study():
    """The same study as ARGS, through the Python API."""
    return Study(optdesign.load(SCENE), [grid("mC", 300, 750, N)], starts=2, chain=4)


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    folder = tmp_path_factory.mktemp("reference")
    result = study().run(out=folder, workers=1, figures=False)
    assert result.complete and all(r["success"] for r in result.rows)
    return (folder / "cases.csv").read_bytes()


def start(out, workers):
    return subprocess.Popen([sys.executable, "-m", "optdesign", "study", str(SCENE), *ARGS, "--workers", str(workers),
                             "--out", str(out)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            start_new_session=True, cwd=ROOT)


def journalled(out):
    path = Path(out) / "journal.jsonl"
    return path.read_bytes().count(b"\n") if path.exists() else 0


def wait_for_cases(proc, out, n, timeout=60):
    t0 = time.monotonic()
    while journalled(out) < n:
        assert proc.poll() is None, f"the study ended before it could be interrupted: {proc.communicate()}"
        assert time.monotonic() - t0 < timeout, "no cases journalled in time"
        time.sleep(0.01)


def resume(out):
    done = subprocess.run([sys.executable, "-m", "optdesign", "study", str(SCENE), *ARGS, "--workers", "1",
                           "--out", str(out)], capture_output=True, text=True, cwd=ROOT, timeout=120)
    assert done.returncode == 0, done.stderr
    return done


def journal_ids(out):
    return [json.loads(line)["id"] for line in (Path(out) / "journal.jsonl").read_text().splitlines()]


def test_killed_study_resumes_to_the_same_csv(tmp_path, reference):
    proc = start(tmp_path, workers=1)
    wait_for_cases(proc, tmp_path, 3)
    os.killpg(proc.pid, signal.SIGKILL)
    proc.communicate()
    before = journalled(tmp_path)
    assert 3 <= before < N
    done = resume(tmp_path)
    assert f"{N - before} computed, {before} taken from the journal" in done.stdout
    ids = journal_ids(tmp_path)
    assert len(ids) == len(set(ids)) == N             # nothing computed twice
    assert (tmp_path / "cases.csv").read_bytes() == reference


@pytest.mark.parametrize("workers", [1, 2])
def test_ctrl_c_stops_cleanly_says_how_to_resume_and_resumes(tmp_path, reference, workers):
    """In process (workers=1) Ctrl-C arrives while IPOPT runs: CasADi would turn an exception
    raised there into a failed solve, so the study must finish the running case instead and
    never journal a solve cut short; with a pool the parent stops and keeps running cases."""
    proc = start(tmp_path, workers=workers)
    wait_for_cases(proc, tmp_path, 2)
    os.killpg(proc.pid, signal.SIGINT)                # what a terminal does on Ctrl-C
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    assert "interrupted" in err and "again with the same folder to resume" in err
    assert "Traceback" not in err
    before = journalled(tmp_path)
    assert 2 <= before < N
    # every journal line is whole, and the partial cases.csv holds exactly the finished cases
    assert len(journal_ids(tmp_path)) == before
    statuses = [json.loads(line)["row"]["status"] for line in (tmp_path / "journal.jsonl").read_text().splitlines()]
    assert set(statuses) == {"Solve_Succeeded"}, statuses
    partial = (tmp_path / "cases.csv").read_text().splitlines()
    assert len(partial) == before + 1
    assert set(partial[1:]) <= set(reference.decode().splitlines()[1:])
    done = resume(tmp_path)
    assert f"{N - before} computed, {before} taken from the journal" in done.stdout
    assert (tmp_path / "cases.csv").read_bytes() == reference
