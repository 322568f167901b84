"""Data loss, single output files (issue 32): `analyse --csv`, `draw --out/--dxf/--svg` and
`animate --out` write through report/files.py.  A regular file or a new path is replaced
atomically; a symbolic link stays and its target gets the file; a FIFO, a character device and
this process's own open files (/dev/stdout, /dev/fd/N) are written into, never renamed over; `-`
is standard output; everything else is a one-line error naming the path, before any work.

Device nodes are made with mknod in a temporary folder (root only: CI runs as root), never the
system's.  Root ignores permission bits, so a read-only folder is simulated by the error the
kernel gives on a read-only file system (EROFS) and a full disk by ENOSPC from os.write, or by a
node with the numbers of /dev/full (char 1 7)."""
from __future__ import annotations

import errno
import os
import socket
import stat
import subprocess
import sys
import threading

import pytest

from optdesign.cli.main import main
from optdesign.errors import OptdesignError, OutputError
from optdesign.report import files
from optdesign.report.files import write_file

from .util import JIB, ROOT, ROOT_USER

root_only = pytest.mark.skipif(not ROOT_USER, reason="mknod needs root (CI runs as root)")
ARGS = ["--samples", "20", "-q"]


def node(path, kind, major=1, minor=3):
    os.mknod(path, kind | 0o666, os.makedev(major, minor))
    return path


def same_node(path, st) -> bool:
    now = os.lstat(path)
    return (now.st_ino, now.st_mode, now.st_rdev) == (st.st_ino, st.st_mode, st.st_rdev)


class Reader(threading.Thread):
    """Reads a FIFO to its end, as `cat FIFO` would."""

    def __init__(self, path):
        super().__init__(daemon=True)
        self.path, self.data = path, None
        self.start()

    def run(self):
        with open(self.path, "rb") as fh:
            self.data = fh.read()

    def result(self):
        self.join(30)
        assert not self.is_alive()
        return self.data


@pytest.fixture
def reference_csv(tmp_path_factory):
    """The CSV of the command written to a plain new file: what every other target must get."""
    path = tmp_path_factory.mktemp("ref") / "ref.csv"
    assert main(["analyse", str(JIB), "--csv", str(path), *ARGS]) == 0
    return path.read_bytes()


# --- the writer itself -----------------------------------------------------------------------------

def test_a_regular_file_keeps_its_permissions_and_leaves_no_temporary(tmp_path):
    f = tmp_path / "a.csv"
    f.write_text("old")
    os.chmod(f, 0o600)
    write_file(f, "new")
    assert f.read_text() == "new" and stat.S_IMODE(os.stat(f).st_mode) == 0o600
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.csv"]


@pytest.mark.parametrize("chain", [1, 2])
def test_a_link_stays_a_link_and_its_target_gets_the_file(tmp_path, chain):
    real = tmp_path / "real.csv"
    real.write_text("old")
    link = real
    for k in range(chain):
        (tmp_path / f"link{k}").symlink_to(link.name)
        link = tmp_path / f"link{k}"
    write_file(link, "new")
    assert link.is_symlink() and os.readlink(link) == (f"link{chain - 2}" if chain > 1 else "real.csv")
    assert real.read_text() == "new" and not real.is_symlink()


def test_a_dangling_link_stays_and_its_target_is_made(tmp_path):
    (tmp_path / "link").symlink_to("sub/made.csv")
    (tmp_path / "sub").mkdir()
    write_file(tmp_path / "link", "text")
    assert (tmp_path / "link").is_symlink() and (tmp_path / "sub" / "made.csv").read_text() == "text"


def test_a_fifo_is_written_into_and_stays_a_fifo(tmp_path):
    fifo = tmp_path / "pipe.csv"
    os.mkfifo(fifo)
    reader = Reader(fifo)
    write_file(fifo, ["a,b\n", b"1,2\n" * 50_000])           # more than a pipe holds: the writer waits on the reader
    assert reader.result() == b"a,b\n" + b"1,2\n" * 50_000
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode)


