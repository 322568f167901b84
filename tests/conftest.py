"""The suite runs the models on CasADi's virtual machine unless a test asks for compiled code
(tests/test_compiled.py): the disk cache of compiled Functions (optdesign/model/compiled.py)
would otherwise make which path a test takes depend on what earlier runs left in the cache,
and start compilers in the background while the suite runs."""
import os
import signal

os.environ.setdefault("OPTDESIGN_NO_COMPILE", "1")

# A run started in the background of a non-interactive shell inherits SIGINT ignored, and Python
# then never raises KeyboardInterrupt: every Ctrl-C test would fail for the way the suite was
# started (the slow set run that way on 2026-11-28: 11 such failures).  The tests get Python's own
# handler back, as in a terminal.
if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)


# --- the default suite and the slow tests ----------------------------------------------------
# `python -m pytest -q -n auto` (the README's test command, CI's .ci/run) runs the default suite:
# pyproject.toml's addopts leave out the tests marked `slow`.  `python -m pytest -q -n auto -m slow`
# runs those; `-m ""` runs everything.  Whole files whose tests optimise with many starts, run
# studies, kill processes or draw whole results folders are slow; so are the single tests that
# took more than about 8 s in the lead's timed runs (SLOW_TESTS, and tests/slow_tests.txt with
# the measured seconds; each of its files keeps faster tests in the default suite).
from pathlib import Path  # noqa: E402

import pytest  # noqa: E402

SLOW_FILES = {
    "test_optimisation_scenes.py", "test_sqp_resolve.py", "test_power_balance.py", "test_report_html.py",
    "test_usertrial_drivetrain.py", "test_stroke_values.py", "test_compiled.py", "test_study_example.py",
    "test_figure_process.py", "test_study_parallel.py", "test_study_interrupt.py", "test_examples.py",
    "test_level_luffing_design.py", "test_sobol_cache.py", "test_optimise_workers.py",
    "test_optimise_certificates.py", "test_multistart.py", "test_cases_scenes.py",
    "test_study.py", "test_cli_interrupt.py", "test_animation_speed.py", "test_notebook.py",
}
SLOW_FOLDERS = {"library", "adversarial"}   # every shipped library scene's global optimum; processes killed
SLOW_TESTS = {
    "test_draw_command.py::test_preview_where_the_stroke_stops_assembling",
    "test_draw_command.py::test_default_file_is_outside_the_project",
    "test_usertrial.py::test_fourbar_optimum_is_the_best_of_grid_and_polish",
    "test_certified_stroke.py::test_random_four_bars",
    "test_simulate.py::test_stiff_slider_crank_implicit_meets_stated_accuracy",
    "test_drawing.py::test_mechanism_figure_files",
    "test_cases_optimise.py::test_the_next_motor_built_while_the_starts_run_gives_the_same_catalogue",
}


# and the single tests (with their parameters) measured over 8 s in the quick subset's timed run
SLOW_IDS = {
    line.split("\t")[0]
    for line in (Path(__file__).parent / "slow_tests.txt").read_text(encoding="utf-8").splitlines()
    if line.strip() and not line.startswith("#")
}


def pytest_collection_modifyitems(config, items):
    for item in items:
        path = item.path
        key = f"{path.name}::{item.originalname or item.name}"
        if (path.name in SLOW_FILES or path.parent.name in SLOW_FOLDERS or key in SLOW_TESTS
                or f"{path.name}::{item.name}" in SLOW_IDS):
            item.add_marker(pytest.mark.slow)
