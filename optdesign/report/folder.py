"""Result folders replaced as a whole: a kill at any instant leaves the old whole folder or the
new whole one, never a mix.

:func:`replace_folder` writes the new files into a temporary sibling ``.NAME.tmp-PID-XXXX``
(same parent, so same filesystem), fsyncs them, then swaps it in with one
``renameat2(RENAME_EXCHANGE)`` (Linux >= 3.15; the old folder lands on the temporary name and
is removed).  Where the exchange is not available, the old folder is renamed aside
(``.NAME.old-PID-XXXX``) and the new one renamed in: a kill between the two renames leaves no
folder at NAME, and the next replacement of NAME renames the old one back before anything else
(:func:`_clean_stale`).

What the old folder holds:

* files this command writes (``produces``) are replaced (dropped when the new run does not
  write them again, e.g. a Pareto figure of a study that now has none);
* any other plain file (a study's ``journal.jsonl``, a figure a script added) is carried into
  the new folder as a hard link, so it is the very same file (a study's journal stays the file
  its lock is on); where hard links are refused it is copied, except ``linked`` names, which
  raise :class:`NoHardLinks` (the caller then writes in place);
* a sub-folder, a link or any other entry means the folder is not a results folder: it is left
  as it is, with an error naming the entry.  So is the folder that holds the current directory.

Every completed replacement is recorded in :data:`replaced` (the command line says on Ctrl-C
whether a folder was written), and Ctrl-C during the swap is held until the swap is done.
"""
from __future__ import annotations

import contextlib
import ctypes
import errno
import os
import shutil
import signal
import tempfile
import threading
from pathlib import Path

from ..errors import OptdesignError

replaced: list = []          # folders replaced by this process, in order (for the Ctrl-C message)

_AT_FDCWD = -100
_RENAME_EXCHANGE = 2


class NoHardLinks(OptdesignError):
    """A file that must stay the same file (``linked``) cannot be hard-linked on this filesystem."""


def _why(exc: OSError) -> str:
    return exc.strerror or str(exc)


def inspect(folder, produces, label="folder") -> list:
    """The plain files of ``folder`` to carry over (names); raises :class:`OptdesignError` when
    ``folder`` cannot be replaced as a whole (a file, read-only, holding sub-folders or the
    current directory).  Touches nothing: call it before a long computation to fail early."""
    folder = Path(os.path.realpath(folder))
    try:
        st = os.stat(folder)
    except FileNotFoundError:
        _check_parent(folder, label)
        return []
    except NotADirectoryError:
        p = folder.parent
        while not p.is_dir() and p != p.parent and not p.is_file():
            p = p.parent
        raise OptdesignError(f"{label} {folder}: {p} is a file, not a folder") from None
    except OSError as exc:
        raise OptdesignError(f"{label} {folder}: {_why(exc)}") from None
    import stat as _stat

    if not _stat.S_ISDIR(st.st_mode):
        raise OptdesignError(f"{label} {folder}: is a file, not a folder (name a new folder, or one optdesign wrote)")
    cwd = os.path.realpath(os.getcwd())
    if cwd == str(folder) or cwd.startswith(str(folder).rstrip(os.sep) + os.sep):
        raise OptdesignError(f"{label} {folder}: holds the current directory; results replace their folder as a "
                             "whole, so name a folder below the current one (e.g. results/NAME)")
    if not os.access(folder, os.W_OK | os.X_OK) or not os.access(folder.parent, os.W_OK | os.X_OK):
        where = folder if not os.access(folder, os.W_OK | os.X_OK) else folder.parent
        raise OptdesignError(f"{label} {folder}: {where} is read-only (no permission to write there)")
    try:
        entries = list(os.scandir(folder))
    except OSError as exc:
        raise OptdesignError(f"{label} {folder}: cannot list it ({_why(exc)})") from None
    carry, foreign = [], []
    for e in entries:
        if _produced(e.name, produces):
            continue
        if e.is_file(follow_symlinks=False):
            carry.append(e.name)
        else:
            foreign.append(e.name + ("/" if e.is_dir(follow_symlinks=False) else ""))
    if foreign:
        shown = ", ".join(sorted(foreign)[:5]) + (", ..." if len(foreign) > 5 else "")
        raise OptdesignError(f"{label} {folder}: holds {shown}, which optdesign did not write; results replace "
                             "their folder as a whole, so name a new folder, an empty one or one optdesign wrote "
                             "(the folder was left as it was)")
    return sorted(carry)


def _check_parent(folder: Path, label):
    """A folder that does not exist yet: its nearest existing ancestor must be a writable folder."""
    p = folder.parent
    while not p.exists():
        if p.is_symlink():
            raise OptdesignError(f"{label} {folder}: {p} is a broken link")
        p = p.parent
    if not p.is_dir():
        raise OptdesignError(f"{label} {folder}: {p} is a file, not a folder")
    if not os.access(p, os.W_OK | os.X_OK):
        raise OptdesignError(f"{label} {folder}: {p} is read-only (no permission to create the folder there)")


def _produced(name, produces) -> bool:
    if name in produces:
        return True
    # a write_file temporary of a produced file, left by a killed run: ".NAME.XXXX.tmp"
    return name.startswith(".") and name.endswith(".tmp") and any(name.startswith(f".{p}.") for p in produces)