def test_a_fifo_nobody_reads_is_an_error_after_a_bounded_wait(tmp_path, monkeypatch):
    fifo = tmp_path / "pipe.csv"
    os.mkfifo(fifo)
    monkeypatch.setattr(files, "READER_WAIT", 0.2)
    with pytest.raises(OutputError, match=r"^--csv .*pipe.csv: is a FIFO that no reader opened within 0.2 s: "
                                          r"start the reader first"):
        write_file(fifo, "x", "--csv")
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode)


def test_a_fifo_whose_reader_stops_is_an_incomplete_output(tmp_path):
    fifo = tmp_path / "pipe.csv"
    os.mkfifo(fifo)

    def read_one_byte():
        with open(fifo, "rb") as fh:
            fh.read(1)
    t = threading.Thread(target=read_one_byte, daemon=True)
    t.start()
    with pytest.raises(OutputError, match=r"pipe.csv: the reader closed it before the end: the output is incomplete"):
        write_file(fifo, b"x" * 10_000_000)
    t.join(5)


@root_only
def test_a_character_device_is_written_into_and_survives(tmp_path):
    null = node(tmp_path / "null", stat.S_IFCHR, 1, 3)
    link = tmp_path / "link.csv"
    link.symlink_to("null")
    before = os.lstat(null), os.lstat(link)
    assert write_file(null, "a" * 100_000) == null and write_file(link, "b") == link
    assert same_node(null, before[0]) and same_node(link, before[1]) and os.readlink(link) == "null"


@root_only
def test_a_full_device_is_an_error_and_survives(tmp_path):
    full = node(tmp_path / "full", stat.S_IFCHR, 1, 7)
    before = os.lstat(full)
    with pytest.raises(OutputError, match=r"^--csv .*full: no space left on the device: the output is incomplete; "
                                          r"free some space or choose another disk$"):
        write_file(full, "x", "--csv")
    assert same_node(full, before)


@root_only
def test_a_block_device_is_refused_and_survives(tmp_path):
    disk = node(tmp_path / "disk", stat.S_IFBLK, 7, 0)
    before = os.lstat(disk)
    with pytest.raises(OutputError, match=r"disk: is a block device \(a disk\): results go to a regular file"):
        write_file(disk, "x")
    assert same_node(disk, before)


def test_a_socket_is_refused(tmp_path):
    path = tmp_path / "s"
    with socket.socket(socket.AF_UNIX) as s:
        s.bind(str(path))
        with pytest.raises(OutputError, match=r"s: is a socket"):
            write_file(path, "x")
        assert stat.S_ISSOCK(os.lstat(path).st_mode)


@pytest.mark.parametrize("path", ["-", "/dev/stdout", "/proc/self/fd/1", "/dev/fd/1"])
def test_standard_output(path, capsysbinary):
    assert str(write_file(path, ["a,b\n", b"1,2\n"])) == "standard output"
    assert capsysbinary.readouterr().out == b"a,b\n1,2\n"


def test_an_open_file_of_ours_is_written_at_its_place_not_replaced(tmp_path):
    f = tmp_path / "log"
    with open(f, "wb") as fh:
        fh.write(b"head\n")
        fh.flush()
        before = os.stat(f).st_ino
        write_file(f"/dev/fd/{fh.fileno()}", "csv\n")
        fh.write(b"tail\n")
    assert f.read_bytes() == b"head\ncsv\ntail\n" and os.stat(f).st_ino == before


@pytest.mark.parametrize("where, message", [
    ("folder", r"--csv {tmp}/folder: is a folder: give the name of a file \(e.g. {tmp}/folder/NAME\)"),
    ("afile/x.csv", r"--csv {tmp}/afile/x.csv: {tmp}/afile is a file, not a folder: choose a path in a folder"),
    ("afile/sub/x.csv", r"--csv {tmp}/afile/sub/x.csv: {tmp}/afile is a file, not a folder"),
    ("/proc/x.csv", r"--csv /proc/x.csv: is in /proc, the kernel's own files, not a place for results: choose a "
                    r"path in an ordinary folder \(or - for standard output\)"),
    ("/proc/sys/vm/x.csv", r"--csv /proc/sys/vm/x.csv: is in /proc"),
    ("/sys/x.csv", r"--csv /sys/x.csv: is in /sys"),
])
def test_paths_that_cannot_hold_a_file_are_named(tmp_path, where, message):
    (tmp_path / "folder").mkdir()
    (tmp_path / "afile").write_text("x")
    path = where if where.startswith("/") else f"{tmp_path}/{where}"
    with pytest.raises(OutputError, match="^" + message.format(tmp=tmp_path)):
        write_file(path, "x", "--csv")
    assert (tmp_path / "afile").read_text() == "x"


