"""One writer for every single output file (`analyse --csv`, `draw --out/--dxf/--svg`,
`animate --out`, and each file of a results folder): what the path names decides how it is
written, so that nothing that is not ours is ever replaced.

- A new path, or a regular file: a temporary file in the same folder, renamed onto it (atomic:
  no reader sees a half-written file, and a failure leaves the old file as it was).  A symbolic
  link is written through: the link stays, and its target is replaced the same way.
- A FIFO or a character device (`/dev/null`, a terminal): opened and written into, never
  renamed over (a FIFO waits at most ``READER_WAIT`` seconds for a reader).
- `-`, and the links to this process's own open files (`/dev/stdout`, `/dev/fd/N`,
  `/proc/self/fd/N`): written into that open file (`-` and `/dev/stdout`: standard output).
- Refused: a folder, a block device (a disk), a socket, any other path in `/proc` or `/sys`.

Every failure is an :class:`~optdesign.errors.OutputError` naming the path and what to do."""
from __future__ import annotations

import errno
import os
import re
import stat
import sys
import tempfile
import time
from pathlib import Path

from ..errors import OutputError

READER_WAIT = 30.0   # seconds a FIFO is waited for a reader
STDOUT = "standard output"


class Target:
    """Where a path's bytes go: ``how`` is 'replace' (``dest``: the regular file, through links,
    replaced atomically), 'into' (``dest``: the FIFO or character device opened), 'fd' (``fd``:
    an open file of this process, 1 for standard output)."""

    def __init__(self, shown, how, dest=None, fd=None):
        self.shown, self.how, self.dest, self.fd = shown, how, dest, fd

    @property
    def is_stdout(self) -> bool:
        return self.how == "fd" and self.fd == 1


def target(path, label="") -> Target:
    """How ``path`` will be written (checked before any work: a path that cannot be written is an
    OutputError now, not after the computation).  ``label``: the option that named it."""
    if str(path) == "-":
        return Target(STDOUT, "fd", fd=1)
    shown = f"{label} {path}".strip()
    kernel, fd = _kernel_path(path)
    if fd is not None:
        return Target(STDOUT if fd == 1 else shown, "fd", fd=fd)
    if kernel:
        raise OutputError(f"{shown}: is in {kernel}, the kernel's own files, not a place for results: choose a "
                          "path in an ordinary folder (or - for standard output)")
    try:
        st = os.stat(path)            # through links
    except FileNotFoundError:
        st = None
    except OSError as exc:
        _check_folder(Path(os.path.abspath(path)).parent, shown)    # names the file on the way
        raise _error(exc, shown, Path(path)) from None
    if st is None or stat.S_ISREG(st.st_mode):
        dest = Path(os.path.realpath(path))     # a link's target (a dangling link's is made)
        if st is None:
            _check_folder(dest.parent, shown)
        return Target(shown, "replace", dest)
    if stat.S_ISDIR(st.st_mode):
        raise OutputError(f"{shown}: is a folder: give the name of a file (e.g. {Path(path) / 'NAME'})")
    if stat.S_ISFIFO(st.st_mode) or stat.S_ISCHR(st.st_mode):
        return Target(shown, "into", Path(path))
    kind = "block device (a disk)" if stat.S_ISBLK(st.st_mode) else (
        "socket" if stat.S_ISSOCK(st.st_mode) else "special file")
    raise OutputError(f"{shown}: is a {kind}: results go to a regular file, a FIFO or a character device; "
                      "choose a file name")


def names_stdout(path) -> bool:
    """Whether ``path`` is standard output: ``-``, /dev/stdout, /dev/fd/1, /proc/self/fd/1."""
    return path is not None and (str(path) == "-" or _kernel_path(path)[1] == 1)


def write_file(path, data, label=""):
    """Write ``data`` (str, bytes, or an iterable of them) to ``path`` by the rules above;
    returns the path (``'standard output'`` for it)."""
    where = target(path, label)
    pieces = (data,) if isinstance(data, (str, bytes)) else data
    if where.how == "replace":
        return _replace(where, pieces, path)
    _write_into(where, pieces)
    return STDOUT if where.is_stdout else Path(path)


def temporary_for(path, label="", suffix="") -> str:
    """An empty temporary file where a program (ffmpeg) can write what :func:`place` then puts
    at ``path``: beside the file to be replaced, or in the temporary folder."""
    where = target(path, label)
    folder = where.dest.parent if where.how == "replace" else None
    try:
        if folder is not None:
            folder.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=folder, prefix=f".{Path(str(path)).name}.", suffix=suffix)
    except OSError as exc:
        raise _error(exc, where.shown, folder) from None
    os.close(fd)
    return tmp


def place(tmp, path, label=""):
    """Put the finished temporary file ``tmp`` (from :func:`temporary_for`) at ``path``:
    renamed onto a regular file, copied into anything else; ``tmp`` is gone afterwards."""
    where = target(path, label)
    try:
        if where.how == "replace":
            try:
                os.chmod(tmp, _mode(where.dest))
                os.replace(tmp, where.dest)
            except OSError as exc:
                raise _error(exc, where.shown, where.dest) from None
        else:
            with open(tmp, "rb") as fh:
                _write_into(where, iter(lambda: fh.read(1 << 20), b""))
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)
    return STDOUT if where.is_stdout else Path(path)


