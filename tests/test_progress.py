"""Progress with the rate and the time left (issue 31): on a terminal a bar, elsewhere (a log
file, a batch job's output) a line every 10 s or 5 % of the total and at the end, from which
the rate and the time left can be read; checked with a clock and a stream written in the test."""
from __future__ import annotations

import io
import os
import subprocess
import sys
from pathlib import Path

from optdesign.cli.progress import duration, progress_bar

ROOT = Path(__file__).resolve().parents[1]


class Clock:
    def __init__(self):
        self.t = 1000.0

    def __call__(self):
        return self.t


class Terminal(io.StringIO):
    def isatty(self):
        return True


def test_log_lines_come_every_ten_seconds_or_five_percent_with_rate_and_time_left():
    out, clock = io.StringIO(), Clock()
    show = progress_bar("cases", log=True, stream=out, clock=clock)
    total = 1000
    show(200, total)                       # resumed: 200 done before, they do not count in the rate
    for done in range(201, 1001):          # 4 cases per second
        clock.t += 0.25
        show(done, total)
    lines = out.getvalue().splitlines()
    assert lines[0] == "cases 200/1000 (20.0 %)"
    # 5 % of 1000 = 50 cases = 12.5 s at 4/s: the 10 s rule comes first (40 cases)
    assert lines[1] == "cases 240/1000 (24.0 %), 4/s, 3 min 10 s left"      # (1000 - 240) / 4 = 190 s
    assert len(lines) == 1 + 800 // 40 and lines[-1] == "cases 1000/1000 (100.0 %), 4/s, 3 min 20 s in all"


def test_a_fast_run_logs_every_five_percent():
    out, clock = io.StringIO(), Clock()
    show = progress_bar("cases", log=True, stream=out, clock=clock)
    show(0, 10_000)
    for done in range(1, 10_001):          # 1000 cases per second: 5 % (500 cases) every 0.5 s
        clock.t += 0.001
        show(done, 10_000)
    lines = out.getvalue().splitlines()
    assert len(lines) == 1 + 20 and lines[1] == "cases 500/10000 (5.0 %), 1e+03/s, 9 s left"


def test_no_lines_off_a_terminal_without_log_and_a_bar_on_one():
    assert progress_bar("starts", stream=io.StringIO()) is None
    term, clock = Terminal(), Clock()
    show = progress_bar("starts", stream=term, clock=clock)
    show(0, 4)
    clock.t += 30
    show(1, 4)
    assert term.getvalue().split("\r")[-1] == "starts    1/4 [########                      ], 0.0333/s, 1 min 30 s left\x1b[K"


def test_durations_read_as_a_person_reads_them():
    assert [duration(s) for s in (0.4, 59.4, 60, 192, 3599, 7380)] == \
        ["0 s", "59 s", "1 min 00 s", "3 min 12 s", "59 min 59 s", "2 h 03 min"]


def test_optdesign_study_logs_its_progress_when_stderr_is_a_file(tmp_path):
    env = {**os.environ, "PYTHONPATH": str(ROOT), "MPLBACKEND": "Agg"}
    done = subprocess.run([sys.executable, "-m", "optdesign", "study", str(ROOT / "problems" / "seed1_jib.toml"),
                           "--mode", "analyse", "--values", "mC=300,400", "--workers", "1", "--no-figures",
                           "--out", str(tmp_path / "s")], capture_output=True, text=True, env=env, timeout=300)
    assert done.returncode == 0, done.stderr
    lines = [line for line in done.stderr.splitlines() if line.startswith("cases ")]
    assert lines[0] == "cases 0/2 (0.0 %)" and lines[-1].startswith("cases 2/2 (100.0 %), ") and " in all" in lines[-1]