def failing_write(code):
    real = os.write

    def write(fd, data):
        if fd > 2:
            raise OSError(code, os.strerror(code))
        return real(fd, data)
    return write


def test_a_full_disk_leaves_the_old_file_and_no_temporary(tmp_path, monkeypatch):
    f = tmp_path / "a.csv"
    f.write_text("old")
    monkeypatch.setattr(os, "write", failing_write(errno.ENOSPC))
    with pytest.raises(OutputError, match=r"^--csv .*a.csv: no space left on the device: nothing was written \(a "
                                          r"file there is as it was\); free some space or choose another disk$"):
        write_file(f, "new" * 1000, "--csv")
    monkeypatch.undo()
    assert f.read_text() == "old" and sorted(p.name for p in tmp_path.iterdir()) == ["a.csv"]


def test_a_read_only_folder_is_named(tmp_path, monkeypatch):
    # root writes anywhere but on a read-only file system: the error such a folder gives
    def read_only(*a, **k):
        raise OSError(errno.EROFS, os.strerror(errno.EROFS))
    monkeypatch.setattr(files.tempfile, "mkstemp", read_only)
    with pytest.raises(OutputError, match=rf"^--csv {tmp_path}/a.csv: writing in {tmp_path} is on a read-only file "
                                          r"system \(Read-only file system\): choose a folder you can write to$"):
        write_file(tmp_path / "a.csv", "x", "--csv")


@pytest.mark.skipif(ROOT_USER, reason="root writes into a folder without write permission")
def test_a_folder_without_write_permission_is_named(tmp_path):
    ro = tmp_path / "ro"
    ro.mkdir(mode=0o500)
    with pytest.raises(OutputError, match=r"not allowed for this user"):
        write_file(ro / "a.csv", "x", "--csv")


# --- the commands ----------------------------------------------------------------------------------

def test_analyse_csv_through_a_link(tmp_path, reference_csv):
    (tmp_path / "real.csv").write_text("old")
    (tmp_path / "link.csv").symlink_to("real.csv")
    assert main(["analyse", str(JIB), "--csv", str(tmp_path / "link.csv"), *ARGS]) == 0
    assert (tmp_path / "link.csv").is_symlink() and (tmp_path / "real.csv").read_bytes() == reference_csv


def test_analyse_csv_into_a_fifo(tmp_path, reference_csv):
    fifo = tmp_path / "pipe.csv"
    os.mkfifo(fifo)
    reader = Reader(fifo)
    assert main(["analyse", str(JIB), "--csv", str(fifo), *ARGS]) == 0
    assert reader.result() == reference_csv and stat.S_ISFIFO(os.lstat(fifo).st_mode)


@pytest.mark.parametrize("path", ["-", "/dev/stdout"])
def test_analyse_csv_to_standard_output_and_the_summary_to_standard_error(path, reference_csv, capsysbinary):
    assert main(["analyse", str(JIB), "--csv", path, "--samples", "20"]) == 0
    out, err = capsysbinary.readouterr()
    assert out == reference_csv
    assert b"wrote standard output\n" in err and b"peak |drive| = " in err


def test_analyse_csv_to_standard_output_quietly(reference_csv, capsysbinary):
    assert main(["analyse", str(JIB), "--csv", "-", *ARGS]) == 0
    assert capsysbinary.readouterr() == (reference_csv, b"")