def replace_folder(folder, write, produces, linked=(), label="folder") -> list:
    """Replace ``folder`` as a whole by a new one in which ``write(tmp)`` writes its files
    (returning their paths in ``tmp``); returns those paths as they are in ``folder``.
    ``produces``: the names this command writes (old files of those names are dropped);
    ``linked``: names that must be carried as the same file (else :class:`NoHardLinks`)."""
    folder = Path(os.path.realpath(folder))
    produces = set(produces)
    carry = inspect(folder, produces, label)
    parent = folder.parent
    try:
        parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OptdesignError(f"{label} {folder}: cannot create {parent} ({_why(exc)})") from None
    _clean_stale(parent, folder.name)
    carry = inspect(folder, produces, label)   # again: _clean_stale may have restored it
    try:
        tmp = Path(tempfile.mkdtemp(dir=parent, prefix=f".{folder.name}.tmp-{os.getpid()}-"))
    except OSError as exc:
        raise OptdesignError(f"{label} {folder}: cannot write into {parent} ({_why(exc)})") from None
    swapped = False
    try:
        try:
            mode = os.stat(folder).st_mode & 0o7777
        except FileNotFoundError:
            umask = os.umask(0)
            os.umask(umask)
            mode = 0o777 & ~umask
        os.chmod(tmp, mode)
        for name in carry:
            try:
                os.link(folder / name, tmp / name, follow_symlinks=False)
            except FileNotFoundError:
                continue                      # gone meanwhile (another run replaced the folder)
            except OSError as exc:
                if name in linked:
                    raise NoHardLinks(f"{label} {folder}: cannot hard-link {name} ({_why(exc)})") from None
                shutil.copy2(folder / name, tmp / name, follow_symlinks=False)
        written = [Path(p) for p in write(tmp)]
        _fsync_files(written, tmp)             # the new files only: carried ones are not new
        with _sigint_held():
            _swap(tmp, folder)
            swapped = True
            replaced.append(folder)
            _fsync_dir(parent)
    except OSError as exc:
        raise OptdesignError(f"{label} {folder}: cannot write the results ({_why(exc)}); the folder was left "
                             "as it was") from None
    finally:
        shutil.rmtree(tmp, ignore_errors=True)   # the old folder after a swap, the unfinished new one before
    assert swapped
    return [folder / p.relative_to(tmp) for p in written]


def _swap(tmp: Path, folder: Path):
    """Put ``tmp`` at ``folder``; afterwards ``tmp`` holds the old folder (or nothing)."""
    while True:
        if not folder.exists():
            try:
                os.rename(tmp, folder)       # onto nothing, or onto an empty folder made meanwhile
                return
            except OSError as exc:
                if exc.errno not in (errno.ENOTEMPTY, errno.EEXIST):
                    raise
        if _exchange(tmp, folder):
            return
        old = Path(tempfile.mkdtemp(dir=folder.parent, prefix=f".{folder.name}.old-{os.getpid()}-"))
        os.rmdir(old)
        os.rename(folder, old)
        try:
            os.rename(tmp, folder)
        except BaseException:
            os.rename(old, folder)
            raise
        os.rename(old, tmp) if not tmp.exists() else shutil.rmtree(old, ignore_errors=True)
        return


_libc = None


def _exchange(a: Path, b: Path) -> bool:
    """Atomically exchange two paths (renameat2 RENAME_EXCHANGE); False where unsupported."""
    global _libc
    if _libc is None:
        try:
            _libc = ctypes.CDLL(None, use_errno=True)
            _libc.renameat2  # noqa: B018  (AttributeError where libc has no renameat2)
        except (OSError, AttributeError):
            _libc = False
    if _libc is False:
        return False
    r = _libc.renameat2(_AT_FDCWD, os.fsencode(a), _AT_FDCWD, os.fsencode(b), _RENAME_EXCHANGE)
    if r == 0:
        return True
    err = ctypes.get_errno()
    if err in (errno.ENOSYS, errno.EINVAL, errno.ENOTSUP, errno.EOPNOTSUPP):
        return False
    raise OSError(err, os.strerror(err), str(b))


def _clean_stale(parent: Path, name: str):
    """Temporaries of ``name`` left by killed runs: an old folder renamed aside is renamed back
    when ``name`` is missing, everything else is removed.  Only those of dead processes."""
    try:
        entries = list(os.scandir(parent))
    except OSError:
        return
    for e in entries:
        for kind in ("old", "tmp"):
            prefix = f".{name}.{kind}-"
            if not e.name.startswith(prefix):
                continue
            pid = e.name[len(prefix):].partition("-")[0]
            if not pid.isdigit() or _alive(int(pid)):
                continue
            target = parent / name
            if kind == "old" and not target.exists():
                with contextlib.suppress(OSError):
                    os.rename(e.path, target)
                    continue
            shutil.rmtree(e.path, ignore_errors=True)


def _alive(pid: int) -> bool:
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def _fsync_files(paths, folder: Path):
    for path in paths:
        try:
            fd = os.open(path, os.O_RDONLY)
        except OSError:
            continue
        try:
            os.fsync(fd)
        finally:
            os.close(fd)
    _fsync_dir(folder)


def _fsync_dir(folder: Path):
    with contextlib.suppress(OSError):
        fd = os.open(folder, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)


@contextlib.contextmanager
def _sigint_held():
    """Ctrl-C during the swap takes effect when it is done (as a KeyboardInterrupt)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    pressed = []
    previous = signal.signal(signal.SIGINT, lambda *a: pressed.append(1))
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
    if pressed:
        if callable(previous):
            previous(signal.SIGINT, None)     # Python's own handler raises KeyboardInterrupt
        elif previous == signal.SIG_DFL:
            raise KeyboardInterrupt


__all__ = ["replace_folder", "inspect", "replaced", "NoHardLinks"]
