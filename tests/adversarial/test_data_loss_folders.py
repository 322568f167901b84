"""Data loss, result folders: every results folder (optimise --out, analyse --plot, simulate
--plot, a study's derived files) is replaced as a whole or left as it was, and an interrupted
command says truthfully which.  (Real kills at random moments: test_fault_injection.py.)"""
from __future__ import annotations

import errno
import os
import signal
import time
from pathlib import Path

import pytest

import optdesign
from optdesign.cli.main import main
from optdesign.errors import OptdesignError
from optdesign.report import folder as folder_module
from optdesign.report.folder import inspect, replace_folder
from optdesign.study import Study, pareto, values
from optdesign.study.journal import JOURNAL

from .util import JIB, JIB_DESIGN, PROBLEMS, SIM, snapshot


def writer(files):
    def write(tmp):
        for name, text in files.items():
            (tmp / name).write_text(text)
        return [tmp / name for name in files]
    return write


def siblings(folder):
    return sorted(p.name for p in Path(folder).parent.iterdir() if p.name.startswith(f".{Path(folder).name}."))


# --- the swap itself -----------------------------------------------------------------------------
def test_a_folder_is_replaced_as_a_whole_and_other_files_are_carried_as_the_same_file(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (out / "a.png").write_text("old a")
    (out / "b.png").write_text("old b")          # produced before, not this time: dropped
    (out / "notes.txt").write_text("mine")
    inode = (out / "notes.txt").stat().st_ino
    paths = replace_folder(out, writer({"a.png": "new a"}), {"a.png", "b.png"})
    assert paths == [out / "a.png"]
    assert snapshot(out) == snapshot_of({"a.png": "new a", "notes.txt": "mine"}, tmp_path)
    assert (out / "notes.txt").stat().st_ino == inode
    assert siblings(out) == []                    # no temporary left beside it
    assert out in folder_module.replaced


def snapshot_of(files, tmp_path):
    ref = tmp_path / "reference"
    ref.mkdir(exist_ok=True)
    for name, text in files.items():
        (ref / name).write_text(text)
    return snapshot(ref)


@pytest.mark.parametrize("exchange", [True, False], ids=["renameat2", "two-renames"])
def test_a_failure_while_writing_leaves_the_old_folder_whole_and_no_temporaries(tmp_path, monkeypatch, exchange):
    if not exchange:
        monkeypatch.setattr(folder_module, "_exchange", lambda a, b: False)
    out = tmp_path / "out"
    replace_folder(out, writer({"a.png": "1", "b.png": "1"}), {"a.png", "b.png"})
    before = snapshot(out)

    def broken(tmp):
        (tmp / "a.png").write_text("2")
        raise KeyboardInterrupt               # Ctrl-C (or any failure) in the middle of writing
    with pytest.raises(KeyboardInterrupt):
        replace_folder(out, broken, {"a.png", "b.png"})
    assert snapshot(out) == before and siblings(out) == []
    replace_folder(out, writer({"a.png": "3"}), {"a.png", "b.png"})
    assert snapshot(out) == snapshot_of({"a.png": "3"}, tmp_path) and siblings(out) == []


def test_ctrl_c_during_the_swap_is_held_until_the_new_folder_is_in(tmp_path, monkeypatch):
    out = tmp_path / "out"
    replace_folder(out, writer({"a.png": "old"}), {"a.png"})
    real_swap = folder_module._swap

    def swap(tmp, folder):
        os.kill(os.getpid(), signal.SIGINT)      # arrives during the swap
        time.sleep(0.01)
        real_swap(tmp, folder)

    monkeypatch.setattr(folder_module, "_swap", swap)
    folder_module.replaced.clear()
    with pytest.raises(KeyboardInterrupt):
        replace_folder(out, writer({"a.png": "new"}), {"a.png"})
    assert (out / "a.png").read_text() == "new" and folder_module.replaced == [out]
    assert siblings(out) == []


def test_temporaries_of_killed_runs_are_cleaned_and_a_folder_renamed_aside_comes_back(tmp_path):
    dead = 2 ** 22 + 12345                      # above pid_max on most systems: a dead process
    out = tmp_path / "out"
    aside = tmp_path / f".out.old-{dead}-abc"     # killed between the two renames: no folder at out
    aside.mkdir()
    (aside / "a.png").write_text("old whole")
    half = tmp_path / f".out.tmp-{dead}-xyz"
    half.mkdir()
    (half / "a.png").write_text("half new")
    alive = tmp_path / f".out.tmp-{os.getppid()}-live"   # another run at work: not touched
    alive.mkdir()
    assert inspect(out, {"a.png"}) == []
    replace_folder(out, writer({"b.png": "new"}), {"a.png", "b.png"})
    assert snapshot(out) == snapshot_of({"b.png": "new"}, tmp_path)   # old restored, then replaced whole
    assert siblings(out) == [alive.name]


@pytest.mark.parametrize("make, fragment", [
    (lambda p: p.write_text("x"), "is a file, not a folder"),
    (lambda p: (p.mkdir(), (p / "sub").mkdir()), "holds sub/, which optdesign did not write"),
    (lambda p: (p.mkdir(), (p / "link").symlink_to("/")), "holds link, which optdesign did not write"),
])
def test_what_is_not_a_results_folder_is_left_as_it_was(tmp_path, make, fragment):
    out = tmp_path / "out"
    make(out)
    before = snapshot(out) if out.is_dir() else out.read_text()
    with pytest.raises(OptdesignError, match=fragment):
        replace_folder(out, writer({"a.png": "new"}), {"a.png"}, label="--out")
    assert (snapshot(out) if out.is_dir() else out.read_text()) == before
    assert siblings(out) == []


def test_the_folder_holding_the_current_directory_is_refused(tmp_path, monkeypatch):
    (tmp_path / "out" / "here").mkdir(parents=True)
    monkeypatch.chdir(tmp_path / "out" / "here")
    with pytest.raises(OptdesignError, match="holds the current directory"):
        replace_folder(tmp_path / "out", writer({"a.png": "new"}), {"a.png"})
    with pytest.raises(OptdesignError, match="holds the current directory"):
        replace_folder(".", writer({"a.png": "new"}), {"a.png"})


def test_a_folder_given_through_a_link_replaces_its_target(tmp_path):
    (tmp_path / "real").mkdir()
    (tmp_path / "link").symlink_to(tmp_path / "real")
    replace_folder(tmp_path / "link", writer({"a.png": "new"}), {"a.png"})
    assert (tmp_path / "link").is_symlink() and (tmp_path / "real" / "a.png").read_text() == "new"


# --- the commands ----------------------------------------------------------------------------------
def test_analyse_plot_replaces_its_folder_and_a_stale_figure_goes(tmp_path):
    out = tmp_path / "plots"
    out.mkdir()
    (out / "constraints.png").write_bytes(b"stale")       # the slider-crank has no per-sample constraint
    (out / "readme.txt").write_text("kept")
    assert main(["analyse", str(PROBLEMS / "seed1_slider_crank.toml"), "--plot", str(out)]) == 0
    assert sorted(p.name for p in out.iterdir()) == ["drive.png", "readme.txt", "reduced_inertia.png"]
    assert siblings(out) == []


def test_simulate_plot_replaces_its_folder(tmp_path):
    out = tmp_path / "plots"
    assert main(["simulate", str(SIM), "--plot", str(out)]) == 0
    assert sorted(p.name for p in out.iterdir()) == ["drive_load.png", "q.png", "q_rate.png"]


@pytest.mark.parametrize("command", [["analyse", str(JIB), "--plot"], ["simulate", str(SIM), "--plot"],
                                     ["optimise", str(JIB_DESIGN), "--starts", "1", "--workers", "1", "--out"]])
def test_an_output_folder_that_cannot_be_written_is_refused_before_any_work(tmp_path, capsys, command):
    (tmp_path / "file").write_text("x")
    for target, fragment in ((tmp_path / "file", "is a file, not a folder"),
                             (tmp_path / "file" / "below", f"{tmp_path / 'file'} is a file, not a folder"),
                             (tmp_path, "holds sub/, which optdesign did not write")):
        (tmp_path / "sub").mkdir(exist_ok=True)
        t0 = time.perf_counter()
        assert main([*command, str(target)]) == 2
        err = capsys.readouterr().err
        assert f"{command[-1]} {target}: {fragment}" in err, err
        assert time.perf_counter() - t0 < 1.0            # refused before the scene is even loaded
    assert (tmp_path / "file").read_text() == "x"


@pytest.mark.skipif(not Path("/sys/kernel").is_dir(), reason="no sysfs (a filesystem nobody may create folders in)")
def test_an_output_folder_on_a_read_only_filesystem_is_a_clear_error(capsys):
    code = main(["analyse", str(JIB), "--plot", "/sys/optdesign-test"])
    err = capsys.readouterr().err
    assert code == 2 and "--plot /sys/optdesign-test" in err
    assert "Traceback" not in err


def test_ctrl_c_after_the_folder_is_written_says_so(tmp_path, monkeypatch, capsys):
    from optdesign.cli import analyse as cli_analyse

    def interrupted(*a):
        raise KeyboardInterrupt

    monkeypatch.setattr(cli_analyse, "emit", interrupted)      # Ctrl-C while the table is printed
    assert main(["analyse", str(JIB), "--plot", str(tmp_path / "p")]) == 130
    err = capsys.readouterr().err
    assert f"interrupted (the new results were written before the interrupt, each folder replaced as a whole: " \
           f"{tmp_path / 'p'})" in err
    assert (tmp_path / "p" / "drive.png").exists()


def test_ctrl_c_before_anything_is_written_says_so(tmp_path, monkeypatch, capsys):
    from optdesign.cli import analyse as cli_analyse

    def interrupted(*a, **k):
        raise KeyboardInterrupt

    monkeypatch.setattr(cli_analyse, "scene_with_design", interrupted)
    assert main(["analyse", str(JIB), "--plot", str(tmp_path / "p")]) == 130
    assert "interrupted (nothing was written: every results folder is as it was)" in capsys.readouterr().err
    assert not (tmp_path / "p").exists()


# --- the study's folder ----------------------------------------------------------------------------
def test_a_study_swaps_its_derived_files_and_keeps_its_journal_as_the_same_file(tmp_path):
    scene = optdesign.load(JIB_DESIGN)
    front = Study(scene, [pareto("cylinder length ratio", [1.5, 1.6])], starts=1)
    front.run(out=tmp_path, workers=1)
    assert {"pareto.csv", "pareto.png", "study.png"} <= {p.name for p in tmp_path.iterdir()}
    (tmp_path / "mine.png").write_bytes(b"a script's figure")
    inode = (tmp_path / JOURNAL).stat().st_ino
    plain = Study(scene, [values("mC", [300.0])], starts=1)      # another study, no Pareto axis
    result = plain.run(out=tmp_path, workers=1, figures=False)
    names = sorted(p.name for p in tmp_path.iterdir())
    assert names == ["cases.csv", "cases.parquet", JOURNAL, "mine.png", "study.json", "summary.txt"]   # stale figures gone
    assert (tmp_path / JOURNAL).stat().st_ino == inode
    assert len((tmp_path / JOURNAL).read_text().splitlines()) == 3                    # 2 + 1 cases, all kept
    assert result.paths == [tmp_path / n for n in ("study.json", "cases.csv", "cases.parquet", "summary.txt")]
    assert siblings(tmp_path) == []


def test_a_study_on_a_filesystem_without_hard_links_writes_in_place_and_says_so(tmp_path, monkeypatch):
    def no_link(*a, **k):
        raise OSError(errno.EPERM, "Operation not permitted")

    monkeypatch.setattr(folder_module.os, "link", no_link)
    scene = optdesign.load(JIB)
    study = Study(scene, [values("mC", [300.0, 400.0])], mode="analyse")
    study.run(out=tmp_path, workers=1, figures=False)
    result = study.run(out=tmp_path, workers=1, figures=False)
    assert (result.computed, result.reused) == (0, 2)
    assert "no hard links on this filesystem" in (tmp_path / "summary.txt").read_text()


def test_a_full_disk_at_the_end_of_a_study_keeps_the_old_folder_and_every_finished_case(tmp_path, monkeypatch):
    from optdesign.study import table as study_table

    scene = optdesign.load(JIB)
    Study(scene, [values("mC", [300.0])], mode="analyse").run(out=tmp_path, workers=1, figures=False)
    before = snapshot(tmp_path)

    def full(*a, **k):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(study_table, "write_tables", full)
    study = Study(scene, [values("mC", [300.0, 400.0, 500.0])], mode="analyse")
    with pytest.raises(OptdesignError, match=r"study folder .*: cannot write the results \(No space left on device\); "
                                             r"the folder was left as it was; the 3 finished cases are kept in "):
        study.run(out=tmp_path, workers=1, figures=False)
    after = snapshot(tmp_path)
    assert {k: v for k, v in after.items() if k != JOURNAL} == {k: v for k, v in before.items() if k != JOURNAL}
    assert len((tmp_path / JOURNAL).read_text().splitlines()) == 3 and siblings(tmp_path) == []
    monkeypatch.undo()
    assert study.run(out=tmp_path, workers=1, figures=False).reused == 3