def test_analyse_csv_to_our_stdout_redirected_to_a_file_does_not_replace_it(tmp_path):
    (tmp_path / "stdout").symlink_to("/proc/self/fd/1")     # /dev/stdout's own link, in a folder of ours
    out = tmp_path / "out.txt"
    with open(out, "wb") as fh:
        done = subprocess.run([sys.executable, "-m", "optdesign", "analyse", str(JIB), "--samples", "20", "--csv",
                               str(tmp_path / "stdout")], stdout=fh, stderr=subprocess.PIPE, cwd=ROOT, timeout=120)
    assert done.returncode == 0, done.stderr
    assert (tmp_path / "stdout").is_symlink() and os.readlink(tmp_path / "stdout") == "/proc/self/fd/1"
    lines = out.read_text().splitlines()
    assert lines[0].startswith("theta [-],q [m],") and len(lines) == 21          # the CSV alone
    assert b"peak |drive| = " in done.stderr


@pytest.mark.parametrize("where, message", [
    ("folder", "--csv {tmp}/folder: is a folder"),
    ("afile/x.csv", "--csv {tmp}/afile/x.csv: {tmp}/afile is a file, not a folder"),
    ("/proc/x.csv", "--csv /proc/x.csv: is in /proc"),
])
def test_analyse_csv_that_cannot_be_written_is_an_error_before_the_work(tmp_path, monkeypatch, capsys, where,
                                                                        message):
    from optdesign.model import analysis

    (tmp_path / "folder").mkdir()
    (tmp_path / "afile").write_text("x")
    monkeypatch.setattr(analysis, "analyse", lambda *a: pytest.fail("the work started"))
    path = where if where.startswith("/") else f"{tmp_path}/{where}"
    assert main(["analyse", str(JIB), "--csv", path, *ARGS]) == 2
    err = capsys.readouterr().err
    assert err.startswith("optdesign analyse: error: " + message.format(tmp=tmp_path)) and err.count("\n") == 1


def test_analyse_csv_to_a_full_disk(tmp_path, monkeypatch, capsys):
    f = tmp_path / "a.csv"
    f.write_text("old")
    monkeypatch.setattr(os, "write", failing_write(errno.ENOSPC))
    assert main(["analyse", str(JIB), "--csv", str(f), *ARGS]) == 2
    monkeypatch.undo()
    assert capsys.readouterr().err == (f"optdesign analyse: error: --csv {f}: no space left on the device: nothing "
                                       "was written (a file there is as it was); free some space or choose another "
                                       "disk\n")
    assert f.read_text() == "old" and sorted(p.name for p in tmp_path.iterdir()) == ["a.csv"]


@root_only
def test_analyse_csv_into_device_nodes(tmp_path, capsys):
    null, full = node(tmp_path / "null", stat.S_IFCHR, 1, 3), node(tmp_path / "full", stat.S_IFCHR, 1, 7)
    before = os.lstat(null), os.lstat(full)
    assert main(["analyse", str(JIB), "--csv", str(null), *ARGS]) == 0
    assert main(["analyse", str(JIB), "--csv", str(full), *ARGS]) == 2
    assert capsys.readouterr().err == (f"optdesign analyse: error: --csv {full}: no space left on the device: the "
                                       "output is incomplete; free some space or choose another disk\n")
    assert same_node(null, before[0]) and same_node(full, before[1])