def _replace(where, pieces, path):
    dest = where.dest
    tmp = None
    try:
        dest.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=dest.parent, prefix=f".{dest.name}.", suffix=".tmp")
        try:
            _write_all(fd, pieces)
        finally:
            os.close(fd)
        os.chmod(tmp, _mode(dest))
        os.replace(tmp, dest)
    except OSError as exc:
        raise _error(exc, where.shown, dest) from None
    finally:
        if tmp is not None and os.path.exists(tmp):
            os.unlink(tmp)
    return Path(path)


def _mode(dest) -> int:
    """The old file's permissions, or those of a new file (0666 less the umask; mkstemp's 0600
    would hide results from everyone else)."""
    try:
        return stat.S_IMODE(os.stat(dest).st_mode)
    except OSError:
        umask = os.umask(0)
        os.umask(umask)
        return 0o666 & ~umask


def _write_into(where, pieces):
    """Write into a FIFO, a device or an open file of ours, never replacing it."""
    if where.fd is not None:
        for stream in (sys.stdout, sys.stderr):
            _flush(stream)
        if where.is_stdout and _has_buffer(sys.stdout):     # the Python stream (a test's capture, -q's)
            try:
                for piece in pieces:
                    sys.stdout.buffer.write(piece.encode() if isinstance(piece, str) else piece)
                sys.stdout.buffer.flush()
            except OSError as exc:
                raise _error(exc, where.shown, None, into=True) from None
            return
        fd = os.dup(where.fd)
    else:
        fd = _open_into(where)
    try:
        _write_all(fd, pieces)
    except OSError as exc:
        raise _error(exc, where.shown, None, into=True) from None
    finally:
        os.close(fd)


def _open_into(where) -> int:
    """Open a FIFO or device for writing; a FIFO without a reader is waited for, at most
    READER_WAIT seconds (a plain open would wait for ever)."""
    flags = os.O_WRONLY | os.O_NOCTTY | getattr(os, "O_CLOEXEC", 0)
    deadline = time.monotonic() + READER_WAIT
    while True:
        try:
            fd = os.open(where.dest, flags | os.O_NONBLOCK)
        except OSError as exc:
            if exc.errno == errno.ENXIO and time.monotonic() < deadline:   # a FIFO nobody reads yet
                time.sleep(0.05)
                continue
            if exc.errno == errno.ENXIO:
                raise OutputError(f"{where.shown}: is a FIFO that no reader opened within {READER_WAIT:g} s: start "
                                  "the reader first (e.g. cat FIFO &)") from None
            raise _error(exc, where.shown, where.dest) from None
        os.set_blocking(fd, True)
        return fd


def _write_all(fd, pieces):
    for piece in pieces:
        view = memoryview(piece.encode() if isinstance(piece, str) else piece)
        while view:
            view = view[os.write(fd, view):]


def _flush(stream):
    try:
        stream.flush()
    except (OSError, ValueError):
        pass


def _has_buffer(stream) -> bool:
    try:
        return stream.buffer is not None
    except AttributeError:
        return False


def _kernel_path(path):
    """('/proc' or '/sys', None) for a path in the kernel's own file systems, (None, N) for a
    link to this process's open file N (/dev/stdout, /dev/fd/N, /proc/self/fd/N), else
    (None, None).  Each link of the chain is followed one at a time: /dev/stdout of a command
    whose output goes to a file resolves to that file, which must not be replaced."""
    p = os.path.abspath(path)
    own = re.compile(rf"^/proc/(?:self|thread-self|{os.getpid()})(?:/task/\d+)?/fd/(\d+)$")
    for _ in range(40):
        head, name = os.path.split(p)
        p = os.path.join(os.path.realpath(head), name)
        mine = own.match(p)
        if mine:
            return None, int(mine.group(1))
        for kernel in ("/proc", "/sys"):
            if p == kernel or p.startswith(kernel + "/"):
                return kernel, None
        if not os.path.islink(p):
            return None, None
        p = os.path.join(head, os.readlink(p))
    return None, None


def _check_folder(folder, shown):
    """A new file's folder: it exists or can be made, and is not under a file."""
    for parent in (folder, *folder.parents):
        if os.path.lexists(parent):
            if not parent.is_dir():
                raise OutputError(f"{shown}: {parent} is a file, not a folder: choose a path in a folder")
            if not os.access(parent, os.W_OK):
                raise _error(PermissionError(errno.EACCES, os.strerror(errno.EACCES)), shown, parent)
            return


def _error(exc, shown, path, into=False) -> OutputError:
    """An OSError as one line: the path, what happened and what to do (``into``: bytes went into
    a FIFO or device before it; otherwise nothing was replaced); its errno and strerror kept."""
    code = getattr(exc, "errno", None)
    outcome = "the output is incomplete" if into else "nothing was written (a file there is as it was)"
    if code in (errno.ENOSPC, errno.EDQUOT):
        text = f"no space left on the device: {outcome}; free some space or choose another disk"
    elif code in (errno.EROFS, errno.EACCES, errno.EPERM):
        folder = "" if path is None else f" in {path if Path(path).is_dir() else Path(path).parent}"
        what = "on a read-only file system" if code == errno.EROFS else "not allowed for this user"
        text = f"writing{folder} is {what} ({exc.strerror}): choose a folder you can write to"
    elif code in (errno.ENOTDIR, errno.EEXIST):
        text = "part of the path is a file, not a folder: choose a path in a folder"
    elif code == errno.EISDIR:
        text = "is a folder: give the name of a file"
    elif code == errno.EPIPE:
        text = "the reader closed it before the end: the output is incomplete"
    else:
        text = f"{exc.strerror or exc}: {outcome}; choose another path"
    return OutputError(f"{shown}: {text}", code, getattr(exc, "strerror", None))