@pytest.mark.parametrize("flag, name, message", [
    ("--dxf", "/proc/x.dxf", "--dxf /proc/x.dxf: is in /proc"),
    ("--svg", "/proc/x.svg", "--svg /proc/x.svg: is in /proc"),
    ("--out", "folder", "--out {tmp}/folder: is a folder"),
    ("--dxf", "afile/x.dxf", "--dxf {tmp}/afile/x.dxf: {tmp}/afile is a file, not a folder"),
])
def test_draw_to_paths_that_cannot_hold_a_file(tmp_path, capsys, flag, name, message):
    (tmp_path / "folder").mkdir()
    (tmp_path / "afile").write_text("x")
    path = name if name.startswith("/") else f"{tmp_path}/{name}"
    assert main(["draw", str(JIB), flag, path, "-q"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("optdesign draw: error: " + message.format(tmp=tmp_path)) and err.count("\n") == 1


def test_draw_through_links_and_into_a_fifo(tmp_path):
    for name in ("real.dxf", "real.png"):
        (tmp_path / name).write_text("old")
    (tmp_path / "link.dxf").symlink_to("real.dxf")
    (tmp_path / "link.png").symlink_to("real.png")
    fifo = tmp_path / "pipe.svg"
    os.mkfifo(fifo)
    reader = Reader(fifo)
    assert main(["draw", str(JIB), "--dxf", str(tmp_path / "link.dxf"), "--svg", str(fifo),
                 "--out", str(tmp_path / "link.png"), "-q"]) == 0
    assert (tmp_path / "link.dxf").is_symlink() and (tmp_path / "link.png").is_symlink()
    assert (tmp_path / "real.dxf").read_text().startswith("  0\nSECTION")
    assert (tmp_path / "real.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert reader.result().startswith(b"<svg ") and stat.S_ISFIFO(os.lstat(fifo).st_mode)


def test_draw_png_to_standard_output(capsysbinary):
    assert main(["draw", str(JIB), "--out", "-"]) == 0
    out, err = capsysbinary.readouterr()
    assert out[:8] == b"\x89PNG\r\n\x1a\n" and b"wrote standard output" in err and b"assembles" in err


def test_draw_two_files_to_standard_output_is_an_error(capsys):
    assert main(["draw", str(JIB), "--dxf", "-", "--svg", "/dev/stdout"]) == 2
    assert capsys.readouterr().err == ("optdesign draw: error: --dxf and --svg: only one file can go to standard "
                                       "output\n")


def test_animate_through_a_link_and_to_standard_output(tmp_path, capsysbinary):
    (tmp_path / "real.gif").write_text("old")
    (tmp_path / "link.gif").symlink_to("real.gif")
    assert main(["animate", str(JIB), "--out", str(tmp_path / "link.gif"), "--frames", "3", "--no-mp4", "-q"]) == 0
    assert (tmp_path / "link.gif").is_symlink() and (tmp_path / "real.gif").read_bytes()[:6] == b"GIF89a"
    assert main(["animate", str(JIB), "--out", "-", "--frames", "3"]) == 0
    out, err = capsysbinary.readouterr()
    assert out == (tmp_path / "real.gif").read_bytes() and b"3 frames over the stroke -> standard output" in err


def test_animate_to_a_full_disk(tmp_path, monkeypatch, capsys):
    from PIL import Image

    gif = tmp_path / "a.gif"
    gif.write_text("old")
    monkeypatch.setattr(os, "write", failing_write(errno.ENOSPC))
    monkeypatch.setattr(Image.Image, "save", lambda self, fp, **k: fp.write(b"GIF89a"))   # nothing else uses os.write
    assert main(["animate", str(JIB), "--out", str(gif), "--frames", "3", "--no-mp4", "-q"]) == 2
    monkeypatch.undo()
    assert capsys.readouterr().err == (f"optdesign animate: error: --out {gif}: no space left on the device: nothing "
                                       "was written (a file there is as it was); free some space or choose another "
                                       "disk\n")
    assert gif.read_text() == "old" and sorted(p.name for p in tmp_path.iterdir()) == ["a.gif"]


@root_only
def test_animate_into_a_device_named_like_a_gif(tmp_path):
    null = node(tmp_path / "a.gif", stat.S_IFCHR, 1, 3)
    before = os.lstat(null)
    assert main(["animate", str(JIB), "--out", str(null), "--frames", "3", "--no-mp4", "-q"]) == 0
    assert same_node(null, before)


def test_a_write_failure_is_an_optdesign_error_and_an_os_error():
    exc = OutputError("x: y", errno.ENOSPC, "No space left on device")
    assert isinstance(exc, OptdesignError) and isinstance(exc, OSError) and str(exc) == "x: y"
    assert exc.errno == errno.ENOSPC and exc.strerror == "No space left on device"
